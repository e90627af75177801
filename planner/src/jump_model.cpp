#include "planner/jump_model.h"

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace wj::planner {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kInvalidCost = 1e16;
// 10^n, exact, for the penalty's 10^(n+3) and 10^n with priorities n <= 10.
constexpr std::array<double, 14> kPow10 = {1e0, 1e1, 1e2, 1e3,  1e4,  1e5,  1e6,
                                           1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13};
// Fixed-point steps for the posture-dependent CoM offset per sample, warm-started from the
// previous sample (the contraction factor is the legs' mass fraction, ~0.35), plus a final pass.
constexpr int kCoMIterations = 1;
// ... and, where a sample must be converged, at most this many, to this step [m] (1e-8 m at
// the hip is ~5e-8 rad at the joints).
constexpr int kCoMMaxIterations = 50;
constexpr double kCoMTolerance = 1e-7;

// Fixed-capacity polynomial in ascending powers: allocation-free for the DE's hot path.
struct Poly {
  static constexpr int kCap = 14;
  std::array<double, kCap> c{};
  int n = 0;  // number of coefficients in use

  Poly() = default;
  Poly(std::initializer_list<double> coeffs) {
    for (double v : coeffs) c[n++] = v;
  }
  double operator()(double t) const {
    double v = 0.0;
    for (int i = n - 1; i >= 0; --i) v = v * t + c[i];
    return v;
  }
};

Poly operator+(const Poly& p, const Poly& q) {
  Poly r;
  r.n = std::max(p.n, q.n);
  for (int i = 0; i < p.n; ++i) r.c[i] += p.c[i];
  for (int i = 0; i < q.n; ++i) r.c[i] += q.c[i];
  return r;
}
Poly operator*(double s, const Poly& p) {
  Poly r = p;
  for (int i = 0; i < r.n; ++i) r.c[i] *= s;
  return r;
}
Poly operator*(const Poly& p, const Poly& q) {
  Poly r;
  if (p.n == 0 || q.n == 0) return r;
  r.n = std::min(p.n + q.n - 1, Poly::kCap);
  for (int i = 0; i < p.n; ++i)
    for (int j = 0; j < q.n && i + j < Poly::kCap; ++j) r.c[i + j] += p.c[i] * q.c[j];
  return r;
}
Poly integral(const Poly& p, double c0 = 0.0) {
  Poly r;
  r.n = std::min(p.n + 1, Poly::kCap);
  r.c[0] = c0;
  for (int i = 0; i + 1 < r.n; ++i) r.c[i + 1] = p.c[i] / (i + 1);
  return r;
}
Poly derivative(const Poly& p) {
  Poly r;
  r.n = std::max(p.n - 1, 0);
  for (int i = 1; i < p.n; ++i) r.c[i - 1] = p.c[i] * i;
  return r;
}

Polynomial toPolynomial(const Poly& p) {
  return Polynomial{{p.c.begin(), p.c.begin() + p.n}};
}

// Rotation of body-frame x-z vectors by pitch (nose-up positive): R = [[c, -s], [s, c]].
// Built once per sample so that the trigonometry is not repeated for every point.
struct Rot2 {
  double c = 1.0, s = 0.0;
  Rot2() = default;
  explicit Rot2(double pitch) : c(std::cos(pitch)), s(std::sin(pitch)) {}
  Eigen::Vector2d operator*(const Eigen::Vector2d& v) const {
    return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
  }
  Eigen::Vector2d transposeTimes(const Eigen::Vector2d& v) const {
    return {c * v.x() + s * v.y(), -s * v.x() + c * v.y()};
  }
};
Eigen::Vector2d rot(double pitch, const Eigen::Vector2d& v) {
  return Rot2(pitch) * v;
}

double wrapToPi(double a) {
  return std::remainder(a, 2.0 * M_PI);
}

double smoothstep(double xi) {
  xi = std::clamp(xi, 0.0, 1.0);
  return xi * xi * (3.0 - 2.0 * xi);
}
double smoothstepRate(double xi) {
  return (xi <= 0.0 || xi >= 1.0) ? 0.0 : 6.0 * xi * (1.0 - xi);
}

// Signed distance from point p to the obstacle box [x_min, x_max] x [0, height] (x-z).
double boxDistance(const BoxObstacle& box, const Eigen::Vector2d& p) {
  const double dx = std::max({box.x_min - p.x(), 0.0, p.x() - box.x_max});
  const double dz = std::max(p.y() - box.height, 0.0);
  if (dx == 0.0 && dz == 0.0)
    return -std::min({p.x() - box.x_min, box.x_max - p.x(), box.height - p.y()});
  return std::sqrt(dx * dx + dz * dz);  // not std::hypot: 10x slower, no overflow risk here
}

// One axis (x or z) of the take-off: force polynomials from sampled positions. Accelerations
// are F/m - g; phase 1 force affine in t, phase 2 force quadratic in tau = t - t1.
struct AxisSolution {
  Poly F1, F2;  // force [N]
  Poly P1, P2;  // position [m]
};

bool solveAxis(double m, double g, double p0, double v0, bool two_step, double t1, double T2,
               double pm, double pe, double ve, AxisSolution& out) {
  if (!two_step) {
    // x(T) = pe and xdot(T) = ve with F = a0 + a1 t (docs/planner.md, Eq. S1).
    const double T = t1;
    Eigen::Matrix2d A;
    A << T * T / 2, T * T * T / 6, T, T * T / 2;
    const Eigen::Vector2d b(m * (pe - p0 - v0 * T + g * T * T / 2), m * (ve - v0 + g * T));
    const double det = A.determinant();
    if (!(std::abs(det) > 1e-14)) return false;
    const Eigen::Vector2d a = A.inverse() * b;
    out.F1 = {a[0], a[1]};
    out.F2 = {};
    out.P1 = {p0, v0, a[0] / (2 * m) - g / 2, a[1] / (6 * m)};
    out.P2 = {};
    return true;
  }
  // Two-step (Eq. S2): unknowns a0..a4, F1 = a0 + a1 t, F2 = a2 + a3 tau + a4 tau^2.
  const double h = t1 / 2, T = t1 + T2;
  Eigen::Matrix<double, 5, 5> A = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 1> b;
  A.row(0) << h * h / 2, h * h * h / 6, 0, 0, 0;  // x(t1/2) = pm
  b[0] = m * (pm - p0 - v0 * h + g * h * h / 2);
  A.row(1) << -1, -t1, 1, 0, 0;  // F continuous at t1 (the front force is 0 there)
  b[1] = 0;
  A.row(2) << 0, -1, 0, 1, 0;  // dF/dt continuous at t1
  b[2] = 0;
  A.row(3) << t1 * t1 / 2 + t1 * T2, t1 * t1 * t1 / 6 + t1 * t1 * T2 / 2, T2 * T2 / 2,
      T2 * T2 * T2 / 6, T2 * T2 * T2 * T2 / 12;  // x(t2) = pe
  b[3] = m * (pe - p0 - v0 * T + g * T * T / 2);
  A.row(4) << t1, t1 * t1 / 2, T2, T2 * T2 / 2, T2 * T2 * T2 / 3;  // xdot(t2) = ve
  b[4] = m * (ve - v0 + g * T);
  const Eigen::PartialPivLU<Eigen::Matrix<double, 5, 5>> lu(A);
  if (!(std::abs(lu.determinant()) > 1e-18)) return false;
  const Eigen::Matrix<double, 5, 1> a = lu.solve(b);
  out.F1 = {a[0], a[1]};
  out.F2 = {a[2], a[3], a[4]};
  out.P1 = {p0, v0, a[0] / (2 * m) - g / 2, a[1] / (6 * m)};
  const double p1 = out.P1(t1), v1 = derivative(out.P1)(t1);
  out.P2 = {p1, v1, a[2] / (2 * m) - g / 2, a[3] / (6 * m), a[4] / (12 * m)};
  return true;
}

}  // namespace

/// The solved take-off: every polynomial of the trajectory.
struct Solved {
  bool two_step = false;
  double t1 = 0, T2 = 0, t2 = 0, Tf = 0, t3 = 0;
  Poly X1, Z1, P1, VX1, VZ1, W1;  // phase 1, in t
  Poly fHx1, fHz1, fFx1, fFz1;    // pair forces, phase 1
  Poly X2, Z2, P2, VX2, VZ2, W2;  // phase 2, in tau = t - t1
  Poly fHx2, fHz2;                // hind forces, phase 2
  Poly dH2, ddH2;                 // hind axle offset from the CoM and its rate, phase 2
  PlanarState mid, takeoff, touchdown;
  Eigen::Vector2d front_b_t1 = Eigen::Vector2d::Zero();  // front axle rel. HFE at t1 (body)
  double front_wheel_rate_t1 = 0.0;
  LegPose front_pose_t1;  // inversePose(front_b_t1), and its reach margin
  double front_reach_t1 = 0.0;
  // Take-off posture and wheel rates (hind, front), and the flight attitude table: pitch and
  // pitch rate at t2 + Tf k / n_flight from the conservation of angular momentum with the legs
  // moving (docs/planner.md, "Flight").
  std::array<Eigen::Vector2d, 2> q_to{}, qd_to{};
  Eigen::Vector2d c_to = Eigen::Vector2d::Zero();  // CoM in the base at take-off
  std::array<double, 2> wheel_to{};
  int n_flight = 0;
  std::array<double, 257> flight_pitch{}, flight_rate{};
  // The legs' (HFE, KFE) per pair and the CoM in the base at the same flight instants.
  std::array<std::array<Eigen::Vector2d, 257>, 2> flight_q{};
  std::array<Eigen::Vector2d, 257> flight_c{};
};

/// Kinematics and statics of one wheel pair at one instant (left leg; right is mirrored).
struct PairSample {
  bool contact = false;
  Eigen::Vector2d q = Eigen::Vector2d::Zero();     // HFE, KFE [rad]
  Eigen::Vector2d qd = Eigen::Vector2d::Zero();    // [rad/s]
  Eigen::Vector2d tau = Eigen::Vector2d::Zero();   // HFE, KFE [Nm]
  double haa_fz = 0.0;                             // body-z force per wheel, for the HAA torque [N]
  double wheel_rate = 0.0;                         // wheel joint speed [rad/s]
  double wheel_tau = 0.0;                          // [Nm]
  Eigen::Vector2d f = Eigen::Vector2d::Zero();     // ground force per wheel, J frame [N]
  Eigen::Vector2d axle = Eigen::Vector2d::Zero();  // axle position in J [m]
  double reach = 0.0;                              // reach margin [m]
};

struct Sample {
  double t = 0.0;
  double t1 = 0.0;                              // end of the four-wheel phase
  Eigen::Vector2d c = Eigen::Vector2d::Zero();  // CoM in the base frame (x-z)
  PlanarState s;
  Rot2 R;  // of s.pitch
  PairSample hind, front;
  // What the posture half of a sample (contactPosture) leaves for its statics half: the phase,
  // the time in it, the poses without angles, the axles relative to the CoM (base frame) and
  // the hind axle's speed.
  bool phase2 = false;
  double local = 0.0;
  LegPose pose_h, pose_f;
  Eigen::Vector2d rel_h = Eigen::Vector2d::Zero(), rel_f = Eigen::Vector2d::Zero();
  double hind_axle_vx = 0.0;
};

