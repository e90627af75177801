#include "sim/reference_plans.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "sim/statics.h"

namespace wj::sim {

JointVector standingPosture(const model::RobotModel& model, double base_height_m,
                            double x_offset_m) {
  JointVector q = JointVector::Zero();
  for (const model::Leg leg : model::kLegs) {
    const model::LegGeometry& g = model.legGeometry(leg);
    const double l1 = g.thigh_length, l2 = g.shank_length;
    // Wheel centre relative to the HFE axis, in the sagittal plane.
    const double px = x_offset_m;
    const double pz = -(base_height_m - model.wheelRadius()) - (g.p_BH.z() + g.p_HT.z());
    const double d2 = px * px + pz * pz;
    const double c2 = (d2 - l1 * l1 - l2 * l2) / (2.0 * l1 * l2);
    if (c2 < -1.0 || c2 > 1.0) throw std::invalid_argument("standingPosture: out of reach");
    // Foot = -(l1 sin q1 + l2 sin(q1+q2), l1 cos q1 + l2 cos(q1+q2)); knee backward: q2 < 0.
    const double q2 = -std::acos(c2);
    const double phi = std::atan2(-px, -pz);
    const double q1 = phi - std::atan2(l2 * std::sin(q2), l1 + l2 * std::cos(q2));
    q[model::jointIndex(leg, model::JointKind::HFE)] = q1;
    q[model::jointIndex(leg, model::JointKind::KFE)] = q2;
  }
  return q;
}

double comHeight(const model::RobotModel& model, double base_height_m) {
  return base_height_m + model.calcCompositeInertia(standingPosture(model, base_height_m)).com.z();
}

double baseHeightForCom(const model::RobotModel& model, double com_height_m) {
  const double reach = model.wheelRadius() + model.legGeometry(model::Leg::LF).thigh_length +
                       model.legGeometry(model::Leg::LF).shank_length;
  double lo = model.wheelRadius() + 0.05 * (reach - model.wheelRadius()), hi = reach - 1e-9;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (comHeight(model, mid) < com_height_m ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

planner::JumpPlan makeVerticalJumpPlan(const model::RobotModel& model, const VerticalJumpSpec& spec,
                                       const ContactSettings& contact, double g) {
  planner::JumpPlan plan;
  const double r = model.wheelRadius();
  const double a = spec.push_accel_m_s2;
  const double sink = calcHertzPenetration(contact, r, model.totalMass() * g / model::kNumLegs);
  const double z0 = comHeight(model, spec.start_base_height_m) - sink;
  const double z_to = comHeight(model, spec.takeoff_base_height_m) - sink;
  const double z_land = comHeight(model, spec.landing_base_height_m);
  const double T = std::sqrt(2.0 * (z_to - z0) / a);
  const double v_to = a * T;
  const double t3 = T + (v_to + std::sqrt(v_to * v_to + 2.0 * g * (z_to - z_land))) / g;

  plan.mode = planner::TakeoffMode::Simultaneous;
  plan.t1 = plan.t2 = T;
  plan.t3 = t3;
  plan.dt = spec.dt_s;
  plan.initial = {0.0, z0, 0.0, spec.v0_m_s, 0.0, 0.0};
  plan.q_initial = standingPosture(model, spec.start_base_height_m);
  plan.q_landing = standingPosture(model, spec.landing_base_height_m);
  planner::ForcePhase push;
  push.t_start = 0.0;
  push.t_end = T;
  push.hind.fx.c = {0.0};
  push.hind.fz.c = {0.5 * model.totalMass() * (g + a)};
  push.front = push.hind;
  plan.force_phases.push_back(push);

  const int n = static_cast<int>(std::floor(t3 / spec.dt_s)) + 1;
  plan.centroidal.resize(n);
  plan.q.setZero(n, model::kNumJoints);
  plan.qd.setZero(n, model::kNumJoints);
  plan.tau.setZero(n, model::kNumJoints);
  const JointVector q_to = standingPosture(model, spec.takeoff_base_height_m);
  const auto comAt = [&](double t, double* vz) {
    if (t <= T) {
      *vz = a * t;
      return z0 + 0.5 * a * t * t;
    }
    *vz = v_to - g * (t - T);
    return z_to + v_to * (t - T) - 0.5 * g * (t - T) * (t - T);
  };
  const auto postureAt = [&](double t) -> JointVector {
    if (t <= T) {
      double vz = 0.0;
      return standingPosture(model, baseHeightForCom(model, comAt(t, &vz) + sink));
    }
    const double u = std::clamp((t - T) / 0.12, 0.0, 1.0);
    const double s = u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
    return q_to + s * (plan.q_landing - q_to);
  };
  for (int k = 0; k < n; ++k) {
    const double t = k * spec.dt_s;
    double vz = 0.0;
    const double z = comAt(t, &vz);
    plan.centroidal[k] = {spec.v0_m_s * t, z, 0.0, spec.v0_m_s, vz, 0.0};
    const JointVector q = postureAt(t);
    const double h = 1e-5;
    const JointVector qd = (postureAt(std::min(t + h, t <= T ? T : t3)) -
                            postureAt(std::max(t - h, t <= T ? 0.0 : T))) /
                           (std::min(t + h, t <= T ? T : t3) - std::max(t - h, t <= T ? 0.0 : T));
    plan.q.row(k) = q.transpose();
    plan.qd.row(k) = qd.transpose();
    if (t <= T) plan.tau.row(k) = calcStandingStatics(model, q, g, a).tau.transpose();
    // Wheels roll at v0: their absolute spin is v0 / r, and the joint measures it relative to
    // the shank, whose pitch is HFE + KFE (the base stays level).
    for (const model::Leg leg : model::kLegs) {
      const int w = model::jointIndex(leg, model::JointKind::Wheel);
      const int hfe = model::jointIndex(leg, model::JointKind::HFE);
      const int kfe = model::jointIndex(leg, model::JointKind::KFE);
      plan.q(k, w) =
          spec.v0_m_s / r * t - (q[hfe] + q[kfe] - plan.q_initial[hfe] - plan.q_initial[kfe]);
      plan.qd(k, w) = spec.v0_m_s / r - (qd[hfe] + qd[kfe]);
      plan.tau(k, w) = 0.0;
    }
  }
  double vz = 0.0;
  plan.predicted.takeoff = {T, {spec.v0_m_s * T, z_to, 0.0, spec.v0_m_s, v_to, 0.0}, 0.0};
  const double t_apex = T + v_to / g;
  plan.predicted.apex = {
      t_apex, {spec.v0_m_s * t_apex, comAt(t_apex, &vz), 0.0, spec.v0_m_s, 0.0, 0.0}, 0.0};
  const double z3 = comAt(t3, &vz);
  plan.predicted.touchdown = {t3, {spec.v0_m_s * t3, z3, 0.0, spec.v0_m_s, vz, 0.0}, 0.0};
  return plan;
}

}  // namespace wj::sim
