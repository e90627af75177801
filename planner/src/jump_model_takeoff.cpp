// The take-off of the jump model (docs/planner.md, "Take-off"): for a candidate u, the force
// polynomials of each axis from the sampled positions (a linear solve), the CoM in closed
// form, and the pitch from the moments of the contact forces about the CoM.

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>

#include "jump_model_internal.h"
#include "jump_model_stance_dynamics.h"

namespace wj::planner::detail {

namespace {

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

// Horizontal split of phase 1: the front pair takes the same ratio of horizontal to normal
// force as the whole robot over phase 1 (it does not enter the dynamics: both contacts are at
// z = 0). Returns false without a positive vertical impulse.
bool splitPhase1(Solved& S, const Poly& fFz1) {
  const Poly IFz = integral(S.Fz1), IFx = integral(S.Fx1);
  const double impulse_z = IFz(S.t1);
  if (!(impulse_z > 0.0)) return false;
  const double kappa = IFx(S.t1) / impulse_z;
  S.fFz1 = fFz1;
  S.fFx1 = kappa * fFz1;
  S.fHz1 = S.Fz1 + (-1.0) * fFz1;
  S.fHx1 = S.Fx1 + (-1.0) * S.fFx1;
  return true;
}

// The front pair's nose-up angular momentum relative to the body at its lift-off sample: what
// its braking to rest hands to the body (the legs' motion and the shanks' turn of the wheels,
// whose joint rate holds) [kg m^2/s].
double frontPairHandover(const JumpModelConstants& M, const Sample& smp) {
  const double moving = stanceMomentumExcess(M, smp);
  const double at_rest =
      stanceMomentumExcess(M, {smp.hind.q, smp.front.q}, {smp.hind.qd, Eigen::Vector2d::Zero()},
                           {smp.hind.wheel_rate, smp.front.wheel_rate}, smp.s.pitch_rate);
  return moving - at_rest;
}

// A two-step take-off's front pair at its lift-off (t1, phase 1's last sample): its axle, wheel
// rate and reach, the braking that brings it to rest, and the stance momentum there. Needs
// phase 1 solved (S.P1, S.W1 and the split); returns the sample.
Sample liftFrontPair(const JumpModelConstants& M, Solved& S) {
  Sample smp;
  // (The second pass starts from the first pass's converged offset.)
  contactSample(M, S, S.t1, smp, /*phase2=*/false, S.stance_momentum ? S.c_front_t1 : M.c0,
                /*converge=*/true);
  S.front_b_t1 = M.leg.forward(smp.front.q);
  S.front_wheel_rate_t1 = smp.front.wheel_rate;
  S.front_pose_t1 = M.leg.inversePose(S.front_b_t1, &S.front_reach_t1);
  // Once lifted, the front legs brake from their speeds at t1 and hold where they stop.
  S.front_brake = startBrake(M, 1, smp.front.q, smp.front.qd, frontLiftBrakeShare(M));
  S.front_pose_stop = poseOf(Eigen::Vector2d(S.front_brake[0].q_stop, S.front_brake[1].q_stop));
  S.c_front_t1 = smp.c;
  if (!S.stance_momentum) {
    S.e_t1 = stanceMomentumExcess(M, smp);
    if (M.settings.stance_momentum) S.handover_t1 = frontPairHandover(M, smp);
  }
  return smp;
}

// The lift-off's unloading tail (docs/planner.md, "The lift-off's unloading tail"): a
// simultaneous take-off's ground force at t2 does not vanish at t2. The executor switches to
// the flight's references (the legs' braking) at its first control instant at or after t2, on
// its grid of kExecutorControlPeriod from t = 0, so the push's torques, and with them about the
// force at t2, hold until then; from there the contact unloads, falling about linearly to zero
// over settings.takeoff_unload_s while the legs brake (Simbody: 3 ms). The impulse, the force
// at t2 times (hold + half that time), goes into the flight's CoM velocity, and the moment at
// t2 times the same into its angular momentum (addUnloadingTailMoment: the moment the motion
// needs, which the balanced forces make; Eq. S-0's rigid-body moment of the model's split left
// out the legs' 25-33 Nm there). The tail is taken as an impulse at t2: what moves the CoM
// within it (~0.1 mm) and the contacts' travel are left out. A zero unloading time turns the
// whole tail off (the flight from the push's state at t2).
// The lift-off correction (docs/planner.md, "The lift-off correction") adds the velocity by
// which the multibody simulation's lift-off differs from the model's, for either take-off.
void addUnloadingTail(const JumpModelConstants& M, Solved& S) {
  S.tail_weight = 0.0;
  S.tail_h = 0.0;
  S.takeoff.vx += M.liftoff_correction.vx;
  S.takeoff.vz += M.liftoff_correction.vz;
  if (S.two_step || !(M.settings.takeoff_unload_s > 0.0)) return;
  const double t = S.t2;
  const double w = unloadingTailWeight(t, kExecutorControlPeriod, M.settings.takeoff_unload_s);
  S.tail_weight = w;
  S.takeoff.vx += w * S.Fx1(t) / M.mass;
  S.takeoff.vz += w * S.Fz1(t) / M.mass;
}

// The pitch of the take-off (Eq. S3, centroidal): the whole robot's angular momentum about its
// CoM changes by the moment of the ground forces,
//   d/dt (I theta' + E) = d_H Fz + (d_F - d_H) f_Fz + z Fx,
// with I the composite pitch inertia at t = 0 and E(t) what the legs and wheels add to I theta'
// as they move (S.D1, S.D2 hold E - E(0); zero in the first pass, docs/planner.md "Stance
// momentum"). Solves the front force (phase 1) and the hind contact's roll (phase 2) that
// bring the pitch to its targets. Returns false if the system is singular.
bool solvePitch(const JumpModelConstants& M, Solved& S) {
  const PlanarState& s0 = M.initial;
  const double I = M.inertia;
  const double dH = M.d_hind, dd = M.d_front - M.d_hind;
  const Poly A1 = dH * S.Fz1 + S.Z1 * S.Fx1;
  const Poly IA1 = integral(A1), IIA1 = integral(IA1);
  const Poly ID1 = integral(S.D1);
  Poly fFz1;
  if (!S.two_step) {
    const double T = S.t1;
    Eigen::Matrix2d A;
    A << dd * T * T / 2, dd * T * T * T / 6, dd * T, dd * T * T / 2;
    const Eigen::Vector2d b(I * (S.pe - s0.pitch - s0.pitch_rate * T) - IIA1(T) + ID1(T),
                            I * (S.we - s0.pitch_rate) - IA1(T) + S.D1(T));
    if (!(std::abs(A.determinant()) > 1e-14)) return false;
    const Eigen::Vector2d c = A.inverse() * b;
    fFz1 = {c[0], c[1]};
    S.P1 = integral(integral((1.0 / I) * (A1 + dd * fFz1), s0.pitch_rate), s0.pitch) +
           (-1.0 / I) * ID1;
  } else {
    const double t1 = S.t1, T2 = S.T2, h = t1 / 2;
    const Poly B1 = {-dd * t1, dd};  // (d_F - d_H)(t - t1): the front force vanishes at t1
    const Poly IB1 = integral(B1), IIB1 = integral(IB1);
    const Poly A2 = dH * S.Fz2 + S.Z2 * S.Fx2;
    // The hind contact's roll: dH2 = d_H + k1 tau + k2 tau^2, or for a backflip
    // d_H + k1 tau^2 + k2 tau^3, which starts at the rolling speed phase 1 ends with (the axle at
    // a fixed offset from the CoM): the linear term asked the hind wheels and legs for a step
    // in speed at t1 (10 rad/s at the wheel on the 42 Nm flips) that no drive gives and the
    // multibody does not follow (docs/backflip.md, "Session 12").
    const bool roll_from_rest = M.task.isBackflip();
    const Poly tau1 = roll_from_rest ? Poly{0.0, 0.0, 1.0} : Poly{0.0, 1.0};
    const Poly tau2 = roll_from_rest ? Poly{0.0, 0.0, 0.0, 1.0} : Poly{0.0, 0.0, 1.0};
    const Poly C1 = tau1 * S.Fz2, C2 = tau2 * S.Fz2;
    const Poly IA2 = integral(A2), IIA2 = integral(IA2);
    const Poly IC1 = integral(C1), IIC1 = integral(IC1);
    const Poly IC2 = integral(C2), IIC2 = integral(IC2);
    // Phase 2's correction relative to its start: D2(tau) - D2(0).
    const Poly D2 = S.D2 + Poly{-S.D2(0.0)};
    const Poly ID2 = integral(D2);
    Eigen::Matrix3d A;
    Eigen::Vector3d b;
    A.row(0) << IIB1(h), 0, 0;
    b[0] = I * (S.pm - s0.pitch - s0.pitch_rate * h) - IIA1(h) + ID1(h);
    A.row(1) << IIB1(t1) + IB1(t1) * T2, IIC1(T2), IIC2(T2);
    b[1] = I * (S.pe - s0.pitch - s0.pitch_rate * (t1 + T2)) - IIA1(t1) - IA1(t1) * T2 - IIA2(T2) +
           ID1(t1) + S.D1(t1) * T2 + ID2(T2);
    A.row(2) << IB1(t1), IC1(T2), IC2(T2);
    b[2] = I * (S.we - s0.pitch_rate) - IA1(t1) - IA2(T2) + S.D2(T2);
    const Eigen::PartialPivLU<Eigen::Matrix3d> lu(A);
    if (!(std::abs(lu.determinant()) > 1e-18)) return false;
    Eigen::Vector3d k = lu.solve(b);
    // Phase 1 needs k[0] alone (row 0): its pitch, the pairs' forces and the front pair's
    // lift-off sample at t1 do not depend on phase 2.
    fFz1 = k[0] * Poly{-t1, 1.0};
    S.P1 = integral(integral((1.0 / I) * (A1 + k[0] * B1), s0.pitch_rate), s0.pitch) +
           (-1.0 / I) * ID1;
    S.W1 = derivative(S.P1);
    if (!splitPhase1(S, fFz1)) return false;
    const Sample smp = liftFrontPair(M, S);
    // A backflip's lifted front pair brakes to rest relative to the body: with no ground force
    // on it, the whole robot's momentum about the CoM does not change, so the pair's momentum
    // relative to the body goes into the body's I theta' at t1 (docs/backflip.md, "Session
    // 13"). The stance-momentum pass has E fall by it at t1 (D2 starts there, from the first
    // pass's sample), and the pitch rate takes this pass's at once: row 2 already holds the
    // whole E at t2 (S.D2(T2)), so only the two samples' difference enters it.
    double handover = 0.0;
    if (S.stance_momentum) {
      handover = frontPairHandover(M, smp);
      b[1] -= handover * T2;
      b[2] -= handover - S.handover_t1;
      k = lu.solve(b);
    } else if (roll_from_rest) {
      handover = frontPairHandover(M, smp);
      b[1] -= handover * T2;
      b[2] -= handover;
      k = lu.solve(b);  // k[0] unchanged: row 0 holds phase 1 only
    }
    const double th1 = S.P1(t1), w1 = S.W1(t1) + handover / I;
    S.P2 = integral(integral((1.0 / I) * (A2 + k[1] * C1 + k[2] * C2), w1), th1) + (-1.0 / I) * ID2;
    S.dH2 = roll_from_rest ? Poly{dH, 0.0, k[1], k[2]} : Poly{dH, k[1], k[2]};
    S.ddH2 = derivative(S.dH2);
    S.fHx2 = S.Fx2;
    S.fHz2 = S.Fz2;
  }
  if (!S.two_step && !splitPhase1(S, fFz1)) return false;
  S.W1 = derivative(S.P1);
  S.W2 = derivative(S.P2);
  S.mid = stateAt(M, S, S.t1 / 2, M.settings.gravity);
  S.takeoff = stateAt(M, S, S.t2, M.settings.gravity);
  addUnloadingTail(M, S);
  return true;
}

// The polynomial through n <= 4 points (t_i, y_i) (Newton's divided differences).
Poly interpolate(const std::array<double, 4>& t, std::array<double, 4> y, int n) {
  for (int j = 1; j < n; ++j)
    for (int i = n - 1; i >= j; --i) y[i] = (y[i] - y[i - 1]) / (t[i] - t[i - j]);
  Poly p = {y[n - 1]};
  for (int i = n - 2; i >= 0; --i) p = p * Poly{-t[i], 1.0} + Poly{y[i]};
  return p;
}

}  // namespace

// Solves the take-off for candidate u and, with `complete`, the legs' momentum in stance
// (solveStanceMomentum), its converged posture at take-off and the flight attitude (otherwise
// the caller completes S with those three). Returns false if u has no valid trajectory.
bool solve(const JumpModelConstants& M, const Eigen::Ref<const Eigen::VectorXd>& u, Solved& S,
           bool complete) {
  const auto& st = M.settings;
  const PlanarState& s0 = M.initial;
  const double m = M.mass, g = st.gravity;
  S.two_step = M.task.mode == TakeoffMode::TwoStep;
  S.t1 = u[kT1];
  // With the unloading tail, a simultaneous take-off's push ends half-way between two control
  // instants (the executors' 1 ms grid from t = 0, kExecutorControlPeriod): the executor runs the
  // push's references up to the first instant after t2 (the row at t2 itself is the push's), so a
  // t2 anywhere in a period holds the push's torques for 0-1 periods after it, 0-0.75 N s of
  // impulse that depends on where t2 falls (docs/planner.md, "The lift-off's unloading tail").
  // As a sawtooth in t2 it drew the DE's optima to the edge where the hold is longest; half a
  // period is as far from both edges as a t2 can be (unloadingTailWeight holds for any t2).
  if (!S.two_step && M.settings.takeoff_unload_s > 0.0) {
    constexpr double dt = kExecutorControlPeriod;
    S.t1 = (std::max(0.0, std::floor(S.t1 / dt)) + 0.5) * dt;
  }
  S.T2 = S.two_step ? u[kT2MinusT1] : 0.0;
  S.t2 = S.t1 + S.T2;
  if (!(S.t1 > 0.0) || !(S.T2 >= 0.0)) return false;
  const double v0 = s0.vx;
  const double xm = v0 * S.t1 / 2 + u[kMidDx], zm = s0.z + u[kMidDz];
  const double xe = v0 * S.t2 + u[kTakeoffDx], ze = s0.z + u[kTakeoffDz];
  const double vxe = v0 + u[kTakeoffDvx], vze = u[kTakeoffVz];
  S.pm = s0.pitch + u[kMidDpitch];
  S.pe = s0.pitch + u[kTakeoffDpitch];
  S.we = u[kTakeoffRate];

  AxisSolution ax, az;
  if (!solveAxis(m, 0.0, s0.x, s0.vx, S.two_step, S.t1, S.T2, xm, xe, vxe, ax)) return false;
  if (!solveAxis(m, g, s0.z, s0.vz, S.two_step, S.t1, S.T2, zm, ze, vze, az)) return false;
  S.X1 = ax.P1;
  S.Z1 = az.P1;
  S.X2 = ax.P2;
  S.Z2 = az.P2;
  S.Fx1 = ax.F1;
  S.Fz1 = az.F1;
  S.Fx2 = ax.F2;
  S.Fz2 = az.F2;
  S.VX1 = derivative(S.X1);
  S.VZ1 = derivative(S.Z1);
  S.VX2 = derivative(S.X2);
  S.VZ2 = derivative(S.Z2);
  S.D1 = {};
  S.D2 = {};
  S.handover_t1 = 0.0;
  S.stance_momentum = false;
  S.takeoff_posture = false;
  if (!solvePitch(M, S)) return false;

  // Flight: ballistic CoM; Tf is when the CoM descends to the landing height (standing in the
  // landing posture on the landing surface), which the legs' schedule is in fractions of. The
  // touchdown t3, the first wheel on the surface, comes with the flight attitude
  // (solveFlight), between t3_min (the CoM at the surface plus the landing posture's reach,
  // the lowest it can be at any pitch) and t2 + Tf.
  const double z_td = M.landing_surface + M.z_land;
  const double disc = S.takeoff.vz * S.takeoff.vz + 2 * g * (S.takeoff.z - z_td);
  if (!(disc >= 0.0)) return false;
  S.Tf = (S.takeoff.vz + std::sqrt(disc)) / g;
  if (!(S.Tf > 1e-3)) return false;
  S.t3 = S.t2 + S.Tf;
  const double disc_min =
      S.takeoff.vz * S.takeoff.vz + 2 * g * (S.takeoff.z - M.landing_surface - M.touchdown_reach);
  S.t3_min = std::min(
      S.t2 +
          (disc_min >= 0.0 ? S.takeoff.vz + std::sqrt(disc_min) : std::max(S.takeoff.vz, 0.0)) / g,
      S.t3);
  if (complete) {
    if (!solveStanceMomentum(M, S)) return false;
    solveTakeoffPosture(M, S);
    solveFlight(M, S);
  }
  return true;
}

double stanceMomentumExcess(const JumpModelConstants& M, const std::array<Eigen::Vector2d, 2>& q,
                            const std::array<Eigen::Vector2d, 2>& qd,
                            const std::array<double, 2>& wheel_rate, double w) {
  double i_total = 0.0, h = 0.0;
  flightMomentum(M, q, qd, i_total, h);
  // The wheels' spin about +y: the joint rate plus the shank's rotation (-w + qd1 + qd2).
  double spin = 0.0;
  for (int pair = 0; pair < 2; ++pair) {
    const PairGeometry& geo = pair == 0 ? M.hind : M.front;
    spin += 2.0 * geo.i_wheel * (wheel_rate[pair] - w + qd[pair][0] + qd[pair][1]);
  }
  // Nose-up (about -y) momentum of the whole robot about its CoM, less I theta'.
  return i_total * w - h - spin - M.inertia * w;
}

double stanceMomentumExcess(const JumpModelConstants& M, const Sample& smp) {
  return stanceMomentumExcess(M, {smp.hind.q, smp.front.q}, {smp.hind.qd, smp.front.qd},
                              {smp.hind.wheel_rate, smp.front.wheel_rate}, smp.s.pitch_rate);
}

bool solveStanceMomentum(const JumpModelConstants& M, Solved& S) {
  if (S.stance_momentum || !M.settings.stance_momentum) return true;
  S.stance_momentum = true;
  // E at nodes of the first pass's path, then E - E(0) interpolated per phase and the pitch
  // solved again. Phase 1: a cubic through t = 0, t1/3, 2 t1/3, t1; phase 2: a quadratic through
  // its start, middle and end (the legs extend fastest at the end of the push, where E bends
  // most). E(0) is the model's (M.e0). The phase ends are converged postures the model needs
  // anyway: a two-step's front posture at t1, and its take-off posture at t2 (first pass); a
  // simultaneous take-off's posture at t2, which the second pass leaves as it is (the state
  // at t2 is u's). The nodes between converge to 1e-5 m from the CoM offset's linear
  // interpolation between the phase ends.
  Sample smp;
  constexpr double kNodeTolerance = 1e-5;  // [m]
  auto excess = [&](double t, bool phase2, const Eigen::Vector2d& c, bool strict) {
    contactSample(M, S, t, smp, phase2, c, /*converge=*/true,
                  strict ? kCoMTolerance : kNodeTolerance);
    return stanceMomentumExcess(M, smp) - M.e0;
  };
  std::array<double, 4> t{}, y{};
  t[3] = S.t1;
  Eigen::Vector2d c_t1;
  if (S.two_step) {
    y[3] = S.e_t1 - M.e0;
    c_t1 = S.c_front_t1;
  } else {
    if (!S.takeoff_posture) {
      contactSample(M, S, S.t1, smp, /*phase2=*/false, M.c0, /*converge=*/true);
      setTakeoffPosture(smp, S);
    }
    y[3] = stanceMomentumExcess(M, S.takeoff_sample) - M.e0;
    c_t1 = S.takeoff_sample.c;
  }
  for (int i = 1; i < 3; ++i) {
    t[i] = S.t1 * i / 3.0;
    y[i] = excess(t[i], false, M.c0 + (c_t1 - M.c0) * (i / 3.0), false);
  }
  S.D1 = interpolate(t, y, 4);
  if (S.two_step) {
    t = {0.0, S.T2 / 2, S.T2, 0.0};
    y[0] = y[3] - S.handover_t1;  // the front pair at rest from t1 on
    y[2] = excess(S.t2, true, c_t1, /*strict=*/true);
    y[1] = excess(S.t1 + t[1], true, 0.5 * (c_t1 + smp.c), false);
    S.D2 = interpolate(t, y, 3);
  }
  return solvePitch(M, S);
}

void addUnloadingTailMoment(const JumpModelConstants& M, Solved& S) {
  S.tail_h = M.liftoff_correction.momentum;
  if (!(S.tail_weight > 0.0)) return;
  if (!M.settings.balanced_stance) {
    // The model's split: the moment of Eq. S-0 at t2, which the take-off sample's forces make.
    S.tail_h += S.tail_weight * groundMoment(S.takeoff_sample);
    return;
  }
  const StanceAccelerations acc =
      stanceAccelerations(M, S, TakeoffAccelerations(S), S.takeoff_sample);
  S.tail_h += S.tail_weight * momentumRate(M, S.takeoff_sample, acc);
}

PlanarState stateAt(const JumpModelConstants& M, const Solved& S, double t, double g) {
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

PlanarState ballisticG(const PlanarState& s, double dt, double g) {
  PlanarState r = s;
  r.x += s.vx * dt;
  r.z += s.vz * dt - 0.5 * g * dt * dt;
  r.vz -= g * dt;
  r.pitch += s.pitch_rate * dt;
  return r;
}

}  // namespace wj::planner::detail