namespace {
using Joints = Eigen::Matrix<double, model::kNumJoints, 1>;

// One instant of the references, except the wheel joint angles, which the caller integrates
// from the wheel rates.
struct PlanRow {
  PlanarState s;
  Joints q = Joints::Zero(), qd = Joints::Zero(), tau = Joints::Zero();
};

enum class Segment { FourWheels, HindOnly, Flight };

constexpr std::array<int, model::kNumLegs> kWheelJoints = {
    model::jointIndex(model::Leg::LF, model::JointKind::Wheel),
    model::jointIndex(model::Leg::RF, model::JointKind::Wheel),
    model::jointIndex(model::Leg::LH, model::JointKind::Wheel),
    model::jointIndex(model::Leg::RH, model::JointKind::Wheel)};

Segment segmentAt(const Solved& S, double t) {
  if (t > S.t2) return Segment::Flight;
  return S.two_step && t > S.t1 ? Segment::HindOnly : Segment::FourWheels;
}
}  // namespace

struct JumpModelAccess {
  // Solves the take-off for candidate u and, with `flight`, its converged posture at take-off
  // and the flight attitude (otherwise solveTakeoffPosture() and solveFlight() complete S
  // later). Returns false if u has no valid trajectory.
  static bool solve(const JumpModel& M, const Eigen::Ref<const Eigen::VectorXd>& u, Solved& S,
                    bool flight = true) {
    const auto& st = M.settings_;
    const PlanarState& s0 = M.initial_;
    const double m = M.mass_, g = st.gravity, I = M.inertia_;
    S.two_step = M.task_.mode == TakeoffMode::TwoStep;
    S.t1 = u[kT1];
    S.T2 = S.two_step ? u[kT2MinusT1] : 0.0;
    S.t2 = S.t1 + S.T2;
    if (!(S.t1 > 0.0) || !(S.T2 >= 0.0)) return false;
    const double v0 = s0.vx;
    const double xm = v0 * S.t1 / 2 + u[kMidDx], zm = s0.z + u[kMidDz],
                 pm = s0.pitch + u[kMidDpitch];
    const double xe = v0 * S.t2 + u[kTakeoffDx], ze = s0.z + u[kTakeoffDz],
                 pe = s0.pitch + u[kTakeoffDpitch];
    const double vxe = v0 + u[kTakeoffDvx], vze = u[kTakeoffVz], we = u[kTakeoffRate];

    AxisSolution ax, az;
    if (!solveAxis(m, 0.0, s0.x, s0.vx, S.two_step, S.t1, S.T2, xm, xe, vxe, ax)) return false;
    if (!solveAxis(m, g, s0.z, s0.vz, S.two_step, S.t1, S.T2, zm, ze, vze, az)) return false;
    S.X1 = ax.P1;
    S.Z1 = az.P1;
    S.X2 = ax.P2;
    S.Z2 = az.P2;

    // Pitch (Eq. S3): I theta'' = d_H Fz + (d_F - d_H) f_Fz + z Fx about the CoM.
    const double dH = M.d_hind_, dd = M.d_front_ - M.d_hind_;
    const Poly A1 = dH * az.F1 + S.Z1 * ax.F1;
    const Poly IA1 = integral(A1), IIA1 = integral(IA1);
    Poly fFz1;
    if (!S.two_step) {
      const double T = S.t1;
      Eigen::Matrix2d A;
      A << dd * T * T / 2, dd * T * T * T / 6, dd * T, dd * T * T / 2;
      const Eigen::Vector2d b(I * (pe - s0.pitch - s0.pitch_rate * T) - IIA1(T),
                              I * (we - s0.pitch_rate) - IA1(T));
      if (!(std::abs(A.determinant()) > 1e-14)) return false;
      const Eigen::Vector2d c = A.inverse() * b;
      fFz1 = {c[0], c[1]};
      S.P1 = integral(integral((1.0 / I) * (A1 + dd * fFz1), s0.pitch_rate), s0.pitch);
    } else {
      const double t1 = S.t1, T2 = S.T2, h = t1 / 2;
      const Poly B1 = {-dd * t1, dd};  // (d_F - d_H)(t - t1): the front force vanishes at t1
      const Poly IB1 = integral(B1), IIB1 = integral(IB1);
      const Poly A2 = dH * az.F2 + S.Z2 * ax.F2;
      const Poly tau1 = {0.0, 1.0}, tau2 = {0.0, 0.0, 1.0};
      const Poly C1 = tau1 * az.F2, C2 = tau2 * az.F2;
      const Poly IA2 = integral(A2), IIA2 = integral(IA2);
      const Poly IC1 = integral(C1), IIC1 = integral(IC1);
      const Poly IC2 = integral(C2), IIC2 = integral(IC2);
      Eigen::Matrix3d A;
      Eigen::Vector3d b;
      A.row(0) << IIB1(h), 0, 0;
      b[0] = I * (pm - s0.pitch - s0.pitch_rate * h) - IIA1(h);
      A.row(1) << IIB1(t1) + IB1(t1) * T2, IIC1(T2), IIC2(T2);
      b[1] = I * (pe - s0.pitch - s0.pitch_rate * (t1 + T2)) - IIA1(t1) - IA1(t1) * T2 - IIA2(T2);
      A.row(2) << IB1(t1), IC1(T2), IC2(T2);
      b[2] = I * (we - s0.pitch_rate) - IA1(t1) - IA2(T2);
      const Eigen::PartialPivLU<Eigen::Matrix3d> lu(A);
      if (!(std::abs(lu.determinant()) > 1e-18)) return false;
      const Eigen::Vector3d k = lu.solve(b);
      fFz1 = k[0] * Poly{-t1, 1.0};
      S.P1 = integral(integral((1.0 / I) * (A1 + k[0] * B1), s0.pitch_rate), s0.pitch);
      const double th1 = S.P1(t1), w1 = derivative(S.P1)(t1);
      S.P2 = integral(integral((1.0 / I) * (A2 + k[1] * C1 + k[2] * C2), w1), th1);
      S.dH2 = {dH, k[1], k[2]};
      S.ddH2 = derivative(S.dH2);
      S.fHx2 = ax.F2;
      S.fHz2 = az.F2;
    }
    // Horizontal split: the front pair takes the same ratio of horizontal to normal force as
    // the whole robot over phase 1 (it does not enter the dynamics: both contacts are at z = 0).
    const Poly IFz = integral(az.F1), IFx = integral(ax.F1);
    const double impulse_z = IFz(S.t1);
    if (!(impulse_z > 0.0)) return false;
    const double kappa = IFx(S.t1) / impulse_z;
    S.fFz1 = fFz1;
    S.fFx1 = kappa * fFz1;
    S.fHz1 = az.F1 + (-1.0) * fFz1;
    S.fHx1 = ax.F1 + (-1.0) * S.fFx1;

    S.VX1 = derivative(S.X1);
    S.VZ1 = derivative(S.Z1);
    S.W1 = derivative(S.P1);
    S.VX2 = derivative(S.X2);
    S.VZ2 = derivative(S.Z2);
    S.W2 = derivative(S.P2);
    S.mid = stateAt(M, S, S.t1 / 2, g);
    S.takeoff = stateAt(M, S, S.t2, g);

    // Flight: ballistic CoM, constant pitch rate; t3 is when the CoM descends to the landing
    // height (the touchdown target height, or the landing posture's standing height).
    const double z_td =
        M.task_.target.event == TargetEvent::Touchdown ? M.task_.target.height : M.z_land_;
    const double disc = S.takeoff.vz * S.takeoff.vz + 2 * g * (S.takeoff.z - z_td);
    if (!(disc >= 0.0)) return false;
    S.Tf = (S.takeoff.vz + std::sqrt(disc)) / g;
    if (!(S.Tf > 1e-3)) return false;
    S.t3 = S.t2 + S.Tf;
    if (S.two_step) {
      Sample smp;
      // The front legs hold their t1 posture relative to the body once lifted.
      contactSample(M, S, S.t1, smp, /*phase2=*/false, M.c0_, /*converge=*/true);
      S.front_b_t1 = M.leg_.forward(smp.front.q);
      S.front_wheel_rate_t1 = smp.front.wheel_rate;
      S.front_pose_t1 = M.leg_.inversePose(S.front_b_t1, &S.front_reach_t1);
    }
    if (flight) {
      solveTakeoffPosture(M, S);
      solveFlight(M, S);
    }
    return true;
  }

  // The converged posture at take-off (q_to, c_to, qd_to, wheel_to) of a solved take-off, which
  // the flight needs (and the FromTakeoff chain).
  static void solveTakeoffPosture(const JumpModel& M, Solved& S) {
    Sample smp;
    contactSample(M, S, S.t2, smp, S.two_step, M.c0_, /*converge=*/true);
    S.q_to = {smp.hind.q, smp.front.q};
    S.c_to = smp.c;
    S.qd_to = {smp.hind.qd, smp.front.qd};
    S.wheel_to = {smp.hind.wheel_rate, smp.front.wheel_rate};
  }

  // The flight attitude and the touchdown state of a solved take-off.
  static void solveFlight(const JumpModel& M, Solved& S) {
    integrateFlightAttitude(M, S);
    S.touchdown = stateAt(M, S, S.t3, M.settings_.gravity);
  }

  // The target's position terms of the target cost (dx and height over their tolerances,
  // squared): the ballistic CoM gives them before the flight attitude is known. The same
  // arithmetic as targetErrors() and the cost, so it never exceeds the full target cost.
  static double targetPositionCost(const JumpModel& M, const Solved& S) {
    const auto& tgt = M.task_.target;
    const auto& st = M.settings_;
    const double g = st.gravity;
    const bool apex = tgt.event == TargetEvent::Apex;
    const double t_apex = std::max(S.takeoff.vz / g, 0.0);
    const PlanarState at = ballisticG(S.takeoff, apex ? (S.t2 + t_apex) - S.t2 : S.t3 - S.t2, g);
    const double e0 = at.x - M.initial_.x - tgt.dx;
    const double e1 = apex ? at.z - tgt.height : 0.0;
    return std::pow(e0 / st.tolerance_dx_m, 2) + std::pow(e1 / st.tolerance_height_m, 2);
  }

