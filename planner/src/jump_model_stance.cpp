// The stance of the jump model: at each take-off sample, where the legs are (the wheels on
// the ground, the base from the CoM and the posture-dependent CoM offset), their joint rates,
// and the joint and wheel torques that balance the planned ground forces (docs/planner.md,
// "Where the base is").

#include <algorithm>
#include <cmath>

#include "jump_model_internal.h"

namespace wj::planner::detail {

namespace {

// Fixed-point steps for the posture-dependent CoM offset per sample, warm-started from the
// previous sample (the contraction factor is the legs' mass fraction, ~0.35), plus a final pass.
constexpr int kCoMIterations = 1;
// ... and, where a sample must be converged, at most this many (to `tolerance`).
constexpr int kCoMMaxIterations = 50;

// Joint torques of a leg in contact (massless links, force at the contact point), and the
// wheel's rate and torque.
void statics(const JumpModelConstants& M, const PlanarState& s, const Rot2& R, const LegPose& pose,
             const Eigen::Vector2d& f, double axle_vx, PairSample& p) {
  const double r = M.wheel_radius;
  p.f = f;
  // The contact point on the ground, r less the tyre's sink below the axle.
  const Eigen::Vector2d contact_b =
      M.leg.forward(pose) + R.transposeTimes(Eigen::Vector2d(0.0, p.sink.x - r));
  const Eigen::Vector2d f_b = R.transposeTimes(f);
  p.tau = M.leg.balancingTorque(pose, contact_b, f_b);
  p.haa_fz = f_b.y();
  // Rolling without slip: wheel rate about +y is v_axle / r; the shank turns at
  // -pitch_rate + qd1 + qd2 about +y (nose-up pitch is a rotation about -y).
  p.wheel_rate = axle_vx / r - (-s.pitch_rate + p.qd[0] + p.qd[1]);
  p.wheel_tau = r * f.x();
  // A loaded tyre rolls on ratio x r and slips at its traction over its slip stiffness.
  p.wheel_rate_loaded =
      p.wheel_rate + M.tyre_rolling_excess * axle_vx / r + p.wheel_tau / M.tyre_slip_torque;
}

// Each pair's tyre sink at a sample (zero for a lifted pair or a rigid wheel): the Hertz law
// on the pair's normal force shared by its two wheels.
void setTyreSinks(const JumpModelConstants& M, const Solved& S, double local, bool phase2,
                  PairSample& H, PairSample& F) {
  H.sink = F.sink = TyreSink{};
  if (!(M.tyre_hertz > 0.0)) return;
  auto sink_of = [&](const Poly& fz) {
    const std::array<double, 3> f = valueAndDerivatives(fz, local);
    return tyreSink(M.tyre_hertz, 0.5 * f[0], 0.5 * f[1], 0.5 * f[2]);
  };
  H.sink = sink_of(phase2 ? S.fHz2 : S.fHz1);
  if (!phase2) F.sink = sink_of(S.fFz1);
}

}  // namespace

TyreSink tyreSink(double k, double f, double fd, double fdd) {
  TyreSink out;
  if (!(k > 0.0)) return out;
  double x = 0.0, x_f = 0.0, x_ff = 0.0;  // x(F) and its first two derivatives in F
  if (f >= kTyreSinkBlendN) {
    x = std::cbrt(f / k);
    x *= x;
    x_f = 2.0 / 3.0 * x / f;
    x_ff = -x_f / (3.0 * f);
  } else {
    // The cubic in r = F / F_b through 0 with Hertz's value, slope and curvature at r = 1:
    // x_b (14 r - 7 r^2 + 2 r^3) / 9; below r = -1 (a pulling force, which the normal-force
    // margin refuses) its tangent there.
    double xb = std::cbrt(kTyreSinkBlendN / k);
    xb *= xb;
    const double ratio = f / kTyreSinkBlendN, r = std::max(ratio, -1.0);
    const double scale = xb / 9.0;
    x = scale * r * (14.0 + r * (-7.0 + 2.0 * r));
    x_f = scale / kTyreSinkBlendN * (14.0 + r * (-14.0 + 6.0 * r));
    x_ff = scale / (kTyreSinkBlendN * kTyreSinkBlendN) * (-14.0 + 12.0 * r);
    if (ratio < -1.0) {  // the tangent at r = -1
      x += x_f * (f + kTyreSinkBlendN);
      x_ff = 0.0;
    }
  }
  out.x = x;
  out.rate = x_f * fd;
  out.acc = x_ff * fd * fd + x_f * fdd;
  return out;
}

// The converged posture at take-off (S.takeoff_sample) of a solved take-off, which
// the flight needs (and the FromTakeoff chain).
void solveTakeoffPosture(const JumpModelConstants& M, Solved& S) {
  if (S.takeoff_posture) return;
  Sample smp;
  contactSample(M, S, S.t2, smp, S.two_step, M.c0, /*converge=*/true);
  setTakeoffPosture(smp, S);
}

void setTakeoffPosture(const Sample& smp, Solved& S) {
  S.takeoff_posture = true;
  S.takeoff_sample = smp;
}

// The CoM in the base frame for the pairs' poses.
Eigen::Vector2d comOffset(const JumpModelConstants& M, const LegPose& hind, const LegPose& front) {
  Eigen::Vector2d first = M.moment_fixed;
  const double l1 = M.leg.l1;
  for (int pair = 0; pair < 2; ++pair) {
    const LegPose& P = pair == 0 ? hind : front;
    const PairGeometry& g = pair == 0 ? M.hind : M.front;
    const Eigen::Vector2d knee(-l1 * P.s1, -l1 * P.c1);
    first += 2.0 * (g.m_thigh * (g.hfe_b + Rv(P.s1, P.c1, g.c_thigh)) +
                    g.m_lower * (g.hfe_b + knee + Rv(P.s12, P.c12, g.c_lower)));
  }
  return first / M.mass;
}

// Its Jacobians d c / d q_pair with respect to each pair's (HFE, KFE): pair 0 hind, 1 front.
std::array<Eigen::Matrix2d, 2> comJacobians(const JumpModelConstants& M, const LegPose& hind,
                                            const LegPose& front) {
  std::array<Eigen::Matrix2d, 2> C;
  const double l1 = M.leg.l1;
  for (int pair = 0; pair < 2; ++pair) {
    const LegPose& P = pair == 0 ? hind : front;
    const PairGeometry& g = pair == 0 ? M.hind : M.front;
    const Eigen::Vector2d dknee(-l1 * P.c1, l1 * P.s1);
    C[pair].col(0) = 2.0 / M.mass *
                     (g.m_thigh * dRv(P.s1, P.c1, g.c_thigh) +
                      g.m_lower * (dknee + dRv(P.s12, P.c12, g.c_lower)));
    C[pair].col(1) = 2.0 / M.mass * g.m_lower * dRv(P.s12, P.c12, g.c_lower);
  }
  return C;
}

LegPose poseOf(const Eigen::Vector2d& q) {
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
void contactSample(const JumpModelConstants& M, const Solved& S, double t, Sample& out, bool phase2,
                   const Eigen::Vector2d& c_guess, bool converge, double tolerance) {
  contactPosture(M, S, t, out, phase2, c_guess, converge, tolerance);
  contactStatics(M, S, out);
}

// The first half of contactSample: the state, the axles, the CoM offset out.c and the poses
// (sines and cosines only, but for the front pair's fixed phase-2 pose). What the next
// sample's warm start needs, and no more.
void contactPosture(const JumpModelConstants& M, const Solved& S, double t, Sample& out,
                    bool phase2, const Eigen::Vector2d& c_guess, bool converge, double tolerance) {
  out.t = t;
  out.t1 = S.t1;
  out.phase2 = phase2;
  PlanarState s;
  double dH = M.d_hind, dHdot = 0.0;
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
  const double r = M.wheel_radius;
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
  setTyreSinks(M, S, local, phase2, H, F);
  H.axle = Eigen::Vector2d(s.x + dH, r - H.sink.x);
  out.hind_axle_vx = s.vx + dHdot;
  Eigen::Vector2d& relH = out.rel_h;
  Eigen::Vector2d& relF = out.rel_f;
  relH = relative(H.axle);
  relF.setZero();
  F.contact = !phase2;
  if (F.contact) {
    F.axle = Eigen::Vector2d(s.x + M.d_front, r - F.sink.x);
    relF = relative(F.axle);
  }
  LegPose& pH = out.pose_h;
  LegPose& pF = out.pose_f;
  pF = LegPose{};
  if (phase2) {
    // The lifted front pair brakes from its speeds at t1, then holds (no inverse kinematics).
    const bool braking = local < std::max(S.front_brake[0].t_stop, S.front_brake[1].t_stop);
    pF = braking ? poseOf(brakePosture(S.front_brake, local, nullptr)) : S.front_pose_stop;
    F.reach = S.front_reach_t1;
  }
  Eigen::Vector2d c = c_guess;
  Eigen::Vector2d step_before = Eigen::Vector2d::Zero();
  for (int it = 0; it < (converge ? kCoMMaxIterations : kCoMIterations); ++it) {
    // c(q) needs only the sines and cosines of the joint angles.
    pH = M.leg.inversePose(relH - M.hind.hfe_b + c, &H.reach, /*angles=*/false);
    if (F.contact) pF = M.leg.inversePose(relF - M.front.hfe_b + c, &F.reach, false);
    const Eigen::Vector2d c_next = comOffset(M, pH, pF);
    const Eigen::Vector2d step = c_next - c;
    c = c_next;
    if (step.squaredNorm() < tolerance * tolerance) break;
    // The map is close to linear: every second step, extrapolate the geometric series of the
    // last two steps (vector Aitken, Irons-Tuck).
    const Eigen::Vector2d dd = step - step_before;
    if (it % 2 == 1 && dd.squaredNorm() > 0.0) c -= (step.dot(dd) / dd.squaredNorm()) * step;
    step_before = step;
  }
  pH = M.leg.inversePose(relH - M.hind.hfe_b + c, &H.reach, false);
  if (F.contact) pF = M.leg.inversePose(relF - M.front.hfe_b + c, &F.reach, false);
  out.c = comOffset(M, pH, pF);
  if (!F.contact) F.axle = com + R * (-c + M.front.hfe_b + M.leg.forward(pF));
}

// The second half of contactSample, on a sample from contactPosture: joint angles, joint
// rates, torques and the wheels.
void contactStatics(const JumpModelConstants& M, const Solved& S, Sample& out) {
  const PlanarState& s = out.s;
  PairSample& H = out.hind;
  PairSample& F = out.front;
  LegPose& pH = out.pose_h;
  LegPose& pF = out.pose_f;
  M.leg.solveAngles(pH);
  if (F.contact) M.leg.solveAngles(pF);  // else the phase-2 pose, solved once (Solved)
  const std::array<Eigen::Matrix2d, 2> C_pair = comJacobians(M, pH, pF);
  H.q = pH.q;
  F.q = pF.q;
  // The axles' rates relative to the CoM in the base frame.
  const Eigen::Vector2d vcom(s.vx, s.vz);
  auto rate = [&](const Eigen::Vector2d& rel, const Eigen::Vector2d& v) -> Eigen::Vector2d {
    return out.R.transposeTimes(v - vcom) + s.pitch_rate * Eigen::Vector2d(rel.y(), -rel.x());
  };
  // The axles roll on the ground and rise out of the tyres' sink (0 - x': +0 for a rigid
  // wheel, as the rows have always had it).
  const Eigen::Vector2d relH_dot =
      rate(out.rel_h, Eigen::Vector2d(out.hind_axle_vx, 0.0 - H.sink.rate));
  const Eigen::Vector2d relF_dot = F.contact
                                       ? rate(out.rel_f, Eigen::Vector2d(s.vx, 0.0 - F.sink.rate))
                                       : Eigen::Vector2d::Zero();
  // Joint rates: b_i = rel_i - hfe_i + c(q) and b_i' = J_i q_i', so
  // (J_i - C_i) q_i' - C_j q_j' = rel_i' for the pairs in contact.
  const Eigen::Matrix2d JH = M.leg.jacobian(pH);
  if (F.contact) {
    const Eigen::Matrix2d JF = M.leg.jacobian(pF);
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
    // The lifted front pair's braking moves the CoM in the base: (J_H - C_H) qd_H =
    // rel_H' + C_F qd_F.
    brakePosture(S.front_brake, out.local, &F.qd);
    const Eigen::Matrix2d A = JH - C_pair[0];
    H.qd = std::abs(A.determinant()) > 1e-12
               ? Eigen::Vector2d(A.inverse() * (relH_dot + C_pair[1] * F.qd))
               : Eigen::Vector2d(1e3, 1e3);
    F.wheel_rate = F.wheel_rate_loaded = S.front_wheel_rate_t1;  // in the air: no tyre load
  }
  // Where the joints come to rest if they brake from here: at its lift-off sample each pair
  // must stop kBrakeLimitClearance short of its limits (emitContact).
  H.q_stop = H.q;
  F.q_stop = F.q;
  H.brakes = F.brakes = false;
  auto brake_from = [&](int pair, PairSample& p, double share) {
    const std::array<JointBrake, 2> b = startBrake(M, pair, p.q, p.qd, share);
    p.q_stop = Eigen::Vector2d(b[0].q_stop, b[1].q_stop);
    p.brakes = true;
  };
  const bool at_t2 = out.t >= S.t2 - 1e-9;
  if (at_t2) brake_from(0, H, kBrakeTorqueShare);
  if (F.contact && (at_t2 || (S.two_step && out.t >= S.t1 - 1e-9)))
    brake_from(1, F, S.two_step ? frontLiftBrakeShare(M) : kBrakeTorqueShare);
  const double local = out.local;
  const Eigen::Vector2d fH = out.phase2 ? Eigen::Vector2d(S.fHx2(local), S.fHz2(local))
                                        : Eigen::Vector2d(S.fHx1(local), S.fHz1(local));
  statics(M, s, out.R, pH, 0.5 * fH, out.hind_axle_vx, H);
  if (F.contact) {
    const Eigen::Vector2d fF(S.fFx1(local), S.fFz1(local));
    statics(M, s, out.R, pF, 0.5 * fF, s.vx, F);
  }
}

}  // namespace wj::planner::detail
