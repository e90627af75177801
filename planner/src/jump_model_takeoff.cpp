// The take-off of the jump model (docs/planner.md, "Take-off"): for a candidate u, the force
// polynomials of each axis from the sampled positions (a linear solve), the CoM in closed
// form, and the pitch from the moments of the contact forces about the CoM.

#include <Eigen/LU>
#include <cmath>

#include "jump_model_internal.h"

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

}  // namespace

// Solves the take-off for candidate u and, with `flight`, its converged posture at take-off
// and the flight attitude (otherwise solveTakeoffPosture() and solveFlight() complete S
// later). Returns false if u has no valid trajectory.
bool solve(const JumpModelConstants& M, const Eigen::Ref<const Eigen::VectorXd>& u, Solved& S,
           bool flight) {
  const auto& st = M.settings;
  const PlanarState& s0 = M.initial;
  const double m = M.mass, g = st.gravity, I = M.inertia;
  S.two_step = M.task.mode == TakeoffMode::TwoStep;
  S.t1 = u[kT1];
  S.T2 = S.two_step ? u[kT2MinusT1] : 0.0;
  S.t2 = S.t1 + S.T2;
  if (!(S.t1 > 0.0) || !(S.T2 >= 0.0)) return false;
  const double v0 = s0.vx;
  const double xm = v0 * S.t1 / 2 + u[kMidDx], zm = s0.z + u[kMidDz], pm = s0.pitch + u[kMidDpitch];
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
  const double dH = M.d_hind, dd = M.d_front - M.d_hind;
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
      M.task.target.event == TargetEvent::Touchdown ? M.task.target.height : M.z_land;
  const double disc = S.takeoff.vz * S.takeoff.vz + 2 * g * (S.takeoff.z - z_td);
  if (!(disc >= 0.0)) return false;
  S.Tf = (S.takeoff.vz + std::sqrt(disc)) / g;
  if (!(S.Tf > 1e-3)) return false;
  S.t3 = S.t2 + S.Tf;
  if (S.two_step) {
    Sample smp;
    // The front legs hold their t1 posture relative to the body once lifted.
    contactSample(M, S, S.t1, smp, /*phase2=*/false, M.c0, /*converge=*/true);
    S.front_b_t1 = M.leg.forward(smp.front.q);
    S.front_wheel_rate_t1 = smp.front.wheel_rate;
    S.front_pose_t1 = M.leg.inversePose(S.front_b_t1, &S.front_reach_t1);
  }
  if (flight) {
    solveTakeoffPosture(M, S);
    solveFlight(M, S);
  }
  return true;
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