  // Pitch inertia of the whole robot about its CoM, and the angular momentum of the legs'
  // motion relative to the base (both about +y of the base), for the pairs' postures q and
  // rates qd. The wheels count as point masses on their axles: in flight they spin freely, so
  // their spin momentum stays with them and exchanges nothing with the body.
  static void flightMomentum(const JumpModel& M, const std::array<Eigen::Vector2d, 2>& q,
                             const std::array<Eigen::Vector2d, 2>& qd, double& i_total, double& h,
                             Eigen::Vector2d* com_in_base = nullptr) {
    auto cross = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
      return a.y() * b.x() - a.x() * b.y();  // y component of (a_x, 0, a_z) x (b_x, 0, b_z)
    };
    const double l1 = M.leg_.l1;
    std::array<Eigen::Vector2d, 4> p, v;  // thigh and lower CoMs of each pair, and rates
    std::array<double, 4> m{}, i{}, w{};
    Eigen::Vector2d first = M.moment_fixed_, rate = Eigen::Vector2d::Zero();
    for (int pair = 0; pair < 2; ++pair) {
      const JumpModel::Geometry& g = pair == 0 ? M.hind_ : M.front_;
      const double s1 = std::sin(q[pair][0]), c1 = std::cos(q[pair][0]);
      const double s12 = std::sin(q[pair][0] + q[pair][1]), c12 = std::cos(q[pair][0] + q[pair][1]);
      const Eigen::Vector2d knee(-l1 * s1, -l1 * c1);
      const Eigen::Vector2d dknee(-l1 * c1, l1 * s1);
      p[2 * pair] = g.hfe_b + Rv(s1, c1, g.c_thigh);
      v[2 * pair] = dRv(s1, c1, g.c_thigh) * qd[pair][0];
      p[2 * pair + 1] = g.hfe_b + knee + Rv(s12, c12, g.c_lower);
      v[2 * pair + 1] =
          dknee * qd[pair][0] + dRv(s12, c12, g.c_lower) * (qd[pair][0] + qd[pair][1]);
      m[2 * pair] = 2.0 * g.m_thigh;
      m[2 * pair + 1] = 2.0 * g.m_lower;
      i[2 * pair] = 2.0 * g.i_thigh;
      i[2 * pair + 1] = 2.0 * g.i_lower;
      w[2 * pair] = qd[pair][0];
      w[2 * pair + 1] = qd[pair][0] + qd[pair][1];
    }
    for (int k = 0; k < 4; ++k) {
      first += m[k] * p[k];
      rate += m[k] * v[k];
    }
    const Eigen::Vector2d c = first / M.mass_, c_dot = rate / M.mass_;
    if (com_in_base) *com_in_base = c;
    const Eigen::Vector2d c_fixed = M.moment_fixed_ / M.mass_fixed_;
    i_total = M.i_fixed_ + M.mass_fixed_ * (c_fixed - c).squaredNorm();
    h = M.mass_fixed_ * cross(c_fixed - c, -c_dot);
    for (int k = 0; k < 4; ++k) {
      i_total += i[k] + m[k] * (p[k] - c).squaredNorm();
      h += i[k] * w[k] + m[k] * cross(p[k] - c, v[k] - c_dot);
    }
  }

  // Wheel joint rate of a pair in flight: from its take-off rate towards the ground speed it
  // will meet at touchdown, done by the end of the legs' landing extension.
  static double flightWheelRate(const JumpModel& M, const Solved& S, int pair, double t) {
    const double xi = (t - S.t2) / (M.settings_.extend_end_fraction * S.Tf);
    return S.wheel_to[pair] + (S.takeoff.vx / M.wheel_radius_ - S.wheel_to[pair]) * smoothstep(xi);
  }

  // Flight attitude: the total angular momentum about the CoM is conserved from the lift-off
  // on. It is taken from the take-off kinematics the joint controllers track (body pitch rate,
  // legs still extending, wheels spinning): when the legs stop and tuck, their momentum goes
  // into the body. The body's pitch rate follows, and is integrated (trapezoid).
  static void integrateFlightAttitude(const JumpModel& M, Solved& S) {
    const int n = M.settings_.samples_flight;
    S.n_flight = n;
    double i_to = 0.0, h_to = 0.0;
    flightMomentum(M, S.q_to, S.qd_to, i_to, h_to);
    const double h_y = -i_to * S.takeoff.pitch_rate + h_to;
    double prev_rate = 0.0;
    for (int k = 0; k <= n; ++k) {
      const double t = S.t2 + S.Tf * k / n;
      std::array<Eigen::Vector2d, 2> q, qd;
      for (int pair = 0; pair < 2; ++pair)
        q[pair] = flightPosture(M, S, S.q_to[pair], t, &qd[pair]);
      double i_total = 0.0, h = 0.0;
      flightMomentum(M, q, qd, i_total, h, &S.flight_c[k]);
      S.flight_q[0][k] = q[0];
      S.flight_q[1][k] = q[1];
      const double rate = -(h_y - h) / i_total;  // nose-up = about -y
      S.flight_rate[k] = rate;
      S.flight_pitch[k] =
          k == 0 ? S.takeoff.pitch : S.flight_pitch[k - 1] + 0.5 * (prev_rate + rate) * S.Tf / n;
      prev_rate = rate;
    }
  }

  // The state in flight: ballistic CoM, attitude from the table (cubic Hermite).
  static PlanarState flightState(const JumpModel& M, const Solved& S, double t) {
    PlanarState s = ballisticG(S.takeoff, t - S.t2, M.settings_.gravity);
    const double u = std::clamp((t - S.t2) / S.Tf, 0.0, 1.0) * S.n_flight;
    const int k = std::min(static_cast<int>(u), S.n_flight - 1);
    const double a = u - k, dt = S.Tf / S.n_flight;
    const double h00 = 2 * a * a * a - 3 * a * a + 1, h10 = a * a * a - 2 * a * a + a;
    const double h01 = -2 * a * a * a + 3 * a * a, h11 = a * a * a - a * a;
    s.pitch = h00 * S.flight_pitch[k] + h10 * dt * S.flight_rate[k] + h01 * S.flight_pitch[k + 1] +
              h11 * dt * S.flight_rate[k + 1];
    s.pitch_rate = (1 - a) * S.flight_rate[k] + a * S.flight_rate[k + 1];
    return s;
  }

  static PlanarState stateAt(const JumpModel& M, const Solved& S, double t, double g) {
    if (t > S.t2 && S.n_flight > 0) return flightState(M, S, t);
    PlanarState s;
    if (t <= S.t1 || !S.two_step) {
      const double tc = std::min(t, S.t1);
      s = {S.X1(tc), S.Z1(tc), S.P1(tc), S.VX1(tc), S.VZ1(tc), S.W1(tc)};
      if (!S.two_step && t > S.t1) s = ballisticG(s, t - S.t1, g);
    } else {
      const double tau = std::min(t, S.t2) - S.t1;
      s = {S.X2(tau), S.Z2(tau), S.P2(tau), S.VX2(tau), S.VZ2(tau), S.W2(tau)};
    }
    if (S.two_step && t > S.t2) s = ballisticG(s, t - S.t2, g);
    return s;
  }

  static PlanarState ballisticG(const PlanarState& s, double dt, double g) {
    PlanarState r = s;
    r.x += s.vx * dt;
    r.z += s.vz * dt - 0.5 * g * dt * dt;
    r.vz -= g * dt;
    r.pitch += s.pitch_rate * dt;
    return r;
  }

  // R_y(q) v = (c x + s z, -s x + c z) and its derivative (-s x + c z, -c x - s z).
  static Eigen::Vector2d Rv(double sn, double cs, const Eigen::Vector2d& v) {
    return Eigen::Vector2d(cs * v.x() + sn * v.y(), -sn * v.x() + cs * v.y());
  }
  static Eigen::Vector2d dRv(double sn, double cs, const Eigen::Vector2d& v) {
    return Eigen::Vector2d(-sn * v.x() + cs * v.y(), -cs * v.x() - sn * v.y());
  }

  // The CoM in the base frame for the pairs' poses.
  static Eigen::Vector2d comOffset(const JumpModel& M, const LegPose& hind, const LegPose& front) {
    Eigen::Vector2d first = M.moment_fixed_;
    const double l1 = M.leg_.l1;
    for (int pair = 0; pair < 2; ++pair) {
      const LegPose& P = pair == 0 ? hind : front;
      const JumpModel::Geometry& g = pair == 0 ? M.hind_ : M.front_;
      const Eigen::Vector2d knee(-l1 * P.s1, -l1 * P.c1);
      first += 2.0 * (g.m_thigh * (g.hfe_b + Rv(P.s1, P.c1, g.c_thigh)) +
                      g.m_lower * (g.hfe_b + knee + Rv(P.s12, P.c12, g.c_lower)));
    }
    return first / M.mass_;
  }

  // Its Jacobians d c / d q_pair with respect to each pair's (HFE, KFE): pair 0 hind, 1 front.
  static std::array<Eigen::Matrix2d, 2> comJacobians(const JumpModel& M, const LegPose& hind,
                                                     const LegPose& front) {
    std::array<Eigen::Matrix2d, 2> C;
    const double l1 = M.leg_.l1;
    for (int pair = 0; pair < 2; ++pair) {
      const LegPose& P = pair == 0 ? hind : front;
      const JumpModel::Geometry& g = pair == 0 ? M.hind_ : M.front_;
      const Eigen::Vector2d dknee(-l1 * P.c1, l1 * P.s1);
      C[pair].col(0) = 2.0 / M.mass_ *
                       (g.m_thigh * dRv(P.s1, P.c1, g.c_thigh) +
                        g.m_lower * (dknee + dRv(P.s12, P.c12, g.c_lower)));
      C[pair].col(1) = 2.0 / M.mass_ * g.m_lower * dRv(P.s12, P.c12, g.c_lower);
    }
    return C;
  }

  static LegPose poseOf(const Eigen::Vector2d& q) {
    LegPose p;
    p.q = q;
    p.s1 = std::sin(q[0]);
    p.c1 = std::cos(q[0]);
    p.s12 = std::sin(q[0] + q[1]);
    p.c12 = std::cos(q[0] + q[1]);
    return p;
  }

  // Kinematics and statics of both pairs at time t of the take-off. The wheel axles are where
  // the contact model puts them; the base follows from the CoM and the posture-dependent CoM
  // offset c(q), found by a fixed-point iteration warm-started from `c_guess`.
  // With `converge`, the iteration runs to convergence instead of one warm-started step (the
  // constraint sweeps, whose consecutive samples are close, take one step; the take-off posture
  // and the plan's references must not depend on where the iteration started).
  static void contactSample(const JumpModel& M, const Solved& S, double t, Sample& out, bool phase2,
                            const Eigen::Vector2d& c_guess, bool converge = false) {
    contactPosture(M, S, t, out, phase2, c_guess, converge);
    contactStatics(M, S, out);
  }

  // The first half of contactSample: the state, the axles, the CoM offset out.c and the poses
  // (sines and cosines only, but for the front pair's fixed phase-2 pose). What the next
  // sample's warm start needs, and no more.
  static void contactPosture(const JumpModel& M, const Solved& S, double t, Sample& out,
                             bool phase2, const Eigen::Vector2d& c_guess, bool converge) {
    out.t = t;
    out.t1 = S.t1;
    out.phase2 = phase2;
    PlanarState s;
    double dH = M.d_hind_, dHdot = 0.0;
    const double local = phase2 ? t - S.t1 : t;
    out.local = local;
    if (!phase2) {
      s = {S.X1(t), S.Z1(t), S.P1(t), S.VX1(t), S.VZ1(t), S.W1(t)};
    } else {
      s = {S.X2(local), S.Z2(local), S.P2(local), S.VX2(local), S.VZ2(local), S.W2(local)};
      dH = S.dH2(local);
      dHdot = S.ddH2(local);
    }
    out.s = s;
    const double r = M.wheel_radius_;
    out.R = Rot2(s.pitch);
    const Rot2& R = out.R;
    const Eigen::Vector2d com(s.x, s.z);
    // Axle positions relative to the CoM in the base frame.
    auto relative = [&](const Eigen::Vector2d& axle) { return R.transposeTimes(axle - com); };
    PairSample& H = out.hind;
    PairSample& F = out.front;
    H = PairSample{};
    F = PairSample{};
    H.contact = true;
    H.axle = Eigen::Vector2d(s.x + dH, r);
    out.hind_axle_vx = s.vx + dHdot;
    Eigen::Vector2d& relH = out.rel_h;
    Eigen::Vector2d& relF = out.rel_f;
    relH = relative(H.axle);
    relF.setZero();
    F.contact = !phase2;
    if (F.contact) {
      F.axle = Eigen::Vector2d(s.x + M.d_front_, r);
      relF = relative(F.axle);
    }
    LegPose& pH = out.pose_h;
    LegPose& pF = out.pose_f;
    pF = LegPose{};
    if (phase2) {
      pF = S.front_pose_t1;
      F.reach = S.front_reach_t1;
    }
    Eigen::Vector2d c = c_guess;
    Eigen::Vector2d step_before = Eigen::Vector2d::Zero();
    for (int it = 0; it < (converge ? kCoMMaxIterations : kCoMIterations); ++it) {
      // c(q) needs only the sines and cosines of the joint angles.
      pH = M.leg_.inversePose(relH - M.hind_.hfe_b + c, &H.reach, /*angles=*/false);
      if (F.contact) pF = M.leg_.inversePose(relF - M.front_.hfe_b + c, &F.reach, false);
      const Eigen::Vector2d c_next = comOffset(M, pH, pF);
      const Eigen::Vector2d step = c_next - c;
      c = c_next;
      if (step.squaredNorm() < kCoMTolerance * kCoMTolerance) break;
      // The map is close to linear: every second step, extrapolate the geometric series of the
      // last two steps (vector Aitken, Irons-Tuck).
      const Eigen::Vector2d dd = step - step_before;
      if (it % 2 == 1 && dd.squaredNorm() > 0.0) c -= (step.dot(dd) / dd.squaredNorm()) * step;
      step_before = step;
    }
    pH = M.leg_.inversePose(relH - M.hind_.hfe_b + c, &H.reach, false);
    if (F.contact) pF = M.leg_.inversePose(relF - M.front_.hfe_b + c, &F.reach, false);
    out.c = comOffset(M, pH, pF);
    if (!F.contact) F.axle = com + R * (-c + M.front_.hfe_b + S.front_b_t1);
  }

  // The second half of contactSample, on a sample from contactPosture: joint angles, joint
  // rates, torques and the wheels.
  static void contactStatics(const JumpModel& M, const Solved& S, Sample& out) {
    const PlanarState& s = out.s;
    PairSample& H = out.hind;
    PairSample& F = out.front;
    LegPose& pH = out.pose_h;
    LegPose& pF = out.pose_f;
    M.leg_.solveAngles(pH);
    if (F.contact) M.leg_.solveAngles(pF);  // else the phase-2 pose, solved once (Solved)
    const std::array<Eigen::Matrix2d, 2> C_pair = comJacobians(M, pH, pF);
    H.q = pH.q;
    F.q = pF.q;
    // The axles' rates relative to the CoM in the base frame.
    const Eigen::Vector2d vcom(s.vx, s.vz);
    auto rate = [&](const Eigen::Vector2d& rel, const Eigen::Vector2d& v) -> Eigen::Vector2d {
      return out.R.transposeTimes(v - vcom) + s.pitch_rate * Eigen::Vector2d(rel.y(), -rel.x());
    };
    const Eigen::Vector2d relH_dot = rate(out.rel_h, Eigen::Vector2d(out.hind_axle_vx, 0.0));
    const Eigen::Vector2d relF_dot =
        F.contact ? rate(out.rel_f, Eigen::Vector2d(s.vx, 0.0)) : Eigen::Vector2d::Zero();
    // Joint rates: b_i = rel_i - hfe_i + c(q) and b_i' = J_i q_i', so
    // (J_i - C_i) q_i' - C_j q_j' = rel_i' for the pairs in contact.
    const Eigen::Matrix2d JH = M.leg_.jacobian(pH);
    if (F.contact) {
      const Eigen::Matrix2d JF = M.leg_.jacobian(pF);
      // [A  B; C  D] (qd_H, qd_F) = (relH', relF') with A = J_H - C_H, B = -C_F, C = -C_H,
      // D = J_F - C_F, by the Schur complement of A (closed-form 2x2 inverses).
      const Eigen::Matrix2d A = JH - C_pair[0], B = -C_pair[1], C = -C_pair[0], D = JF - C_pair[1];
      const double det_a = A.determinant();
      bool ok = std::abs(det_a) > 1e-12;
      if (ok) {
        const Eigen::Matrix2d A_inv = A.inverse();
        const Eigen::Matrix2d Sc = D - C * A_inv * B;
        const double det_s = Sc.determinant();
        ok = std::abs(det_a * det_s) > 1e-12 && std::abs(det_s) > 1e-14;
        if (ok) {
          const Eigen::Vector2d y = A_inv * relH_dot;
          F.qd = Sc.inverse() * (relF_dot - C * y);
          H.qd = y - A_inv * (B * F.qd);
        }
      }
      if (!ok) {
        H.qd = Eigen::Vector2d::Constant(1e3);
        F.qd = Eigen::Vector2d::Constant(1e3);
      }
    } else {
      const Eigen::Matrix2d A = JH - C_pair[0];
      H.qd = std::abs(A.determinant()) > 1e-12 ? Eigen::Vector2d(A.inverse() * relH_dot)
                                               : Eigen::Vector2d(1e3, 1e3);
      F.qd.setZero();
      F.wheel_rate = S.front_wheel_rate_t1;
    }
    const double local = out.local;
    const Eigen::Vector2d fH = out.phase2 ? Eigen::Vector2d(S.fHx2(local), S.fHz2(local))
                                          : Eigen::Vector2d(S.fHx1(local), S.fHz1(local));
    statics(M, s, out.R, pH, 0.5 * fH, out.hind_axle_vx, H);
    if (F.contact) {
      const Eigen::Vector2d fF(S.fFx1(local), S.fFz1(local));
      statics(M, s, out.R, pF, 0.5 * fF, s.vx, F);
    }
  }

  // Joint torques of a leg in contact (massless links, force at the contact point), and the
  // wheel's rate and torque.
  static void statics(const JumpModel& M, const PlanarState& s, const Rot2& R, const LegPose& pose,
                      const Eigen::Vector2d& f, double axle_vx, PairSample& p) {
    const double r = M.wheel_radius_;
    p.f = f;
    const Eigen::Vector2d contact_b =
        M.leg_.forward(pose) + R.transposeTimes(Eigen::Vector2d(0.0, -r));
    const Eigen::Vector2d f_b = R.transposeTimes(f);
    p.tau = M.leg_.balancingTorque(pose, contact_b, f_b);
    p.haa_fz = f_b.y();
    // Rolling without slip: wheel rate about +y is v_axle / r; the shank turns at
    // -pitch_rate + qd1 + qd2 about +y (nose-up pitch is a rotation about -y).
    p.wheel_rate = axle_vx / r - (-s.pitch_rate + p.qd[0] + p.qd[1]);
    p.wheel_tau = r * f.x();
  }

  // Feeds every sampled margin of one take-off sample to `sink(class, margin, t, location)`.
  template <class Sink>
  static void emitContact(const JumpModel& M, const Sample& smp, Sink& sink) {
    const auto& st = M.settings_;
    for (int pair = 0; pair < 2; ++pair) {
      const PairSample& p = pair == 0 ? smp.hind : smp.front;
      const model::Leg leg = pair == 0 ? model::Leg::LH : model::Leg::LF;
      const int base = model::jointIndex(leg, model::JointKind::HAA);
      const int loc_pair = pair == 0 ? -1 : -2;
      const double lever = pair == 0 ? M.hind_.haa_lever : M.front_.haa_lever;
      const bool lift_off = pair == 1 && M.task_.mode == TakeoffMode::TwoStep && smp.t >= smp.t1;
      if (p.contact && !lift_off) {
        // In a two-step take-off the front pair unloads linearly to zero at its lift-off (t1),
        // so its minimum normal force ramps down with it.
        const double f_min = (pair == 1 && M.task_.mode == TakeoffMode::TwoStep)
                                 ? st.min_normal_force_n * std::max(0.0, 1.0 - smp.t / smp.t1)
                                 : st.min_normal_force_n;
        sink(ConstraintClass::NormalForce, p.f.y() - f_min, smp.t, loc_pair);
        sink(ConstraintClass::FrictionCone, st.friction_mu * p.f.y() - std::abs(p.f.x()), smp.t,
             loc_pair);
      } else {
        sink(ConstraintClass::NormalForce, JumpModel::classScale(ConstraintClass::NormalForce),
             smp.t, loc_pair);
        sink(ConstraintClass::FrictionCone, JumpModel::classScale(ConstraintClass::FrictionCone),
             smp.t, loc_pair);
      }
      sink(ConstraintClass::JointPosition, p.reach / M.leg_.l1, smp.t, base + 2);
      sink(ConstraintClass::JointPosition, std::min(p.q[0] - M.lim_hfe_[0], M.lim_hfe_[1] - p.q[0]),
           smp.t, base + 1);
      sink(ConstraintClass::JointPosition, std::min(p.q[1] - M.lim_kfe_[0], M.lim_kfe_[1] - p.q[1]),
           smp.t, base + 2);
      sink(ConstraintClass::JointSpeed, M.env_hfe_.speedMargin(p.qd[0]), smp.t, base + 1);
      sink(ConstraintClass::JointSpeed, M.env_kfe_.speedMargin(p.qd[1]), smp.t, base + 2);
      const double tau_haa = lever * p.haa_fz;
      sink(ConstraintClass::JointTorque, M.env_haa_.peak_torque_nm - std::abs(tau_haa), smp.t,
           base);
      sink(ConstraintClass::JointTorque, M.env_hfe_.peak_torque_nm - std::abs(p.tau[0]), smp.t,
           base + 1);
      sink(ConstraintClass::JointTorque, M.env_kfe_.peak_torque_nm - std::abs(p.tau[1]), smp.t,
           base + 2);
      sink(ConstraintClass::ActuatorEnvelope, M.env_haa_.torqueMargin(tau_haa, 0.0), smp.t, base);
      sink(ConstraintClass::ActuatorEnvelope, M.env_hfe_.torqueMargin(p.tau[0], p.qd[0]), smp.t,
           base + 1);
      sink(ConstraintClass::ActuatorEnvelope, M.env_kfe_.torqueMargin(p.tau[1], p.qd[1]), smp.t,
           base + 2);
      sink(ConstraintClass::WheelTraction, M.env_wheel_.torqueMargin(p.wheel_tau, p.wheel_rate),
           smp.t, base + 3);
      sink(ConstraintClass::WheelSpeed, M.env_wheel_.speedMargin(p.wheel_rate), smp.t, base + 3);
    }
    emitBody(M, smp.t, smp.s, smp.R, smp.c, &smp, nullptr, sink);
  }

  // Clearance of a disc (centre p, radius r) to the obstacle. While the robot is on the ground
  // (take-off), a point below the obstacle's top must stay in front of it: this cannot be
  // tunnelled through between two samples, however fast the run-up.
  // A wheel disc (r > 0) in flight over a platform the jump lands on (`platform`): the top is
  // where it lands, like the ground, so only the near face and its edge are an obstacle.
  static double obstacleMargin(const BoxObstacle& box, const Eigen::Vector2d& p, double r,
                               bool on_ground, bool platform = false) {
    if (on_ground && p.y() - r < box.height) return box.x_min - (p.x() + r);
    if (platform && r > 0.0 && p.x() >= box.x_min) {
      if (p.y() < box.height) return p.y() - box.height - r;  // centre below the top: inside
      const double dx = p.x() - box.x_min, dz = p.y() - box.height;
      return std::sqrt(dx * dx + dz * dz) - r;  // to the near top edge
    }
    return boxDistance(box, p) - r;
  }

  // Body height and obstacle margins at one instant. In take-off the wheel axles come from the
  // sample; in flight from the blended leg posture `flight_q` (HFE, KFE) per pair.
  template <class Sink>
  static void emitBody(const JumpModel& M, double t, const PlanarState& s, const Rot2& R,
                       const Eigen::Vector2d& c, const Sample* smp,
                       const std::array<Eigen::Vector2d, 2>* flight_q, Sink& sink) {
    const Eigen::Vector2d com(s.x, s.z);
    double clearance = kInf;
    const auto* box = M.task_.obstacle ? &*M.task_.obstacle : nullptr;
    // The base box: its centre and half axes in the world.
    const Eigen::Vector2d centre = com - R * c;
    const Eigen::Vector2d ax = R * Eigen::Vector2d(M.box_half_.x(), 0.0);
    const Eigen::Vector2d az = R * Eigen::Vector2d(0.0, M.box_half_.y());
    // Its lowest point is a corner.
    const double lowest = centre.y() - std::abs(ax.y()) - std::abs(az.y());
    sink(ConstraintClass::BodyHeight, lowest - M.settings_.min_body_clearance_m, t, -3);
    if (box) {
      // 4 corners and 4 edge midpoints of the base box.
      static constexpr std::array<std::array<double, 2>, 8> kPts = {
          {{1, 1}, {1, -1}, {-1, 1}, {-1, -1}, {0, 1}, {0, -1}, {1, 0}, {-1, 0}}};
      for (const auto& k : kPts) {
        const Eigen::Vector2d p = centre + k[0] * ax + k[1] * az;
        clearance = std::min(clearance, obstacleMargin(*box, p, 0.0, smp != nullptr));
      }
      for (int pair = 0; pair < 2; ++pair) {
        Eigen::Vector2d axle;
        if (smp) {
          axle = pair == 0 ? smp->hind.axle : smp->front.axle;
        } else {
          const auto& geo = pair == 0 ? M.hind_ : M.front_;
          axle = com + R * (-c + geo.hfe_b + M.leg_.forward((*flight_q)[pair]));
        }
        clearance = std::min(clearance, obstacleMargin(*box, axle, M.wheel_radius_, smp != nullptr,
                                                       M.task_.landsOnObstacle()));
      }
      sink(ConstraintClass::ObstacleClearance, clearance - M.settings_.obstacle_margin_m, t, -3);
    }
  }

  // Blended (HFE, KFE) of a pair in flight at time t.
  // (HFE, KFE) of a pair in flight at time t: from the take-off posture to the tuck posture
  // over [0, tuck_end], held, then to the landing posture over [extend_start, extend_end]
  // (fractions of the flight), with smoothstep blends.
  static Eigen::Vector2d flightPosture(const JumpModel& M, const Solved& S,
                                       const Eigen::Vector2d& q_takeoff, double t,
                                       Eigen::Vector2d* qd) {
    const auto& st = M.settings_;
    const double xi = (t - S.t2) / S.Tf;
    const Eigen::Vector2d q_tuck(st.tuck_hfe_rad, st.tuck_kfe_rad);
    auto blend = [&](const Eigen::Vector2d& from, const Eigen::Vector2d& to, double a, double b) {
      const double T = (b - a) * S.Tf, u = (xi - a) / (b - a);
      if (qd) *qd = (to - from) * smoothstepRate(u) / T;
      return Eigen::Vector2d(from + (to - from) * smoothstep(u));
    };
    if (xi < st.tuck_end_fraction) return blend(q_takeoff, q_tuck, 0.0, st.tuck_end_fraction);
    return blend(q_tuck, M.q_landing_, st.extend_start_fraction, st.extend_end_fraction);
  }

  // Sweeps every constraint sample of a solved take-off and flight through `sink`, and
  // accumulates energy and joint maxima into the optional evaluation.
  // |P|, or its smooth version sqrt(P^2 + 1 W^2) for the gradient-based polish.
  static double absPower(double p, bool smooth) {
    return smooth ? std::sqrt(p * p + 1.0) : std::abs(p);
  }

  // `slot` as in sweepContact; it is -1 once the flight's margins are emitted.
  template <class Sink>
  static void sweep(const JumpModel& M, const Solved& S, Sink& sink, Evaluation* ev,
                    bool smooth_energy = false, int* slot = nullptr) {
    const auto never = [] { return false; };
    sweepContact(M, S, sink, ev, smooth_energy, never, slot);
    if (slot) *slot = -1;
    sweepFlight(M, S, sink, never);
  }

  // The take-off part of sweep(): every contact sample, the energy and the joint maxima. It
  // asks `stop()` after every sample whether to give up (evaluate()'s cut-off; asking every 8
  // samples instead costs 5-7 % more instructions per solve) and returns false if it did.
  // Each sample is computed in two halves:
  // - its posture (contactPosture), in the order of settings.contact_chain, each one step of
  //   the CoM-offset iteration from the sample before it in that order: FromStart in time
  //   order from the standing posture's offset; FromTakeoff t = 0 (from that offset, exact
  //   there), then the take-off t2 (from the converged take-off posture) and backwards;
  // - its statics and margins (contactStatics, about half of a sample's cost), in the order
  //   t = 0, then from the take-off t2 backwards, computing postures as they are needed.
  //   Most cut-offs come at t = 0 or near t2, where the push starts and where the speeds and
  //   torques peak: seed 1, forward preset, 70 % of the cut-offs in the take-off at t = 0;
  //   backflip, 54 % at t2 once t2 comes first. Instructions per DE solve against time order
  //   (callgrind, seed 1): backflip -12 %, forward +0.6 %, vertical and forward_hw -1.6 %.
  //   The order changes no number: the energy is summed in time order, and evaluate() breaks
  //   ties of the worst margins towards the earliest instant.
  // `slot`, if given, receives each sample's index in time order before its margins go out.
  template <class Sink, class Stop>
  static bool sweepContact(const JumpModel& M, const Solved& S, Sink& sink, Evaluation* ev,
                           bool smooth_energy, Stop&& stop, int* slot = nullptr) {
    const auto& st = M.settings_;
    const bool from_takeoff = st.contact_chain == ContactChain::FromTakeoff;
    const int n1 = st.samples_phase1, n2 = S.two_step ? st.samples_phase2 : 0;
    const int count = n1 + n2;
    // Per-thread scratch, grown once: the DE evaluates on a fixed team of threads.
    thread_local std::vector<Sample> samples;
    thread_local std::vector<double> power;
    if (static_cast<int>(samples.size()) < count) {
      samples.resize(count);
      power.resize(count);
    }
    // Postures. j: the sample's index in time order (phase 1's n1 samples on [0, t1], then
    // phase 2's n2 on [t1, t2]; both have one at t1); e: its place in the chain.
    int chained = 0;  // postures done, in chain order
    Eigen::Vector2d c_guess = M.c0_;
    auto posture_up_to = [&](int j) {
      const int e_of_j = from_takeoff && j > 0 ? count - j : j;
      for (; chained <= e_of_j; ++chained) {
        const int e = chained;
        const int k = from_takeoff && e > 0 ? count - e : e;
        const bool phase2 = k >= n1;
        const double t = phase2 ? S.t1 + S.T2 * (k - n1) / (n2 - 1) : 0.0 + S.t1 * k / (n1 - 1);
        if (from_takeoff && e == 1) c_guess = S.c_to;
        contactPosture(M, S, t, samples[k], phase2, c_guess, /*converge=*/false);
        c_guess = samples[k].c;
      }
    };
    // Trapezoids between neighbours in time, none across the instant t1 (where phase 1's last
    // sample and phase 2's first coincide).
    auto trapezoid = [&](int j) {  // from sample j - 1 to j
      const double t = samples[j].t, prev_t = samples[j - 1].t;
      return t > prev_t ? 0.5 * (power[j] + power[j - 1]) * (t - prev_t) : 0.0;
    };
    double energy = 0.0;  // the trapezoids between samples done so far: a lower bound
    for (int i = 0; i < count; ++i) {
      const int j = i == 0 ? 0 : count - i;
      posture_up_to(j);
      Sample& smp = samples[j];
      contactStatics(M, S, smp);
      if (slot) *slot = j;
      emitContact(M, smp, sink);
      double p_sum = 0.0;
      for (const PairSample* p : {&smp.hind, &smp.front}) {
        if (!p->contact) continue;
        p_sum += 2.0 * (absPower(p->tau[0] * p->qd[0], smooth_energy) +
                        absPower(p->tau[1] * p->qd[1], smooth_energy) +
                        absPower(p->wheel_tau * p->wheel_rate, smooth_energy));
        if (ev) {
          const double haa = std::abs((p == &smp.hind ? M.hind_ : M.front_).haa_lever * p->haa_fz);
          auto& mt = ev->max_abs_torque_nm;
          auto& ms = ev->max_abs_speed_rad_s;
          mt[0] = std::max(mt[0], haa);
          mt[1] = std::max(mt[1], std::abs(p->tau[0]));
          mt[2] = std::max(mt[2], std::abs(p->tau[1]));
          mt[3] = std::max(mt[3], std::abs(p->wheel_tau));
          ms[1] = std::max(ms[1], std::abs(p->qd[0]));
          ms[2] = std::max(ms[2], std::abs(p->qd[1]));
          ms[3] = std::max(ms[3], std::abs(p->wheel_rate));
        }
      }
      power[j] = p_sum;
      if (i > 0 && j + 1 < count) energy += trapezoid(j + 1);
      if (i > 0 && j == 1) energy += trapezoid(1);
      // A lower bound of the final sum, which adds the same >= 0 terms and more in another
      // order: each sum is within (count - 1) eps of its exact value (~1e-14 relative for
      // 100 samples), so 1e-12 less never exceeds it.
      if (ev) ev->energy_j = energy * (1.0 - 1e-12);
      if (stop()) return false;
    }
    energy = 0.0;
    for (int j = 1; j < count; ++j) energy += trapezoid(j);
    if (ev) ev->energy_j = energy;
    return true;
  }

  // The flight part of sweep(): body and wheels against the ground and the obstacle, and the
  // landing beyond the obstacle; `stop()` is asked once, after the flight samples.
  template <class Sink, class Stop>
  static bool sweepFlight(const JumpModel& M, const Solved& S, Sink& sink, Stop&& stop) {
    const auto& st = M.settings_;
    // Flight: the postures and CoM offsets tabulated with the attitude (same instants).
    for (int k = 1; k <= S.n_flight; ++k) {
      const double t = S.t2 + S.Tf * k / S.n_flight;
      const PlanarState s = flightState(M, S, t);
      const std::array<Eigen::Vector2d, 2> q = {S.flight_q[0][k], S.flight_q[1][k]};
      emitBody(M, t, s, Rot2(s.pitch), S.flight_c[k], nullptr, &q, sink);
    }
    if (stop()) return false;
    if (M.task_.obstacle) {
      // Clearing the obstacle means landing beyond it: the rear wheel touches down past its
      // far face (otherwise stopping short of the wall would count as clearing it). Landing on
      // it (a platform): both pairs' wheels touch down on its top, each wheel disc inside the
      // near and the far face by the margin (one row: the smaller of the two).
      const PlanarState& td = S.touchdown;
      const BoxObstacle& box = *M.task_.obstacle;
      const Eigen::Vector2d com(td.x, td.z);
      const Rot2 R(td.pitch);
      const Eigen::Vector2d leg = M.leg_.forward(M.q_landing_);
      const Eigen::Vector2d hind = com + R * (-M.c_land_ + M.hind_.hfe_b + leg);
      double m = hind.x() - M.wheel_radius_ - box.x_max - st.obstacle_margin_m;
      if (M.task_.landsOnObstacle()) {
        const Eigen::Vector2d front = com + R * (-M.c_land_ + M.front_.hfe_b + leg);
        m = std::min(hind.x() - M.wheel_radius_ - box.x_min,
                     box.x_max - (front.x() + M.wheel_radius_)) -
            st.obstacle_margin_m;
      }
      sink(ConstraintClass::ObstacleClearance, m, S.t3, -1);
    }
    return true;
  }

  static void targetErrors(const JumpModel& M, const Solved& S, Eigen::Vector4d& e,
                           JumpOutcome& out) {
    const auto& tgt = M.task_.target;
    const PlanarState& to = S.takeoff;
    const double g = M.settings_.gravity;
    auto event = [&](double t, const PlanarState& s, const Eigen::Vector2d& c) {
      JumpEvent ev;
      ev.t = t;
      ev.state = s;
      ev.base_z = s.z + rot(s.pitch, -c).y();
      return ev;
    };
    // The base at take-off from the take-off posture; in flight the legs are taken at the
    // landing posture they are moving to.
    out.takeoff = event(S.t2, to, S.c_to);
    const double t_apex = std::max(to.vz / g, 0.0);
    std::array<Eigen::Vector2d, 2> q_apex;
    for (int pair = 0; pair < 2; ++pair)
      q_apex[pair] = flightPosture(M, S, S.q_to[pair], S.t2 + t_apex, nullptr);
    out.apex = event(S.t2 + t_apex, flightState(M, S, S.t2 + t_apex),
                     comOffset(M, poseOf(q_apex[0]), poseOf(q_apex[1])));
    out.touchdown = event(S.t3, S.touchdown, M.c_land_);
    const PlanarState& s0 = M.initial_;
    const PlanarState& at = tgt.event == TargetEvent::Apex ? out.apex.state : S.touchdown;
    e[0] = at.x - s0.x - tgt.dx;
    e[1] = tgt.event == TargetEvent::Apex ? at.z - tgt.height : 0.0;
    e[2] = at.pitch - s0.pitch - tgt.pitch_change;
    // Apex targets must still land upright (pitch a multiple of 2 pi at touchdown).
    e[3] = tgt.event == TargetEvent::Apex ? wrapToPi(S.touchdown.pitch) : 0.0;
  }

  // The references at time t in `segment` (the segment's own values at its boundaries).
  // `c_guess` warm-starts the contact sample's CoM-offset iteration and is updated.
  static void planRow(const JumpModel& M, const Solved& S, double t, Segment segment,
                      Eigen::Vector2d& c_guess, PlanRow& out) {
    using model::JointKind;
    using model::Leg;
    std::array<Eigen::Vector2d, 2> q, qd;
    std::array<double, 2> wheel_rate{}, wheel_tau{}, haa_fz{};
    out.tau.setZero();
    if (segment != Segment::Flight) {
      Sample smp;
      contactSample(M, S, t, smp, segment == Segment::HindOnly, c_guess,
                    /*converge=*/true);
      c_guess = smp.c;
      out.s = smp.s;
      int i = 0;
      for (const PairSample* p : {&smp.hind, &smp.front}) {
        q[i] = p->q;
        qd[i] = p->contact ? p->qd : Eigen::Vector2d::Zero();
        wheel_rate[i] = p->wheel_rate;
        wheel_tau[i] = p->contact ? p->wheel_tau : 0.0;
        haa_fz[i] = p->contact ? p->haa_fz : 0.0;
        ++i;
      }
      for (int pair = 0; pair < 2; ++pair) {
        const PairSample& p = pair == 0 ? smp.hind : smp.front;
        for (const Leg leg : model::kLegs) {
          if ((pair == 0) == model::isFront(leg)) continue;
          out.tau[model::jointIndex(leg, JointKind::HFE)] = p.contact ? p.tau[0] : 0.0;
          out.tau[model::jointIndex(leg, JointKind::KFE)] = p.contact ? p.tau[1] : 0.0;
        }
      }
    } else {
      out.s = flightState(M, S, t);
      for (int pair = 0; pair < 2; ++pair) {
        q[pair] = flightPosture(M, S, S.q_to[pair], t, &qd[pair]);
        wheel_rate[pair] = flightWheelRate(M, S, pair, t);
      }
    }
    for (const Leg leg : model::kLegs) {
      const int pair = model::isFront(leg) ? 1 : 0;
      const int haa = model::jointIndex(leg, JointKind::HAA);
      const double lever =
          M.robot_.legGeometry(leg).p_HT.y() + M.robot_.legGeometry(leg).wheel_lateral_offset;
      out.q[haa] = M.init_input_.q[haa];
      out.qd[haa] = 0.0;
      out.tau[haa] = -lever * haa_fz[pair];
      out.q[haa + 1] = q[pair][0];
      out.q[haa + 2] = q[pair][1];
      out.qd[haa + 1] = qd[pair][0];
      out.qd[haa + 2] = qd[pair][1];
      out.qd[haa + 3] = wheel_rate[pair];
      out.tau[haa + 3] = wheel_tau[pair];
    }
  }
};

