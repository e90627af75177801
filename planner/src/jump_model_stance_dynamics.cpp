// The legs' own dynamics in the take-off: the exact accelerations of a contact sample and the
// legs' joint torques from them (jump_model_stance_dynamics.h; docs/planner.md, "Stance
// torques").

#include "jump_model_stance_dynamics.h"

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace wj::planner::detail {

// The legs' own dynamics in the take-off (issue 22, sessions 13 and 15; docs/planner.md,
// "Stance torques"). The statics torques balance the ground force with massless links; but 12
// of the 22.5 kg are legs and wheels, which accelerate with the push (the knees at up to ~1,000
// rad/s^2 before the lift-off): without their inertia and weight in the feed-forward the joints
// tracked the plan's speeds 2-4 % short at t2, which left Simbody's angular momentum there
// 0.1-0.17 kg m^2/s below the plan's. For each leg of a pair in contact, the Newton-Euler
// balance of the links below each joint about its axis (Featherstone 2008, Sec. 5.3):
//   tau_j = a_j . [sum_i ((p_i - o_j) x m_i (a_i + g z) + I_i phi_i'' y) - (p_c - o_j) x f_c],
// with f_c the wheel's share of its pair's force at p_c, below the axle, and the wheel's spin.
// The links' accelerations are exact: the CoM's and the pitch's from the take-off polynomials,
// the joints' from the contact geometry differentiated twice (stanceAccelerations), the
// links' from the joints' by the forward recursion of the same section. The links' pitch
// inertia only (planar motion).

TakeoffAccelerations::TakeoffAccelerations(const Solved& S)
    : ax1(derivative(S.VX1)),
      az1(derivative(S.VZ1)),
      aw1(derivative(S.W1)),
      ax2(derivative(S.VX2)),
      az2(derivative(S.VZ2)),
      aw2(derivative(S.W2)),
      ddd_h2(derivative(S.ddH2)) {}

StanceDynamics::StanceDynamics(const JumpModelConstants& M, const Solved& S)
    : TakeoffAccelerations(S) {
  const std::vector<Eigen::Isometry3d> X_B = M.robot.calcLinkPoses(M.init_input.q);
  const auto& joints = M.robot.joints();
  const auto& links = M.robot.links();
  for (const model::Leg leg_id : model::kLegs) {
    const int haa = model::jointIndex(leg_id, model::JointKind::HAA);
    const model::JointSpec &J0 = joints[haa], &J1 = joints[haa + 1];
    const Eigen::Isometry3d X_haa = X_B[J0.parent_link] * J0.X_PJ;
    const Eigen::Isometry3d& X_hip = X_B[J0.child_link];
    const Eigen::Isometry3d X_BH = X_hip * J1.X_PJ;
    const Eigen::Isometry3d X_HB = X_BH.inverse();
    Chain& c = leg[static_cast<std::size_t>(leg_id)];
    c.R_hfe = X_BH.linear();
    c.t_hfe = X_BH.translation();
    c.e_y = X_HB.linear() * Eigen::Vector3d::UnitY();
    c.o_haa = X_HB * X_haa.translation();
    c.axis_haa = X_HB.linear() * (X_haa.linear() * J0.axis);
    c.axis[0] = c.axis_haa;
    for (int m = 1; m < 4; ++m) {
      const model::JointSpec& J = joints[haa + m];
      const bool about_y = std::abs(std::abs(J.axis.y()) - 1.0) < 1e-12;
      const bool aligned = m == 1 || J.X_PJ.linear().isIdentity(1e-12);
      if (!about_y || !aligned)
        throw std::invalid_argument("JumpModel: the stance torques need joint " + J.name +
                                    " to turn about its parent's y axis (a planar leg below HFE)");
      c.axis[static_cast<std::size_t>(m)] = J.axis;
      c.sign[static_cast<std::size_t>(m - 1)] = J.axis.y() > 0.0 ? 1.0 : -1.0;
    }
    c.t_kfe = joints[haa + 2].X_PJ.translation();
    c.t_wheel = joints[haa + 3].X_PJ.translation();
    for (int m = 0; m < 4; ++m) {
      const model::Inertia& in = links[joints[haa + m].child_link].inertia;
      c.com[static_cast<std::size_t>(m)] =
          m == 0 ? Eigen::Vector3d(X_HB * (X_hip * in.com)) : in.com;
      c.mass[static_cast<std::size_t>(m)] = in.mass;
      c.i_yy[static_cast<std::size_t>(m)] = in.inertia_com(1, 1);
    }
  }
}

namespace {

// A braking joint's acceleration at time tau after its start (the derivative of
// JointBrake::at's rate) [rad/s^2].
double brakeAcceleration(const JointBrake& b, double tau) {
  if (tau >= b.t_stop) return 0.0;
  if (tau < b.t_a) return -b.sign * b.lambda * (b.w_nl - b.w0) * std::exp(b.lambda * tau);
  const double x = (tau - b.t_a) / b.t_b, x2 = x * x, x3 = x2 * x;
  return -b.sign * b.decel * (2.0 * x3 - 3.0 * x2 + 1.0 + b.kappa * (x3 - 2.0 * x2 + x));
}

// perp(v) = J v with J the rotation by +90 degrees in x-z: d/dt (R v) = pitch' R J v.
Eigen::Vector2d perp(const Eigen::Vector2d& v) {
  return {-v.y(), v.x()};
}

}  // namespace

// A sample's accelerations. The pairs in contact keep their axles where the contact model puts
// them: b_i(q_i) = rel_i - hfe_i + c(q) with rel_i = R^T (axle_i - com), so, differentiated
// twice, (J_i - C_i) q_i'' - C_j q_j'' = rel_i'' + h_c - h_i, where h_i and h_c are the terms of
// b_i'' and c'' with q'' = 0 (the links' centripetal terms: d^2/dq^2 of a rotated vector is
// minus the vector); the same matrix as the joint rates' (contactStatics). A lifted front pair
// brakes: its q'' is the braking's. The base origin from com = p_B + R c.
StanceAccelerations stanceAccelerations(const JumpModelConstants& M, const Solved& S,
                                        const TakeoffAccelerations& D, const Sample& smp) {
  StanceAccelerations acc;
  const double local = smp.local;
  const PlanarState& s = smp.s;
  double dH_dd = 0.0;
  if (!smp.phase2) {
    acc.com = Eigen::Vector2d(D.ax1(local), D.az1(local));
    acc.pitch = D.aw1(local);
  } else {
    acc.com = Eigen::Vector2d(D.ax2(local), D.az2(local));
    acc.pitch = D.aw2(local);
    dH_dd = D.ddd_h2(local);
  }
  acc.hind_axle_x = acc.com.x() + dH_dd;
  const double w = s.pitch_rate, w_dot = acc.pitch;
  const Rot2& R = smp.R;
  const PairSample &H = smp.hind, &F = smp.front;
  const LegPose &pH = smp.pose_h, &pF = smp.pose_f;
  const double l1 = M.leg.l1, l2 = M.leg.l2;
  // The centripetal terms of c'' (both pairs) and of each pair's b''.
  Eigen::Vector2d h_c = Eigen::Vector2d::Zero();
  std::array<Eigen::Vector2d, 2> h_b;
  for (int pair = 0; pair < 2; ++pair) {
    const LegPose& P = pair == 0 ? pH : pF;
    const PairGeometry& g = pair == 0 ? M.hind : M.front;
    const Eigen::Vector2d& qd = pair == 0 ? H.qd : F.qd;
    const double w1 = qd[0] * qd[0], w12 = (qd[0] + qd[1]) * (qd[0] + qd[1]);
    const Eigen::Vector2d knee(-l1 * P.s1, -l1 * P.c1);
    h_c -= 2.0 / M.mass *
           (g.m_thigh * w1 * Rv(P.s1, P.c1, g.c_thigh) +
            g.m_lower * (w1 * knee + w12 * Rv(P.s12, P.c12, g.c_lower)));
    h_b[pair] =
        Eigen::Vector2d(l1 * P.s1 * w1 + l2 * P.s12 * w12, l1 * P.c1 * w1 + l2 * P.c12 * w12);
  }
  const Eigen::Vector2d vcom(s.vx, s.vz);
  // The axles roll on the ground and rise out of the tyres' sink: (vx, -x'), (ax, -x''),
  // written 0 - x' so that a rigid wheel keeps +0 (contactStatics; the plan digests see it).
  auto rel_dd = [&](const Eigen::Vector2d& rel, double axle_vx, double axle_ax,
                    const TyreSink& sink) {
    const Eigen::Vector2d u = R.transposeTimes(Eigen::Vector2d(axle_vx, 0.0 - sink.rate) - vcom);
    return Eigen::Vector2d(R.transposeTimes(Eigen::Vector2d(axle_ax, 0.0 - sink.acc) - acc.com) -
                           2.0 * w * perp(u) - w_dot * perp(rel) - w * w * rel);
  };
  const std::array<Eigen::Matrix2d, 2> C = comJacobians(M, pH, pF);
  const Eigen::Matrix2d A = M.leg.jacobian(pH) - C[0];
  const Eigen::Vector2d r_h =
      rel_dd(smp.rel_h, smp.hind_axle_vx, acc.hind_axle_x, H.sink) + h_c - h_b[0];
  if (F.contact) {
    // As for the rates: [A B; C D] with B = -C_F, C = -C_H, D = J_F - C_F (Schur complement).
    const Eigen::Vector2d r_f = rel_dd(smp.rel_f, s.vx, acc.com.x(), F.sink) + h_c - h_b[1];
    const Eigen::Matrix2d B = -C[1], Cm = -C[0], Dm = M.leg.jacobian(pF) - C[1];
    const double det_a = A.determinant();
    if (std::abs(det_a) > 1e-12) {
      const Eigen::Matrix2d A_inv = A.inverse();
      const Eigen::Matrix2d Sc = Dm - Cm * A_inv * B;
      const double det_s = Sc.determinant();
      if (std::abs(det_a * det_s) > 1e-12 && std::abs(det_s) > 1e-14) {
        const Eigen::Vector2d y = A_inv * r_h;
        acc.qdd[1] = Sc.inverse() * (r_f - Cm * y);
        acc.qdd[0] = y - A_inv * (B * acc.qdd[1]);
      }
    }
  } else {
    for (int j = 0; j < 2; ++j) acc.qdd[1][j] = brakeAcceleration(S.front_brake[j], local);
    if (std::abs(A.determinant()) > 1e-12) acc.qdd[0] = A.inverse() * (r_h + C[1] * acc.qdd[1]);
  }
  // c, c' and c'' in the base; the base origin p_B = com - R c and its acceleration.
  const Eigen::Vector2d c_d = C[0] * H.qd + C[1] * F.qd;
  const Eigen::Vector2d c_dd = C[0] * acc.qdd[0] + C[1] * acc.qdd[1] + h_c;
  acc.base_pos = Eigen::Vector2d(s.x, s.z) - R * smp.c;
  acc.base = acc.com -
             (R * c_dd + 2.0 * w * perp(R * c_d) + w_dot * perp(R * smp.c) - w * w * (R * smp.c));
  return acc;
}

namespace {

// The wheel's absolute spin acceleration's part that is not the shank's: its joint
// acceleration is axle_ax / r + pitch'' - q1'' - q2'' (rolling without slip, contactStatics).
double wheelAcceleration(const JumpModelConstants& M, const StanceAccelerations& acc, int pair) {
  const double axle_ax = pair == 0 ? acc.hind_axle_x : acc.com.x();
  return axle_ax / M.wheel_radius + acc.pitch - acc.qdd[pair][0] - acc.qdd[pair][1];
}

}  // namespace

// H(t) = stanceMomentumExcess + I theta' is a function of the joints' angles and rates, the
// wheels' rates and the pitch rate (not of the pitch, nor of the CoM's motion), so its rate is
// the directional derivative along (q', q'', the wheels' accelerations, theta''): a central
// difference over +-1e-5 s of that line, exact to ~1e-9 of H's scale (its third derivative
// times eps^2), with no posture solve.
double momentumRate(const JumpModelConstants& M, const Sample& smp,
                    const StanceAccelerations& acc) {
  constexpr double eps = 1e-5;  // [s]
  auto h_at = [&](double e) {
    std::array<Eigen::Vector2d, 2> q, qd;
    std::array<double, 2> wheel{};
    for (int pair = 0; pair < 2; ++pair) {
      const PairSample& p = smp.pair(pair);
      q[pair] = p.q + e * p.qd;
      qd[pair] = p.qd + e * acc.qdd[pair];
      // A lifted front pair's wheel holds its rate (contactStatics).
      const double wheel_acc = p.contact ? wheelAcceleration(M, acc, pair) : 0.0;
      wheel[pair] = p.wheel_rate + e * wheel_acc;
    }
    const double w = smp.s.pitch_rate + e * acc.pitch;
    return stanceMomentumExcess(M, q, qd, wheel, w) + M.inertia * w;
  };
  return (h_at(eps) - h_at(-eps)) / (2.0 * eps);
}

double groundMoment(const Sample& smp) {
  double moment = 0.0;
  for (const PairSample* p : {&smp.hind, &smp.front})
    if (p->contact)  // two wheels; the contact point on the ground below the axle
      moment += 2.0 * ((p->axle.x() - smp.s.x) * p->f.y() + smp.s.z * p->f.x());
  return moment;
}

void balancePairForces(const JumpModelConstants& M, const StanceAccelerations& acc, Sample& smp) {
  if (!smp.hind.contact || !smp.front.contact) return;
  const double lever = smp.front.axle.x() - smp.hind.axle.x();
  if (!(lever > 0.0)) return;
  // Per wheel: the pairs' normal forces differ by 2 df, whose moment is 2 df * lever.
  const double df = (momentumRate(M, smp, acc) - groundMoment(smp)) / (2.0 * lever);
  smp.front.f.y() += df;
  smp.hind.f.y() -= df;
}

namespace {

// Rotation about y by the angle of sine sn and cosine cs.
Eigen::Vector3d rotateY(double sn, double cs, const Eigen::Vector3d& v) {
  return {cs * v.x() + sn * v.z(), v.y(), -sn * v.x() + cs * v.z()};
}

// A point of a leg below H, in H: its position, and its velocity and acceleration relative to
// H (the leg turns about H's y axis).
struct LegPoint {
  Eigen::Vector3d r, v, a;
};

// The point at rho (in H's axes) from `origin` on a link turning at w, w' about H's y axis.
LegPoint onLink(const LegPoint& origin, const Eigen::Vector3d& rho, double w, double w_dot) {
  const Eigen::Vector3d y_x_rho(rho.z(), 0.0, -rho.x());  // y x rho
  return {origin.r + rho, origin.v + w * y_x_rho,
          origin.a + w_dot * y_x_rho - w * w * Eigen::Vector3d(rho.x(), 0.0, rho.z())};
}

// One leg's Newton-Euler balance in H, the frame of its HFE joint (Featherstone 2008, Sec.
// 5.3): H's origin accelerates with the base, which turns at w_B = -pitch' e_y; a point at r
// with velocity v and acceleration a relative to H has the acceleration a_H + w_B' x r +
// w_B x (w_B x r) + 2 w_B x v + a (the transport theorem). The links' pitch accelerations about
// the world's y axis are -pitch'' + e_y . (their turn in H)''.
struct LegBalance {
  const JumpModelConstants& M;
  const StanceDynamics::Chain& c;
  const Rot2& R;
  double w, w_dot;                  // the base's nose-up pitch rate and acceleration
  const Eigen::Vector2d& base_acc;  // the base origin's acceleration (world x-z)
  const LegPose& pose;
  const Eigen::Vector2d &qd, &qdd;  // (HFE, KFE)

  // World x-z vectors in H's axes.
  Eigen::Vector3d inH(const Eigen::Vector2d& v_world) const {
    const Eigen::Vector2d b = R.transposeTimes(v_world);
    return Eigen::Vector3d(c.R_hfe.transpose() * Eigen::Vector3d(b.x(), 0.0, b.y()));
  }

  // Writes the leg's HAA, HFE, KFE and wheel torques into tau (from index `haa`). In contact
  // (`ground`): the wheel's share f_c of its pair's force at the contact point, below the axle,
  // and the wheel's spin acceleration `wheel_acc` (its absolute spin's part that is not the
  // shank's). In flight (`ground` null) the wheel turns freely: its spin keeps its rate, so it
  // adds no moment and needs no torque.
  void torques(const PairSample* ground, double wheel_acc, int haa,
               Eigen::Matrix<double, model::kNumJoints, 1>& tau) const {
    // H's origin: a point of the base (x-z), plus gravity's support.
    const Eigen::Vector2d d = R * Eigen::Vector2d(c.t_hfe.x(), c.t_hfe.z());
    const Eigen::Vector3d a_h =
        inH(base_acc + w_dot * perp(d) - w * w * d + Eigen::Vector2d(0.0, M.settings.gravity));
    // With w_B = -pitch' e_y and |e_y| = 1: w_B' x r + w_B x (w_B x r) + 2 w_B x v
    // = e_y x (-pitch'' r - 2 pitch' v) + pitch'^2 ((e_y . r) e_y - r).
    auto absolute = [&](const LegPoint& pt) -> Eigen::Vector3d {
      return a_h + c.e_y.cross(-w_dot * pt.r - 2.0 * w * pt.v) +
             w * w * (c.e_y.dot(pt.r) * c.e_y - pt.r) + pt.a;
    };
    // The thigh and shank angles in H and their rates.
    const double s1 = c.sign[0] * pose.s1, c1 = pose.c1;
    const double sin2 = c.sign[1] * (pose.s12 * pose.c1 - pose.c12 * pose.s1);
    const double cos2 = pose.c12 * pose.c1 + pose.s12 * pose.s1;
    const double s12 = s1 * cos2 + c1 * sin2, c12 = c1 * cos2 - s1 * sin2;
    const double w1 = c.sign[0] * qd[0], w12 = w1 + c.sign[1] * qd[1];
    const double a1 = c.sign[0] * qdd[0], a12 = a1 + c.sign[1] * qdd[1];
    const LegPoint hfe{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    const LegPoint knee = onLink(hfe, rotateY(s1, c1, c.t_kfe), w1, a1);
    const LegPoint axle = onLink(knee, rotateY(s12, c12, c.t_wheel), w12, a12);
    // Joint origins and, per link, its CoM, m (a + g) and its inertia's moment (pitch only,
    // and the wheel's spin), all in H.
    const std::array<Eigen::Vector3d, 4> o{c.o_haa, hfe.r, knee.r, axle.r};
    const std::array<LegPoint, 4> com{
        LegPoint{c.com[0], Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()},
        onLink(hfe, rotateY(s1, c1, c.com[1]), w1, a1),
        onLink(knee, rotateY(s12, c12, c.com[2]), w12, a12),
        onLink(axle, rotateY(s12, c12, c.com[3]), w12, a12)};
    const double e_yy = c.e_y.y();
    const std::array<double, 4> pitch_dd{-w_dot, -w_dot + a1 * e_yy, -w_dot + a12 * e_yy,
                                         -w_dot + a12 * e_yy};
    // Up the chain: the links below each joint and the ground force at the contact point.
    Eigen::Vector3d f_sum = Eigen::Vector3d::Zero(), m_sum = Eigen::Vector3d::Zero();
    if (ground) {
      const Eigen::Vector2d up_b = R.transposeTimes(Eigen::Vector2d(0.0, 1.0));  // world z in B
      const Eigen::Vector3d f_c = inH(ground->f);
      const Eigen::Vector3d p_c = axle.r - (M.wheel_radius - ground->sink.x) * c.R_hfe.transpose() *
                                               Eigen::Vector3d(up_b.x(), 0.0, up_b.y());
      f_sum = -f_c;
      m_sum = -p_c.cross(f_c);
    }
    for (int n = 3; n >= 0; --n) {
      const std::size_t i = static_cast<std::size_t>(n);
      const Eigen::Vector3d force = c.mass[i] * absolute(com[i]);
      f_sum += force;
      // A free wheel (in flight) keeps its spin: its own inertia adds no moment.
      const bool free_wheel = n == 3 && !ground;
      const Eigen::Vector3d spin =
          free_wheel ? Eigen::Vector3d::Zero() : Eigen::Vector3d(c.i_yy[i] * pitch_dd[i] * c.e_y);
      m_sum += com[i].r.cross(force) + spin;
      if (n == 3 && ground) m_sum += c.i_yy[3] * wheel_acc * c.axis[3];
      // HFE, KFE and the wheel turn about H's y axis: only the moment's y is needed.
      const Eigen::Vector3d& o_n = o[i];
      tau[haa + n] =
          n == 0 ? c.axis[0].dot(m_sum - o_n.cross(f_sum))
                 : c.sign[i - 1] * (m_sum.y() - (o_n.z() * f_sum.x() - o_n.x() * f_sum.z()));
    }
  }
};

}  // namespace

void addStanceTorques(const JumpModelConstants& M, const StanceDynamics& D, const Sample& smp,
                      const StanceAccelerations& acc,
                      Eigen::Matrix<double, model::kNumJoints, 1>& tau) {
  for (const model::Leg leg : model::kLegs) {
    const int pair = model::isFront(leg) ? 1 : 0;
    const PairSample& p = pair == 1 ? smp.front : smp.hind;
    if (!p.contact) continue;
    const LegBalance balance{
        M,        D.leg[static_cast<std::size_t>(leg)], smp.R, smp.s.pitch_rate, acc.pitch,
        acc.base, pair == 1 ? smp.pose_f : smp.pose_h,  p.qd,  acc.qdd[pair]};
    balance.torques(&p, wheelAcceleration(M, acc, pair),
                    model::jointIndex(leg, model::JointKind::HAA), tau);
  }
}

// The flight's feed-forward: the legs' joint torques along the flight references, with the
// base's motion the plan's: the CoM's ballistic, the attitude the table's, and the pitch rate
// the momentum balance's, (flight_h + h_legs) / I (the table's Hermite has steps in its second
// derivative at its samples, a few Nm at the hips in a tuck). The rates' derivatives are
// central differences over h of the references' own rates (the postures' analytic rates), the
// base origin's acceleration a second difference of com - R c(q).
void flightTorques(const JumpModelConstants& M, const StanceDynamics& D, const Solved& S, double t,
                   Eigen::Matrix<double, model::kNumJoints, 1>& tau) {
  constexpr double h = 1e-4;  // [s]
  if (t > S.t3) {             // after the plan's touchdown: the landing's (the executor's own)
    for (int j = 0; j < model::kNumJoints; ++j) tau[j] = 0.0;
    return;
  }
  struct At {
    PlanarState s;
    std::array<Eigen::Vector2d, 2> q, qd;
    Eigen::Vector2d base;
  };
  auto at = [&](double ti) {
    At a;
    a.s = flightState(M, S, ti);
    for (int pair = 0; pair < 2; ++pair) a.q[pair] = flightPosture(M, S, pair, ti, &a.qd[pair]);
    double i_total = 0.0, h_legs = 0.0;
    Eigen::Vector2d c;
    flightMomentum(M, a.q, a.qd, i_total, h_legs, &c);
    a.s.pitch_rate = (S.flight_h + h_legs) / i_total;
    a.base = Eigen::Vector2d(a.s.x, a.s.z) - Rot2(a.s.pitch) * c;
    return a;
  };
  // Central differences over (t - h, t, t + h), or one-sided ones over (t, t + h, t + 2h) at
  // the lift-off (the flight's first instant).
  const bool central = t - h >= S.t2;
  const At mid = at(t), a = central ? at(t - h) : mid, b = at(t + h),
           c = central ? mid : at(t + 2.0 * h);
  auto rate = [&](auto f) {
    return central ? (f(b) - f(a)) / (2.0 * h) : (-3.0 * f(a) + 4.0 * f(b) - f(c)) / (2.0 * h);
  };
  const Eigen::Vector2d base_acc =
      central ? Eigen::Vector2d((b.base - 2.0 * mid.base + a.base) / (h * h))
              : Eigen::Vector2d((a.base - 2.0 * b.base + c.base) / (h * h));
  const Rot2 R(mid.s.pitch);
  const double w_dot = rate([](const At& x) { return x.s.pitch_rate; });
  for (const model::Leg leg : model::kLegs) {
    const int pair = model::isFront(leg) ? 1 : 0;
    const Eigen::Vector2d qdd(rate([&](const At& x) { return x.qd[pair][0]; }),
                              rate([&](const At& x) { return x.qd[pair][1]; }));
    const LegPose pose = poseOf(mid.q[pair]);
    const LegBalance balance{M,     D.leg[static_cast<std::size_t>(leg)],
                             R,     mid.s.pitch_rate,
                             w_dot, base_acc,
                             pose,  mid.qd[pair],
                             qdd};
    balance.torques(nullptr, 0.0, model::jointIndex(leg, model::JointKind::HAA), tau);
    tau[model::jointIndex(leg, model::JointKind::Wheel)] = 0.0;
  }
}

}  // namespace wj::planner::detail