JumpModel::JumpModel(const model::RobotModel& robot, const PlannerSettings& settings,
                     const JumpTask& task, const InitialState& initial)
    : robot_(robot), settings_(settings), task_(task), init_input_(initial) {
  settings_.validate();
  task_.validate();
  init_input_.validate(robot_);
  using model::JointKind;
  using model::Leg;
  const auto& lg = robot_.legGeometry(Leg::LF);
  leg_ = PlanarLeg{lg.thigh_length, robot_.legGeometry(Leg::LF).shank_length};
  wheel_radius_ = robot_.wheelRadius();
  mass_ = robot_.totalMass();
  env_haa_ = robot_.joint(Leg::LF, JointKind::HAA).actuator;
  env_hfe_ = robot_.joint(Leg::LF, JointKind::HFE).actuator;
  env_kfe_ = robot_.joint(Leg::LF, JointKind::KFE).actuator;
  env_wheel_ = robot_.joint(Leg::LF, JointKind::Wheel).actuator;
  for (auto* env : {&env_haa_, &env_hfe_, &env_kfe_, &env_wheel_}) {
    env->peak_torque_nm *= settings_.actuator_torque_scale;
    // The paper's drives: the peak torque at every speed up to the no-load speed.
    if (settings_.actuator_model == ActuatorModel::ConstantTorque)
      env->corner_speed_rad_s = env->no_load_speed_rad_s;
  }
  lim_hfe_ = {robot_.joint(Leg::LF, JointKind::HFE).lower_rad,
              robot_.joint(Leg::LF, JointKind::HFE).upper_rad};
  lim_kfe_ = {robot_.joint(Leg::LF, JointKind::KFE).lower_rad,
              robot_.joint(Leg::LF, JointKind::KFE).upper_rad};

  // Composite inertia in the take-off posture (held constant: docs/planner.md, S-3).
  const Eigen::VectorXd q0 = init_input_.q;
  const model::Inertia inertia = robot_.calcCompositeInertia(q0);
  inertia_ = inertia.inertia_com(1, 1);
  const Eigen::Vector2d com_b(inertia.com.x(), inertia.com.z());

  box_half_ = Eigen::Vector2d(robot_.baseBoxSize().x() / 2, robot_.baseBoxSize().z() / 2);
  const auto X = robot_.calcLinkPoses(q0);
  auto geometry = [&](Leg leg) {
    const auto& g = robot_.legGeometry(leg);
    Geometry geo;
    const Eigen::Vector3d hfe = g.p_BH + g.p_HT;
    geo.hfe_b = Eigen::Vector2d(hfe.x(), hfe.z());
    // Leg link masses in the sagittal plane (HAA at 0): thigh in its frame; shank and wheel
    // together in the shank frame (the wheel's CoM is on its axle).
    const auto& thigh = robot_.links()[robot_.joint(leg, JointKind::HFE).child_link].inertia;
    const auto& shank = robot_.links()[robot_.joint(leg, JointKind::KFE).child_link].inertia;
    const auto& wheel_j = robot_.joint(leg, JointKind::Wheel);
    const auto& wheel = robot_.links()[wheel_j.child_link].inertia;
    geo.m_thigh = thigh.mass;
    geo.c_thigh = Eigen::Vector2d(thigh.com.x(), thigh.com.z());
    geo.m_lower = shank.mass + wheel.mass;
    const Eigen::Vector3d wheel_c = wheel_j.X_PJ * wheel.com;
    geo.c_lower = (shank.mass * Eigen::Vector2d(shank.com.x(), shank.com.z()) +
                   wheel.mass * Eigen::Vector2d(wheel_c.x(), wheel_c.z())) /
                  geo.m_lower;
    const Eigen::Vector2d cs(shank.com.x(), shank.com.z()), cw(wheel_c.x(), wheel_c.z());
    geo.i_thigh = thigh.inertia_com(1, 1);
    geo.i_lower = shank.inertia_com(1, 1) + shank.mass * (cs - geo.c_lower).squaredNorm() +
                  wheel.mass * (cw - geo.c_lower).squaredNorm();
    geo.haa_lever = g.p_HT.y() + g.wheel_lateral_offset;
    return geo;
  };
  hind_ = geometry(Leg::LH);
  front_ = geometry(Leg::LF);
  // The parts that do not move with the sagittal joints: the base and the hip (HAA) links.
  mass_fixed_ = 0.0;
  moment_fixed_.setZero();
  for (std::size_t i = 0; i < robot_.links().size(); ++i) {
    const auto& link = robot_.links()[i];
    const bool fixed =
        link.parent_joint < 0 || robot_.joints()[link.parent_joint].kind == JointKind::HAA;
    if (!fixed) continue;
    const Eigen::Vector3d p = X[i] * link.inertia.com;
    mass_fixed_ += link.inertia.mass;
    moment_fixed_ += link.inertia.mass * Eigen::Vector2d(p.x(), p.z());
  }
  {
    const Eigen::Vector2d c_fixed = moment_fixed_ / mass_fixed_;
    i_fixed_ = 0.0;
    for (std::size_t i = 0; i < robot_.links().size(); ++i) {
      const auto& link = robot_.links()[i];
      if (link.parent_joint >= 0 && robot_.joints()[link.parent_joint].kind != JointKind::HAA)
        continue;
      const Eigen::Vector3d p = X[i] * link.inertia.com;
      const Eigen::Matrix3d Ib =
          X[i].linear() * link.inertia.inertia_com * X[i].linear().transpose();
      i_fixed_ +=
          Ib(1, 1) + link.inertia.mass * (Eigen::Vector2d(p.x(), p.z()) - c_fixed).squaredNorm();
    }
  }
  c0_ = comInBase(Eigen::Vector2d(q0[model::jointIndex(Leg::LH, JointKind::HFE)],
                                  q0[model::jointIndex(Leg::LH, JointKind::KFE)]),
                  Eigen::Vector2d(q0[model::jointIndex(Leg::LF, JointKind::HFE)],
                                  q0[model::jointIndex(Leg::LF, JointKind::KFE)]));
  auto axle_rel_com = [&](Leg leg) {
    const Eigen::Vector3d p = X[robot_.joint(leg, JointKind::Wheel).child_link].translation();
    return rot(init_input_.pitch, Eigen::Vector2d(p.x(), p.z()) - com_b);
  };
  const Eigen::Vector2d a_h = axle_rel_com(Leg::LH), a_f = axle_rel_com(Leg::LF);
  d_hind_ = a_h.x();
  d_front_ = a_f.x();
  if (!(d_front_ - d_hind_ > 0.05))
    throw std::invalid_argument("initial.q: the front wheels must be ahead of the hind wheels");
  initial_.x = 0.0;
  initial_.z = wheel_radius_ - 0.5 * (a_h.y() + a_f.y());
  initial_.pitch = init_input_.pitch;
  initial_.vx = init_input_.v0;
  initial_.vz = 0.0;
  initial_.pitch_rate = init_input_.pitch_rate;
  q_landing_ = Eigen::Vector2d(settings_.landing_hfe_rad, settings_.landing_kfe_rad);
  Eigen::VectorXd q_land = q0;
  for (const Leg leg : model::kLegs) {
    q_land[model::jointIndex(leg, JointKind::HFE)] = q_landing_[0];
    q_land[model::jointIndex(leg, JointKind::KFE)] = q_landing_[1];
  }
  z_land_ = standingComHeight(robot_, q_land);
  c_land_ = comInBase(q_landing_, q_landing_);
  if (task_.obstacle && task_.obstacle->x_min <= d_front_ + wheel_radius_)
    throw std::invalid_argument("task.obstacle.x_min must be ahead of the front wheels (> " +
                                std::to_string(d_front_ + wheel_radius_) +
                                " m in the jump frame), got " +
                                std::to_string(task_.obstacle->x_min));

  const auto& s = settings_;
  lower_.resize(kNumDecision);
  upper_.resize(kNumDecision);
  auto set = [&](int i, const std::array<double, 2>& b, double offset = 0.0) {
    lower_[i] = b[0] + offset;
    upper_[i] = b[1] + offset;
  };
  set(kMidDx, s.mid_dx_m);
  set(kMidDz, s.mid_dz_m);
  set(kMidDpitch, s.mid_dpitch_rad);
  set(kTakeoffDx, s.takeoff_dx_m);
  set(kTakeoffDz, s.takeoff_dz_m);
  set(kTakeoffDpitch, s.takeoff_dpitch_rad);
  set(kTakeoffDvx, s.takeoff_dvx_m_s);
  set(kTakeoffVz, s.takeoff_vz_m_s);
  set(kTakeoffRate, s.takeoff_pitch_rate_rad_s);
  set(kT1, s.t1_s);
  set(kT2MinusT1, s.t2_minus_t1_s);
  if (task_.mode == TakeoffMode::Simultaneous) {
    for (int i : {kMidDx, kMidDz, kMidDpitch, kT2MinusT1}) lower_[i] = upper_[i] = 0.0;
  } else {
    set(kTakeoffDpitch, s.two_step_takeoff_dpitch_rad);
    set(kTakeoffRate, s.two_step_takeoff_pitch_rate_rad_s);
  }
  if (task_.isBackflip()) {  // the flip box (planner_settings.h, docs/backflip.md)
    set(kT1, s.flip_t1_s);
    set(kT2MinusT1, s.flip_t2_minus_t1_s);
    set(kTakeoffDpitch, s.flip_takeoff_dpitch_rad);
    set(kTakeoffRate, s.flip_takeoff_pitch_rate_rad_s);
    set(kTakeoffVz, s.flip_takeoff_vz_m_s);
  }
  per_contact_sample_ = 2 * 15 + 1 + (task_.obstacle ? 1 : 0);
  per_flight_sample_ = 1 + (task_.obstacle ? 1 : 0);
  num_contact_samples_ =
      s.samples_phase1 + (task_.mode == TakeoffMode::TwoStep ? s.samples_phase2 : 0);
  num_constraint_samples_ = per_contact_sample_ * num_contact_samples_ +
                            per_flight_sample_ * s.samples_flight + (task_.obstacle ? 1 : 0);
}

JumpModel::SampleOrigin JumpModel::constraintSampleOrigin(int i) const {
  if (i < 0 || i >= num_constraint_samples_)
    throw std::out_of_range("JumpModel::constraintSampleOrigin: " + std::to_string(i) +
                            " not in [0, " + std::to_string(num_constraint_samples_) + ")");
  const int contact = per_contact_sample_ * num_contact_samples_;
  if (i < contact) return {i % per_contact_sample_, i / per_contact_sample_};
  const int j = i - contact;
  const int flight = per_flight_sample_ * settings_.samples_flight;
  if (j < flight) return {per_contact_sample_ + j % per_flight_sample_, j / per_flight_sample_};
  return {per_contact_sample_ + per_flight_sample_, 0};  // landing beyond the obstacle
}

Eigen::Vector2d JumpModel::comInBase(const Eigen::Vector2d& q_hind,
                                     const Eigen::Vector2d& q_front) const {
  return JumpModelAccess::comOffset(*this, JumpModelAccess::poseOf(q_hind),
                                    JumpModelAccess::poseOf(q_front));
}

double JumpModel::standingComHeight(const model::RobotModel& robot, const Eigen::VectorXd& q) {
  const model::Inertia inertia = robot.calcCompositeInertia(q);
  const auto X = robot.calcLinkPoses(q);
  double lowest = kInf;
  for (const model::Leg leg : model::kLegs)
    lowest =
        std::min(lowest, X[robot.joint(leg, model::JointKind::Wheel).child_link].translation().z() -
                             inertia.com.z());
  return robot.wheelRadius() - lowest;
}

double JumpModel::classScale(ConstraintClass c) {
  switch (c) {
    case ConstraintClass::NormalForce:
    case ConstraintClass::FrictionCone:
      return 50.0;
    case ConstraintClass::JointPosition:
      return 0.2;
    case ConstraintClass::JointSpeed:
    case ConstraintClass::WheelSpeed:
      return 5.0;
    case ConstraintClass::JointTorque:
    case ConstraintClass::ActuatorEnvelope:
    case ConstraintClass::WheelTraction:
      return 5.0;
    case ConstraintClass::BodyHeight:
    case ConstraintClass::ObstacleClearance:
      return 0.05;
  }
  return 1.0;
}

int JumpModel::classPriority(ConstraintClass c) {
  switch (c) {
    case ConstraintClass::JointPosition:
      return 10;
    case ConstraintClass::NormalForce:
      return 9;
    case ConstraintClass::FrictionCone:
      return 8;
    case ConstraintClass::BodyHeight:
      return 7;
    case ConstraintClass::ObstacleClearance:
      return 6;
    case ConstraintClass::JointTorque:
      return 5;
    case ConstraintClass::ActuatorEnvelope:
      return 4;
    case ConstraintClass::JointSpeed:
      return 3;
    case ConstraintClass::WheelTraction:
      return 2;
    case ConstraintClass::WheelSpeed:
      return 1;
  }
  return 1;
}

void JumpModel::evaluate(const Eigen::Ref<const Eigen::VectorXd>& u, Evaluation& ev,
                         double cutoff) const {
  ev = Evaluation{};
  Solved S;
  // The cost is built up cheapest bound first, and with a finite cut-off the evaluation stops
  // once what is known already exceeds it: every term (penalty, target, energy) is >= 0 and
  // only grows as samples come in. The order changes no value: the same numbers either way.
  if (!JumpModelAccess::solve(*this, u, S, /*flight=*/false)) {
    ev.valid = false;
    ev.cost = kInvalidCost;
    return;
  }
  ev.valid = true;
  const bool bounded = cutoff < std::numeric_limits<double>::infinity();
  // The penalty of the margins so far.
  auto penalty = [&ev, this] {
    double p = 0.0;
    for (int i = 0; i < kNumConstraintClasses; ++i) {
      const double worst = ev.margins[i].worst;
      if (worst < 0.0) {
        const auto c = static_cast<ConstraintClass>(i);
        const int n = classPriority(c);
        p += settings_.class_weight[i] * (kPow10[n + 3] + kPow10[n] * (-worst / classScale(c)));
      }
    }
    return p;
  };
  double target_bound = 0.0;
  auto cut = [&] {
    if (!bounded) return false;
    const double lower_bound = penalty() + target_bound + settings_.energy_weight * ev.energy_j;
    if (!(lower_bound > cutoff)) return false;
    ev.cut_off = true;
    ev.cost = lower_bound;
    ev.constraints_ok = false;
    ev.target_ok = false;
    ev.feasible = false;
    return true;
  };
  // Ties go to the earliest instant, as if the samples came in time order.
  auto sink = [&ev](ConstraintClass c, double margin, double t, int loc) {
    ClassMargin& m = ev.margins[static_cast<int>(c)];
    if (margin < m.worst || (margin == m.worst && t < m.t)) {
      m.worst = margin;
      m.t = t;
      m.location = loc;
    }
  };
  // 1. The target's position from the ballistic CoM; 2. the take-off samples.
  if (bounded) target_bound = JumpModelAccess::targetPositionCost(*this, S);
  if (cut()) return;
  // (The converged take-off posture is needed by the flight, and by the FromTakeoff chain.)
  const bool posture_first = settings_.contact_chain == ContactChain::FromTakeoff;
  if (posture_first) JumpModelAccess::solveTakeoffPosture(*this, S);
  if (!JumpModelAccess::sweepContact(*this, S, sink, &ev, false, cut)) return;
  // 3. The flight attitude and the whole target error.
  if (!posture_first) JumpModelAccess::solveTakeoffPosture(*this, S);
  JumpModelAccess::solveFlight(*this, S);
  Eigen::Vector4d e;
  JumpModelAccess::targetErrors(*this, S, e, ev.predicted);
  ev.err_dx = e[0];
  ev.err_height = e[1];
  ev.err_pitch = e[2];
  ev.err_landing_pitch = e[3];
  const double landing_excess =
      std::max(std::abs(e[3]) - settings_.landing_pitch_tolerance_rad, 0.0);
  ev.target_cost = targetErrorCost(e) +
                   std::pow(landing_excess / settings_.landing_pitch_tolerance_rad, 2) * 100.0;
  ev.target_ok = std::abs(e[0]) <= settings_.tolerance_dx_m &&
                 std::abs(e[1]) <= settings_.tolerance_height_m &&
                 std::abs(e[2]) <= settings_.tolerance_pitch_rad && landing_excess == 0.0;
  target_bound = ev.target_cost;
  if (cut()) return;
  // 4. The flight samples.
  if (!JumpModelAccess::sweepFlight(*this, S, sink, cut)) return;
  ev.penalty = penalty();
  ev.constraints_ok = true;
  for (const ClassMargin& m : ev.margins) ev.constraints_ok = ev.constraints_ok && m.worst >= 0.0;
  ev.predicted.min_obstacle_clearance =
      task_.obstacle ? ev.margins[static_cast<int>(ConstraintClass::ObstacleClearance)].worst +
                           settings_.obstacle_margin_m
                     : kInf;
  ev.feasible = ev.constraints_ok && ev.target_ok;
  ev.cost = ev.penalty + ev.target_cost + settings_.energy_weight * ev.energy_j;
}

double JumpModel::targetErrorCost(const Eigen::Ref<const Eigen::Vector4d>& e) const {
  return std::pow(e[0] / settings_.tolerance_dx_m, 2) +
         std::pow(e[1] / settings_.tolerance_height_m, 2) +
         std::pow(e[2] / settings_.tolerance_pitch_rad, 2);
}

bool JumpModel::evaluateConstraints(const Eigen::Ref<const Eigen::VectorXd>& u,
                                    Eigen::Ref<Eigen::VectorXd> g,
                                    Eigen::Ref<Eigen::Vector4d> target_residual,
                                    double* energy_j) const {
  Solved S;
  if (!JumpModelAccess::solve(*this, u, S)) return false;
  // g is in time order (constraintSampleOrigin) whatever the sweep's order: each take-off
  // sample's margins go to the block of its time index; the flight's follow.
  int i = 0, slot = -1, slot_now = -1, in_slot = 0;
  int next = per_contact_sample_ * num_contact_samples_;
  const int n = static_cast<int>(g.size());
  auto sink = [&](ConstraintClass c, double margin, double, int) {
    if (slot != slot_now) {
      slot_now = slot;
      in_slot = 0;
    }
    const int k = slot >= 0 ? slot * per_contact_sample_ + in_slot++ : next++;
    if (k < n && (slot < 0 || in_slot <= per_contact_sample_)) g[k] = margin / classScale(c);
    ++i;
  };
  Evaluation ev;
  JumpModelAccess::sweep(*this, S, sink, &ev, /*smooth_energy=*/true, &slot);
  if (i != num_constraint_samples_ || next != num_constraint_samples_)
    throw std::logic_error("JumpModel: constraint count " + std::to_string(i) +
                           " != " + std::to_string(num_constraint_samples_));
  Eigen::Vector4d e;
  JumpOutcome out;
  JumpModelAccess::targetErrors(*this, S, e, out);
  target_residual = e;
  if (energy_j) *energy_j = ev.energy_j;
  return true;
}

namespace {
// D = [s(t1/2), s(t2), s(t3), t1, t2, t3] of a solved candidate.
Eigen::VectorXd decisionOf(const Solved& S) {
  Eigen::VectorXd D(12);
  D << S.mid.x, S.mid.z, S.mid.pitch, S.takeoff.x, S.takeoff.z, S.takeoff.pitch, S.touchdown.x,
      S.touchdown.z, S.touchdown.pitch, S.t1, S.t2, S.t3;
  return D;
}
}  // namespace

Eigen::VectorXd JumpModel::decisionVector(const Eigen::Ref<const Eigen::VectorXd>& u) const {
  Solved S;
  if (!JumpModelAccess::solve(*this, u, S))
    throw std::runtime_error("JumpModel::decisionVector: candidate has no valid trajectory");
  return decisionOf(S);
}

namespace {
// The plan's phase times, force polynomials, postures and decision vector: all but the sampled
// trajectory.
void fillPlanHeader(const Solved& S, const JumpTask& task, const InitialState& init,
                    const Eigen::Vector2d& q_landing, const PlanarState& initial, JumpPlan& plan) {
  using model::JointKind;
  plan.mode = task.mode;
  plan.t1 = S.t1;
  plan.t2 = S.t2;
  plan.t3 = S.t3;
  ForcePhase p1;
  p1.t_start = 0.0;
  p1.t_end = S.t1;
  p1.hind = {toPolynomial(S.fHx1), toPolynomial(S.fHz1)};
  p1.front = {toPolynomial(S.fFx1), toPolynomial(S.fFz1)};
  plan.force_phases.push_back(p1);
  if (S.two_step) {
    ForcePhase p2;
    p2.t_start = S.t1;
    p2.t_end = S.t2;
    p2.hind = {toPolynomial(S.fHx2), toPolynomial(S.fHz2)};
    p2.front = {Polynomial{{0.0}}, Polynomial{{0.0}}};
    plan.force_phases.push_back(p2);
  }
  plan.initial = initial;
  plan.q_initial = init.q;
  plan.q_landing = init.q;
  for (const model::Leg leg : model::kLegs) {
    plan.q_landing[model::jointIndex(leg, JointKind::HFE)] = q_landing[0];
    plan.q_landing[model::jointIndex(leg, JointKind::KFE)] = q_landing[1];
  }
  plan.decision = decisionOf(S);
}
}  // namespace

JumpOutcome JumpModel::predictedOutcome(const Eigen::Ref<const Eigen::VectorXd>& u,
                                        const Evaluation* evaluation) const {
  if (evaluation != nullptr && evaluation->valid && !evaluation->cut_off)
    return evaluation->predicted;
  Evaluation ev;
  evaluate(u, ev);
  return ev.predicted;
}

JumpPlan JumpModel::buildPlan(const Eigen::Ref<const Eigen::VectorXd>& u,
                              const Evaluation* evaluation) const {
  Solved S;
  if (!JumpModelAccess::solve(*this, u, S))
    throw std::runtime_error("JumpModel::buildPlan: candidate has no valid trajectory");
  JumpPlan plan;
  fillPlanHeader(S, task_, init_input_, q_landing_, initial_, plan);
  plan.dt = settings_.output_dt_s;
  const int N = static_cast<int>(std::ceil(S.t3 / plan.dt - 1e-9)) + 1;
  plan.centroidal.resize(N);
  plan.q.setZero(N, model::kNumJoints);
  plan.qd.setZero(N, model::kNumJoints);
  plan.tau.setZero(N, model::kNumJoints);
  Eigen::Vector2d c_guess = c0_, c_before = c0_;
  PlanRow row;
  for (int k = 0; k < N; ++k) {
    const double t = std::min(k * plan.dt, S.t3);
    // The CoM offset's iteration starts from its linear extrapolation over the last two samples.
    const Eigen::Vector2d c_last = c_guess;
    if (k >= 2) c_guess = 2.0 * c_last - c_before;
    c_before = c_last;
    JumpModelAccess::planRow(*this, S, t, segmentAt(S, t), c_guess, row);
    plan.centroidal[k] = row.s;
    plan.q.row(k) = row.q.transpose();
    plan.qd.row(k) = row.qd.transpose();
    plan.tau.row(k) = row.tau.transpose();
    // Wheel angles: the trapezoid rule over the rates.
    for (const int w : kWheelJoints)
      plan.q(k, w) = k == 0 ? init_input_.q[w]
                            : plan.q(k - 1, w) + 0.5 * (plan.qd(k - 1, w) + plan.qd(k, w)) *
                                                     (t - std::min((k - 1) * plan.dt, S.t3));
  }
  plan.predicted = predictedOutcome(u, evaluation);
  return plan;
}

JumpPlan JumpModel::buildKnots(const Eigen::Ref<const Eigen::VectorXd>& u,
                               const Evaluation* evaluation) const {
  Solved S;
  if (!JumpModelAccess::solve(*this, u, S))
    throw std::runtime_error("JumpModel::buildKnots: candidate has no valid trajectory");
  JumpPlan plan;
  fillPlanHeader(S, task_, init_input_, q_landing_, initial_, plan);
  plan.dt = 0.0;
  // Phases and, in flight, the corners of the leg motion (tucked, extending, extended), where
  // the postures' second derivatives jump: a knot sits on each.
  struct Piece {
    double a, b;
    Segment segment;
  };
  std::vector<Piece> pieces;
  if (S.two_step) {
    pieces.push_back({0.0, S.t1, Segment::FourWheels});
    pieces.push_back({S.t1, S.t2, Segment::HindOnly});
  } else {
    pieces.push_back({0.0, S.t2, Segment::FourWheels});
  }
  double from = S.t2;
  for (const double f : {settings_.tuck_end_fraction, settings_.extend_start_fraction,
                         settings_.extend_end_fraction, 1.0}) {
    const double to = std::min(S.t2 + f * S.Tf, S.t3);
    if (to > from + 1e-9 || f == 1.0)
      pieces.push_back({from, f == 1.0 ? S.t3 : to, Segment::Flight});
    from = std::max(from, to);
  }
  // Each piece starts with even knots at most knot_dt_s apart. An interval is then halved
  // while the references at its midpoint differ from what densify() makes of its two knots by
  // more than the tolerances below (the legs move fast as they straighten at the end of the
  // push), down to output_dt_s. The midpoint rows also give the wheel angles (Simpson).
  constexpr double kQTol = 5e-4;    // joint position [rad]
  constexpr double kQdTol = 0.05;   // joint velocity [rad/s]
  constexpr double kTauTol = 0.25;  // torque, against the chord [Nm]
  struct Knot {
    double t;
    Segment segment;
    PlanRow row;
    Eigen::Vector4d wheel_mid_rate = Eigen::Vector4d::Zero();  // of the interval ending here
  };
  std::vector<Knot> knots;
  Eigen::Vector2d c_guess = c0_;
  const double min_dt = settings_.output_dt_s;
  auto accurate = [](const Knot& a, const Knot& m, const Knot& b) {
    const double h = b.t - a.t;
    for (int j = 0; j < model::kNumJoints; ++j) {
      if (model::isWheel(j)) continue;
      const double q0 = a.row.q[j], q1 = b.row.q[j], m0 = a.row.qd[j], m1 = b.row.qd[j];
      // Cubic Hermite at s = 1/2: value and derivative.
      const double q_mid = 0.5 * (q0 + q1) + h / 8.0 * (m0 - m1);
      const double qd_mid = 1.5 * (q1 - q0) / h - 0.25 * (m0 + m1);
      if (std::abs(q_mid - m.row.q[j]) > kQTol || std::abs(qd_mid - m.row.qd[j]) > kQdTol ||
          std::abs(0.5 * (a.row.tau[j] + b.row.tau[j]) - m.row.tau[j]) > kTauTol)
        return false;
    }
    return true;
  };
  auto refine = [&](auto&& self, const Knot& a, const Knot& b) -> void {
    Knot m{0.5 * (a.t + b.t), a.segment, {}, {}};
    Eigen::Vector2d c_mid = c_guess;
    JumpModelAccess::planRow(*this, S, m.t, m.segment, c_mid, m.row);
    if (b.t - a.t > 2.0 * min_dt && !accurate(a, m, b)) {
      self(self, a, m);
      self(self, m, b);
      return;
    }
    Knot accepted = b;
    for (int i = 0; i < 4; ++i) accepted.wheel_mid_rate[i] = m.row.qd[kWheelJoints[i]];
    knots.push_back(accepted);
  };
  const double h_max = settings_.knot_dt_s;
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    const Piece& p = pieces[i];
    const int n = std::max(1, static_cast<int>(std::ceil((p.b - p.a) / h_max - 1e-9)));
    // A flight piece continues the one before it: its first knot is that piece's last.
    const bool continues =
        i > 0 && p.segment == Segment::Flight && pieces[i - 1].segment == Segment::Flight;
    Knot prev{p.a, p.segment, {}, {}};
    if (continues) {
      prev = knots.back();
    } else {
      JumpModelAccess::planRow(*this, S, p.a, p.segment, c_guess, prev.row);
      knots.push_back(prev);
    }
    for (int k = 1; k <= n; ++k) {
      Knot next{k == n ? p.b : p.a + (p.b - p.a) * k / n, p.segment, {}, {}};
      JumpModelAccess::planRow(*this, S, next.t, next.segment, c_guess, next.row);
      refine(refine, prev, next);
      prev = next;
    }
  }
  PlanKnots& K = plan.knots;
  const int count = static_cast<int>(knots.size());
  K.t.resize(count);
  K.centroidal.resize(count);
  K.q.setZero(count, model::kNumJoints);
  K.qd.setZero(count, model::kNumJoints);
  K.tau.setZero(count, model::kNumJoints);
  for (int k = 0; k < count; ++k) {
    const Knot& kn = knots[k];
    K.t[k] = kn.t;
    K.centroidal[k] = kn.row.s;
    K.q.row(k) = kn.row.q.transpose();
    K.qd.row(k) = kn.row.qd.transpose();
    K.tau.row(k) = kn.row.tau.transpose();
    // Wheel angles: Simpson's rule over the rates of each interval, continuous across a phase
    // boundary.
    for (int i = 0; i < 4; ++i) {
      const int w = kWheelJoints[i];
      if (k == 0) {
        K.q(k, w) = init_input_.q[w];
        continue;
      }
      const double h = kn.t - knots[k - 1].t;  // 0 at a phase boundary's second knot
      K.q(k, w) =
          K.q(k - 1, w) + h / 6.0 * (K.qd(k - 1, w) + 4.0 * kn.wheel_mid_rate[i] + kn.row.qd[w]);
    }
  }
  plan.predicted = predictedOutcome(u, evaluation);
  return plan;
}

}  // namespace wj::planner
