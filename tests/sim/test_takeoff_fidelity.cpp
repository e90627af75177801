// The planner's take-off model against the multibody simulation (issue 22): for the presets
// forward_hw, forward and vertical (planner seed 7), the plan's lift-off CoM velocity and
// angular momentum about the CoM, its apex and its touchdown pitch against what Simbody does
// with the plan. Both momenta are computed by the same function, from the base's attitude and
// angular velocity and the joints' positions and rates (link poses of robot_model, velocities
// by a central difference): the plan's at its row at t2, Simbody's at its measured lift-off.
//
// Each case prints one line of JSON to stdout (scripts/bench-takeoff-fidelity.sh collects a
// grid of seeds and speeds).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <iomanip>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "sim/liftoff_correction.h"
#include "sim/verifier.h"

namespace wj::sim {
namespace {

using JointVec = Eigen::Matrix<double, model::kNumJoints, 1>;

/// A telemetry sample's joint array as a vector.
JointVec toJointVec(const std::array<double, model::kNumJoints>& a) {
  return Eigen::Map<const JointVec>(a.data());
}

/// Angular momentum of the whole robot about its CoM, in W [kg m^2/s], from the base
/// orientation R_WB and angular velocity w_WB (in W) and the joints' q and qd. Independent of
/// the base's position and linear velocity.
Eigen::Vector3d angularMomentumAboutCom(const model::RobotModel& robot, const Eigen::Matrix3d& R_WB,
                                        const Eigen::Vector3d& w_WB, const JointVec& q,
                                        const JointVec& qd) {
  constexpr double h = 1e-6;  // central difference of the link poses along qd [s]
  const auto X = robot.calcLinkPoses(q);
  const auto Xp = robot.calcLinkPoses(q + h * qd);
  const auto Xm = robot.calcLinkPoses(q - h * qd);
  const auto& links = robot.links();
  double m_total = 0.0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero(), v_c = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> p(links.size()), v(links.size()), w(links.size());
  for (std::size_t i = 0; i < links.size(); ++i) {
    const auto& in = links[i].inertia;
    const Eigen::Vector3d p_b = X[i] * in.com;
    const Eigen::Vector3d v_b = (Xp[i] * in.com - Xm[i] * in.com) / (2 * h);
    const Eigen::Matrix3d dR = (Xp[i].linear() - Xm[i].linear()) / (2 * h);
    const Eigen::Matrix3d W = dR * X[i].linear().transpose();  // skew(omega) in the base
    const Eigen::Vector3d w_rel(W(2, 1), W(0, 2), W(1, 0));
    p[i] = R_WB * p_b;
    v[i] = w_WB.cross(p[i]) + R_WB * v_b;
    w[i] = w_WB + R_WB * w_rel;
    m_total += in.mass;
    c += in.mass * p[i];
    v_c += in.mass * v[i];
  }
  c /= m_total;
  v_c /= m_total;
  Eigen::Vector3d H = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < links.size(); ++i) {
    const auto& in = links[i].inertia;
    const Eigen::Matrix3d R_WL = R_WB * X[i].linear();
    H += in.mass * (p[i] - c).cross(v[i] - v_c) + R_WL * in.inertia_com * R_WL.transpose() * w[i];
  }
  return H;
}

/// Nose-up angular momentum (about -y) of the plan's row k.
double plannedMomentum(const model::RobotModel& robot, const planner::JumpPlan& plan, int k) {
  const planner::PlanarState& s = plan.centroidal[k];
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(-s.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d w(0.0, -s.pitch_rate, 0.0);
  const JointVec q = plan.q.row(k).transpose(), qd = plan.qd.row(k).transpose();
  return -angularMomentumAboutCom(robot, R, w, q, qd).y();
}

/// ... at the lift-off t2: extrapolated from the last two rows of the take-off (the rows after
/// t2 are the flight's references, whose legs restart from rest).
double plannedLiftOffMomentum(const model::RobotModel& robot, const planner::JumpPlan& plan,
                              double t2) {
  const int k = std::clamp(static_cast<int>(std::floor(t2 / plan.dt + 1e-9)), 1,
                           static_cast<int>(plan.centroidal.size()) - 1);
  const double h1 = plannedMomentum(robot, plan, k), h0 = plannedMomentum(robot, plan, k - 1);
  return h1 + (h1 - h0) * (t2 - k * plan.dt) / plan.dt;
}

/// ... and its rate at t2 [Nm]: the derivative at t2 of the quadratic through the push's last
/// three rows (the moment the plan's motion needs there, which the planner's unloading tail
/// takes with its balanced forces: docs/planner.md, "The balanced stance").
double plannedLiftOffMomentumRate(const model::RobotModel& robot, const planner::JumpPlan& plan,
                                  double t2) {
  const int k = std::clamp(static_cast<int>(std::floor(t2 / plan.dt + 1e-9)), 2,
                           static_cast<int>(plan.centroidal.size()) - 1);
  const double h2 = plannedMomentum(robot, plan, k), h1 = plannedMomentum(robot, plan, k - 1),
               h0 = plannedMomentum(robot, plan, k - 2);
  const double x = (t2 - k * plan.dt) / plan.dt;  // 0 at row k
  return ((h2 - h1) + (h2 - 2.0 * h1 + h0) * (x + 0.5)) / plan.dt;
}

/// Nose-up angular momentum of a simulated instant.
double simulatedMomentum(const model::RobotModel& robot, const TelemetrySample& s) {
  JointVec q, qd;
  for (int j = 0; j < model::kNumJoints; ++j) {
    q[j] = s.q[j];
    qd[j] = s.qd[j];
  }
  return -angularMomentumAboutCom(robot, s.q_WB.toRotationMatrix(), s.w_WB, q, qd).y();
}

/// Simbody's nose-up momentum minus the plan's at the same instant, split by what differs
/// (H is linear in the base's angular velocity and the joint rates): the configuration (the
/// plan's rates in Simbody's posture less the plan's), the base's angular velocity, and each
/// group of joints' rates (Simbody's less the plan's, in Simbody's posture). The parts sum to
/// the difference up to the central difference's O(h^2).
struct MomentumParts {
  /// config, base, front HFE, front KFE, hind HFE, hind KFE, HAA, wheels; then their sum.
  static constexpr int kParts = 8;
  static constexpr std::array<const char*, kParts + 1> kNames = {
      "config", "base", "hfe_f", "kfe_f", "hfe_h", "kfe_h", "haa", "wheel", "total"};
  std::array<double, kParts + 1> h{};
  /// The wheels' mean rate relative to the base, plan / Simbody [rad/s].
  double wheel_rate_plan = 0.0, wheel_rate_sim = 0.0;
};

/// The joint group of MomentumParts (0-based after config and base) of joint j.
int jointGroup(int j) {
  const auto leg = static_cast<model::Leg>(j / model::kJointsPerLeg);
  const auto kind = static_cast<model::JointKind>(j % model::kJointsPerLeg);
  if (kind == model::JointKind::HAA) return 4;
  if (kind == model::JointKind::Wheel) return 5;
  return (model::isFront(leg) ? 0 : 2) + (kind == model::JointKind::KFE ? 1 : 0);
}

MomentumParts momentumParts(const model::RobotModel& robot, const planner::JumpPlan& plan, int k,
                            const TelemetrySample& s) {
  const JointVec q_s = toJointVec(s.q), qd_s = toJointVec(s.qd);
  const planner::PlanarState& c = plan.centroidal[k];
  const Eigen::Matrix3d R_p =
      Eigen::AngleAxisd(-c.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d w_p(0.0, -c.pitch_rate, 0.0);
  const JointVec q_p = plan.q.row(k).transpose(), qd_p = plan.qd.row(k).transpose();
  const Eigen::Matrix3d R_s = s.q_WB.toRotationMatrix();
  const auto noseUp = [&](const Eigen::Matrix3d& R, const Eigen::Vector3d& w, const JointVec& q,
                          const JointVec& qd) {
    return -angularMomentumAboutCom(robot, R, w, q, qd).y();
  };
  MomentumParts m;
  m.h[0] = noseUp(R_s, w_p, q_s, qd_p) - noseUp(R_p, w_p, q_p, qd_p);
  m.h[1] = noseUp(R_s, s.w_WB - w_p, q_s, JointVec::Zero());
  for (int j = 0; j < model::kNumJoints; ++j) {
    JointVec dqd = JointVec::Zero();
    dqd[j] = qd_s[j] - qd_p[j];
    m.h[2 + jointGroup(j)] += noseUp(R_s, Eigen::Vector3d::Zero(), q_s, dqd);
    if (model::isWheel(j)) {
      m.wheel_rate_plan += qd_p[j] / model::kNumLegs;
      m.wheel_rate_sim += qd_s[j] / model::kNumLegs;
    }
  }
  m.h.back() = noseUp(R_s, s.w_WB, q_s, qd_s) - noseUp(R_p, w_p, q_p, qd_p);
  return m;
}

/// Simbody's nose-up pitch rate minus the plan's at the same instant, from the kinematics of the
/// two wheel pairs (left legs; the runs are symmetric): with the front and hind axles a distance
/// dx apart along x and rising at vz_F, vz_H in W, theta' dx = (vz_F - vz_H) - (R (v_F - v_H))_z,
/// v the axles' velocities relative to the base from the joint rates. The rigid wheel's plan
/// keeps its axles on the ground (vz = 0); Simbody's compliant contact does not quite. Split:
/// the joints' rates (Simbody's less the plan's, in Simbody's posture), the contact (Simbody's
/// axles' vz less the plan's, which its tyres' sink moves) and the
/// posture (the plan's rates in Simbody's posture and attitude against the plan's own).
struct PitchRateClosure {
  double measured = 0.0;  ///< Simbody's pitch rate less the plan's [rad/s]
  double joints = 0.0, contact = 0.0, posture = 0.0;
};

PitchRateClosure pitchRateClosure(const model::RobotModel& robot, const planner::JumpPlan& plan,
                                  int k, const TelemetrySample& s) {
  constexpr double h = 1e-6;  // central difference along the joint rates [s]
  const int front = robot.joint(model::Leg::LF, model::JointKind::Wheel).child_link;
  const int hind = robot.joint(model::Leg::LH, model::JointKind::Wheel).child_link;
  const JointVec q_s = toJointVec(s.q), qd_s = toJointVec(s.qd);
  const planner::PlanarState& c = plan.centroidal[k];
  const Eigen::Matrix3d R_p =
      Eigen::AngleAxisd(-c.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d R_s = s.q_WB.toRotationMatrix();
  const JointVec q_p = plan.q.row(k).transpose(), qd_p = plan.qd.row(k).transpose();
  // (R (v_F - v_H))_z and the axles' distance along x, for a posture, rates and attitude.
  const auto relative = [&](const JointVec& q, const JointVec& qd, const Eigen::Matrix3d& R) {
    const auto Xp = robot.calcLinkPoses(q + h * qd), Xm = robot.calcLinkPoses(q - h * qd);
    const auto X = robot.calcLinkPoses(q);
    const Eigen::Vector3d dv = ((Xp[front].translation() - Xm[front].translation()) -
                                (Xp[hind].translation() - Xm[hind].translation())) /
                               (2 * h);
    return std::pair<double, double>((R * dv).z(),
                                     (R * (X[front].translation() - X[hind].translation())).x());
  };
  const auto [dvz_s, dx_s] = relative(q_s, qd_s, R_s);
  const auto [dvz_sp, dx_sp] = relative(q_s, qd_p, R_s);
  const auto [dvz_p, dx_p] = relative(q_p, qd_p, R_p);
  // Simbody's axles' vertical speeds in W: the base's motion plus the legs'.
  const auto X = robot.calcLinkPoses(q_s);
  const auto Xp = robot.calcLinkPoses(q_s + h * qd_s), Xm = robot.calcLinkPoses(q_s - h * qd_s);
  const auto axleVz = [&](int link) {
    const Eigen::Vector3d r = R_s * X[link].translation();
    const Eigen::Vector3d v_rel = (Xp[link].translation() - Xm[link].translation()) / (2 * h);
    return (s.v_WB + s.w_WB.cross(r) + R_s * v_rel).z();
  };
  PitchRateClosure out;
  out.measured = -s.w_WB.y() - c.pitch_rate;
  out.joints = -(dvz_s - dvz_sp) / dx_s;
  // The plan's axles rise out of its tyres' sink (PlannerSettings::tyre_contact_modulus_pa;
  // zero for the rigid wheel): vz_F - vz_H = theta' dx + (R (v_F - v_H))_z in its own rows.
  const double dvz_axles_p = c.pitch_rate * dx_p + dvz_p;
  out.contact = (axleVz(front) - axleVz(hind) - dvz_axles_p) / dx_s;
  out.posture = -dvz_sp / dx_s + dvz_p / dx_p + dvz_axles_p * (1.0 / dx_s - 1.0 / dx_p);
  return out;
}

/// MomentumParts and PitchRateClosure of one instant as a JSON object.
std::string toJson(double t, const MomentumParts& m, const PitchRateClosure& p) {
  std::ostringstream o;
  o << std::setprecision(4) << "{\"t\": " << t;
  for (std::size_t i = 0; i < m.h.size(); ++i) o << ", \"" << m.kNames[i] << "\": " << m.h[i];
  o << ", \"wheel_rate\": [" << m.wheel_rate_plan << ", " << m.wheel_rate_sim
    << "], \"pitch_rate\": {\"measured\": " << p.measured << ", \"joints\": " << p.joints
    << ", \"contact\": " << p.contact << ", \"posture\": " << p.posture << "}}";
  return o.str();
}

/// Nose-up moment of the plan's ground forces about the CoM at row k (t <= t2): each pair's
/// force at its wheels' contact points, below the axles on the ground.
double plannedMoment(const model::RobotModel& robot, const planner::JumpPlan& plan, int k) {
  const double t = k * plan.dt;
  const planner::PlanarState& s = plan.centroidal[k];
  const JointVec q = plan.q.row(k).transpose();
  const model::Inertia in = robot.calcCompositeInertia(q);
  const auto X = robot.calcLinkPoses(q);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(-s.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  double moment = 0.0;
  for (const planner::ForcePhase& ph : plan.force_phases) {
    if (t < ph.t_start || t > ph.t_end) continue;
    const double tau = t - ph.t_start;
    for (const model::Leg leg : model::kLegs) {
      const planner::PairForce& f = model::isFront(leg) ? ph.front : ph.hind;
      const Eigen::Vector3d axle =
          R * (X[robot.joint(leg, model::JointKind::Wheel).child_link].translation() - in.com);
      // Half the pair's force per wheel; the contact is on the ground, z below the CoM.
      moment += 0.5 * (axle.x() * f.fz(tau) + s.z * f.fx(tau));
    }
    break;
  }
  return moment;
}

/// The ground's moment impulses about the CoM from t = 0 to Simbody's sample i_end (trapezoid
/// rule over the 1 ms samples), Simbody's against the plan's: H(t) - H(0) of each against the
/// integrated moment of its ground forces (the plan's differ by its pitch model's imbalance:
/// zero for the centroidal stance_momentum, the legs' momentum for the rigid-body stance), and
/// Simbody's impulse less the plan's split by what differs: each pair's normal force (Simbody's
/// less the plan's, times the plan's lever), the horizontal forces (times the plan's CoM
/// height), and the levers (the contact points under the axles relative to the CoM).
struct MomentImpulse {
  double dh_sim = 0.0, impulse_sim = 0.0, dh_plan = 0.0, impulse_plan = 0.0;
  double fz_front = 0.0, fz_hind = 0.0, fx = 0.0, lever = 0.0;
};

MomentImpulse momentImpulse(const model::RobotModel& robot, const planner::JumpPlan& plan,
                            const std::vector<TelemetrySample>& samples, std::size_t i_end) {
  MomentImpulse out;
  const double r = robot.wheelRadius();
  std::array<double, 6> prev{};  // sim, plan, fz_front, fz_hind, fx, lever at the last sample
  for (std::size_t i = 0; i <= i_end; ++i) {
    const TelemetrySample& s = samples[i];
    const int k = static_cast<int>(std::lround(s.t / plan.dt));
    const JointVec q_s = toJointVec(s.q);
    const auto X_s = robot.calcLinkPoses(q_s);
    const Eigen::Matrix3d R_s = s.q_WB.toRotationMatrix();
    const planner::PlanarState& c = plan.centroidal[k];
    const JointVec q_p = plan.q.row(k).transpose();
    const auto X_p = robot.calcLinkPoses(q_p);
    const Eigen::Vector3d com_p = robot.calcCompositeInertia(q_p).com;
    const Eigen::Matrix3d R_p =
        Eigen::AngleAxisd(-c.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
    const planner::ForcePhase* phase = nullptr;
    for (const planner::ForcePhase& ph : plan.force_phases)
      if (k * plan.dt >= ph.t_start && k * plan.dt <= ph.t_end) phase = &ph;
    std::array<double, 6> now{};
    for (const model::Leg leg : model::kLegs) {
      const int link = robot.joint(leg, model::JointKind::Wheel).child_link;
      const Eigen::Vector3d axle = s.p_WB + R_s * X_s[link].translation();
      // Nose-up moment of a force (fx, fz) at a contact x_rel ahead of and z_rel below the CoM.
      const double x_s = axle.x() - s.p_WC.x(), z_s = s.p_WC.z() - (axle.z() - r);
      const Eigen::Vector3d& f = s.wheel_force_W[static_cast<int>(leg)];
      now[0] += x_s * f.z() + z_s * f.x();
      if (!phase) continue;
      const planner::PairForce& pair = model::isFront(leg) ? phase->front : phase->hind;
      const double tau = k * plan.dt - phase->t_start;
      const double fz = 0.5 * pair.fz(tau), fx = 0.5 * pair.fx(tau);
      const double x_p = (R_p * (X_p[link].translation() - com_p)).x(), z_p = c.z;
      now[1] += x_p * fz + z_p * fx;
      now[model::isFront(leg) ? 2 : 3] += x_p * (f.z() - fz);
      now[4] += z_p * (f.x() - fx);
      now[5] += (x_s - x_p) * f.z() + (z_s - z_p) * f.x();
    }
    if (i > 0) {
      const double dt = s.t - samples[i - 1].t;
      std::array<double*, 6> acc = {&out.impulse_sim, &out.impulse_plan, &out.fz_front,
                                    &out.fz_hind,     &out.fx,           &out.lever};
      for (std::size_t n = 0; n < acc.size(); ++n) *acc[n] += 0.5 * (prev[n] + now[n]) * dt;
    }
    prev = now;
  }
  const int k_end = static_cast<int>(std::lround(samples[i_end].t / plan.dt));
  out.dh_sim = simulatedMomentum(robot, samples[i_end]) - simulatedMomentum(robot, samples[0]);
  out.dh_plan = plannedMomentum(robot, plan, k_end) - plannedMomentum(robot, plan, 0);
  return out;
}

struct Fidelity {
  std::string task;
  double v0 = 0.0;
  double t2_plan = 0.0, t2_sim = 0.0;
  double vx_plan = 0.0, vx_sim = 0.0, vz_plan = 0.0, vz_sim = 0.0;
  double h_plan = 0.0, h_sim = 0.0, h_sim_t2 = 0.0;
  /// The plan's H at t2 less its H at the instant of Simbody's last sample at or before t2.
  double h_plan_instant = 0.0;
  /// The plan's total ground force at t2 (x, z) [N] and its flight's momentum: the push's at
  /// t2 plus the unloading tail's (the moment at t2 times planner::unloadingTailWeight).
  double fx_t2 = 0.0, fz_t2 = 0.0, h_plan_flight = 0.0;
  /// The flight's momentum with the wheels as point masses (planner::JumpEvent::momentum): the
  /// plan's own and Simbody's at its lift-off [kg m^2/s].
  double h_flight_plan = 0.0, h_flight_sim = 0.0;
  int rounds = 0;  ///< plans made (the lift-off correction's rounds + 1)
  /// The chosen round's lift-off residual against the correction's tolerances (<= 1 within)
  double residual_ratio = 0.0;
  /// Simbody at the plan's t2: the CoM's vz and the wheels' total normal force, and the
  /// ground's vertical impulse from t2 to its lift-off (from the CoM's momentum) [m/s, N, N s].
  double vz_sim_t2 = 0.0, fz_sim_t2 = 0.0, tail_impulse_sim = 0.0;
  double apex_plan = 0.0, apex_sim = 0.0;  ///< CoM apex height [m]
  double td_pitch_plan = 0.0, td_pitch_sim = 0.0;
  /// The part of the touchdown pitch error the flight momentum's error makes [rad].
  double td_pitch_from_dh = 0.0;
  /// Simbody's pitch at its lift-off less the plan's at that instant [rad].
  double lift_pitch_error = 0.0;
  /// The plan's pitch at Simbody's touchdown instant less at its own touchdown [rad].
  double td_instant_pitch = 0.0;
  double td_dx_plan = 0.0, td_dx_sim = 0.0;
  bool passed = false;
};

/// WJ_FIDELITY_NO_TAIL=1: the flight from the push's state at t2, without the lift-off's
/// unloading tail (PlannerSettings::takeoff_unload_s = 0), for the before/after comparison of
/// the bench grid.
bool noTailFromEnv() {
  const char* v = std::getenv("WJ_FIDELITY_NO_TAIL");
  return v && std::string(v) == "1";
}

/// PlannerSettings with the stance momentum on or off; WJ_FIDELITY_TYRE_MODULUS=<Pa>: with the
/// tyre's sink (PlannerSettings::tyre_contact_modulus_pa) in place of the rigid wheel;
/// WJ_FIDELITY_SAMPLES_FLIGHT=<n>: the flight attitude's table with n samples in place of 24;
/// with `drive_limited_flight` the flight's feed-forward and the drive-limited tuck
/// (physics.flight_feedforward, postures.drive_limited_tuck).
planner::PlannerSettings plannerSettings(bool stance_momentum, bool drive_limited_flight) {
  planner::PlannerSettings s;
  s.stance_momentum = stance_momentum;
  if (noTailFromEnv()) s.takeoff_unload_s = 0.0;
  if (const char* e = std::getenv("WJ_FIDELITY_TYRE_MODULUS"))
    s.tyre_contact_modulus_pa = std::stod(e);
  if (const char* e = std::getenv("WJ_FIDELITY_SAMPLES_FLIGHT")) s.samples_flight = std::stoi(e);
  s.flight_feedforward = drive_limited_flight;
  s.drive_limited_tuck = drive_limited_flight;
  return s;
}

/// WJ_FIDELITY_FLIGHT_FEEDFORWARD=1: the bench grid with the flight's feed-forward and the
/// drive-limited tuck.
bool driveLimitedFlightFromEnv() {
  const char* v = std::getenv("WJ_FIDELITY_FLIGHT_FEEDFORWARD");
  return v && std::string(v) == "1";
}

/// WJ_FIDELITY_STANCE_MOMENTUM=1: the bench grid with the stance momentum on.
bool stanceMomentumFromEnv() {
  const char* v = std::getenv("WJ_FIDELITY_STANCE_MOMENTUM");
  return v && std::string(v) == "1";
}

/// The environment variable `name` as "kp,kd", if set.
std::optional<std::pair<double, double>> gainPair(const char* name) {
  const char* g = std::getenv(name);
  if (g == nullptr) return std::nullopt;
  const char* comma = std::strchr(g, ',');
  if (comma == nullptr)
    throw std::invalid_argument(std::string(name) + " must be 'kp,kd', got '" + g + "'");
  return std::make_pair(std::stod(g), std::stod(comma + 1));
}

/// WJ_FIDELITY_SPEED_LOOP=1: the take-off's wheels with session 16's law (the plan's torque
/// plus takeoff_wheel_kd on the whole error to the plan's no-slip rate), for the before/after
/// comparison of the bench grid. WJ_FIDELITY_OPEN_LOOP=1: session 19's executor, without the
/// take-off's momentum feedback and with the flight gains 80 / 2.
/// WJ_FIDELITY_REFERENCE_INTEGRATOR=1: Simbody with the reference integrator
/// (VerifierSettings::reference(), Runge-Kutta-Merson at 1e-5) instead of the verifier's 1 ms
/// semi-explicit Euler step: the simulation's own discretization error on the lift-off state
/// (docs/planner.md, "What the simulation itself resolves"). WJ_FIDELITY_TRANSITION_VELOCITY:
/// the friction law's transition speed [m/s] in place of the default 0.2 (below 0.2 with the
/// reference integrator only: the 1 ms step chatters, docs/sim.md "Integrator").
/// WJ_FIDELITY_CONTACT_STIFFNESS: the contact's plane-strain modulus [Pa] in place of 8e6 (how
/// much of the gap is the tyre's compliance, docs/planner.md "The tyre's lag").
/// WJ_FIDELITY_CONTACT_DISSIPATION: the contact's Hunt-Crossley dissipation [s/m] in place of
/// 0.8 (how much the unloading tail depends on it, docs/takeoff-fidelity.md "Session 35").
/// WJ_FIDELITY_TAKEOFF_GAINS="kp,kd": the take-off's joint gains in place of 150, 3 (how much of
/// the gap is the joints' tracking, docs/takeoff-fidelity.md "Stiffer tracking").
/// WJ_FIDELITY_MOMENTUM_GAINS="kp,kd": the take-off's momentum feedback gains in place of
/// 150, 0.5 (docs/takeoff-fidelity.md, "The momentum feedback's gain").
/// WJ_FIDELITY_FLIGHT_GAINS="kp,kd": the flight's leg gains in place of 300, 6 (how much of the
/// touchdown pitch's error is the legs' lag, docs/takeoff-fidelity.md "Session 32").
VerifierSettings verifierSettings() {
  const char* reference = std::getenv("WJ_FIDELITY_REFERENCE_INTEGRATOR");
  VerifierSettings s = reference && std::string(reference) == "1" ? VerifierSettings::reference()
                                                                  : VerifierSettings{};
  if (const char* vt = std::getenv("WJ_FIDELITY_TRANSITION_VELOCITY"))
    s.sim.contact.transition_velocity_m_s = std::stod(vt);
  if (const char* k = std::getenv("WJ_FIDELITY_CONTACT_STIFFNESS"))
    s.sim.contact.stiffness_pa = std::stod(k);
  if (const char* c = std::getenv("WJ_FIDELITY_CONTACT_DISSIPATION"))
    s.sim.contact.dissipation_s_m = std::stod(c);
  const char* v = std::getenv("WJ_FIDELITY_SPEED_LOOP");
  if (v && std::string(v) == "1") {
    s.executor.takeoff_wheel_slip_band_m_s = 0.0;
    s.executor.tyre_slip_stiffness_n_s_m = std::numeric_limits<double>::max();
    s.executor.tyre_rolling_radius_ratio = 1.0;
  }
  if (const auto g = gainPair("WJ_FIDELITY_TAKEOFF_GAINS")) {
    s.executor.takeoff_kp = g->first;
    s.executor.takeoff_kd = g->second;
  }
  if (const auto g = gainPair("WJ_FIDELITY_FLIGHT_GAINS")) {
    s.executor.flight_kp = g->first;
    s.executor.flight_kd = g->second;
  }
  if (const auto g = gainPair("WJ_FIDELITY_MOMENTUM_GAINS")) {
    s.executor.takeoff_momentum_kp = g->first;
    s.executor.takeoff_momentum_kd = g->second;
  }
  const char* open = std::getenv("WJ_FIDELITY_OPEN_LOOP");
  if (open && std::string(open) == "1") {
    s.executor.takeoff_momentum_kp = 0.0;
    s.executor.takeoff_momentum_kd = 0.0;
    s.executor.flight_kp = 80.0;
    s.executor.flight_kd = 2.0;
  }
  return s;
}

/// WJ_FIDELITY_CORRECTION=<rounds>: the plans with the lift-off correction
/// (sim::planWithLiftOffCorrection, at most that many rounds after the first); 0 or unset: the
/// model alone.
int correctionRoundsFromEnv() {
  const char* v = std::getenv("WJ_FIDELITY_CORRECTION");
  return v ? std::atoi(v) : 0;
}

Fidelity measure(const std::string& task, std::optional<double> v0, std::uint64_t seed = 7,
                 bool stance_momentum = false, int correction_rounds = correctionRoundsFromEnv(),
                 bool drive_limited_flight = driveLimitedFlightFromEnv(),
                 const VerifierSettings& verifier_settings = verifierSettings()) {
  const auto robot = model::RobotModel::loadDefault();
  const planner::JumpPlanner planner(robot, plannerSettings(stance_momentum, drive_limited_flight));
  const planner::Scenario sc = planner::makePreset(planner, task, v0);
  planner::PlanOptions opts;
  opts.seed = seed;
  opts.threads = 2;
  const Verifier verifier(robot, verifier_settings);
  LiftOffCorrectionSettings correction;
  correction.max_rounds = correction_rounds;
  // Each verification recorded: round k's is recordings[k].
  std::deque<TelemetryRecorder> recordings;
  const CorrectedPlan corrected = planWithLiftOffCorrection(
      planner,
      [&](const planner::JumpPlan& plan) {
        return verifier.verify(plan, scenarioForTask(sc.task),
                               recordings.emplace_back().callback());
      },
      sc.task, sc.initial, opts, correction);
  const planner::PlannerResult& r = corrected.result;
  EXPECT_TRUE(r.evaluation.valid) << task;
  if (recordings.size() <= static_cast<std::size_t>(corrected.chosen))
    recordings.resize(static_cast<std::size_t>(corrected.chosen) +
                      1);  // no plan: nothing was recorded
  const TelemetryRecorder& recorder = recordings[static_cast<std::size_t>(corrected.chosen)];
  const VerificationReport& v = corrected.report;
  Fidelity f;
  f.task = task;
  f.v0 = sc.initial.v0;
  f.passed = v.passed;
  for (const std::string& why : v.reasons)
    std::cerr << task << " seed " << seed << " failed verification: " << why << "\n";
  const planner::JumpOutcome& p = r.plan.predicted;
  const planner::JumpOutcome& m = v.measured;
  f.t2_plan = p.takeoff.t;
  f.t2_sim = m.takeoff.t;
  f.h_flight_plan = p.takeoff.momentum;
  f.h_flight_sim = m.takeoff.momentum;
  f.rounds = static_cast<int>(corrected.rounds.size());
  if (!corrected.rounds.empty())
    f.residual_ratio = corrected.rounds[static_cast<std::size_t>(corrected.chosen)].residual_ratio;
  // The velocities at the same instant, Simbody's lift-off: the plan's flight is ballistic
  // from t2 with the unloading tail's impulse (Simbody's wheels leave the ground 4-6 ms later,
  // with the contact force falling to zero meanwhile: docs/planner.md, "The lift-off's
  // unloading tail").
  f.vx_plan = p.takeoff.state.vx;
  f.vx_sim = m.takeoff.state.vx;
  f.vz_plan = p.takeoff.state.vz - planner::PlannerSettings{}.gravity * (f.t2_sim - f.t2_plan);
  f.vz_sim = m.takeoff.state.vz;
  f.h_plan = plannedLiftOffMomentum(robot, r.plan, p.takeoff.t);
  const planner::ForcePhase& last = r.plan.force_phases.back();
  const double tau_end = last.t_end - last.t_start;
  f.fx_t2 = last.hind.fx(tau_end) + last.front.fx(tau_end);
  f.fz_t2 = last.hind.fz(tau_end) + last.front.fz(tau_end);
  f.h_plan_flight =
      f.h_plan + (sc.task.mode == planner::TakeoffMode::TwoStep
                      ? 0.0
                      : planner::unloadingTailWeight(p.takeoff.t, planner::kExecutorControlPeriod,
                                                     planner.settings().takeoff_unload_s) *
                            plannedLiftOffMomentumRate(robot, r.plan, p.takeoff.t));
  // ... and the lift-off correction's impulse, if the plan has one.
  f.h_plan_flight += r.plan.liftoff_correction.momentum;
  const TelemetrySample* lift = nullptr;
  for (const TelemetrySample& s : recorder.samples())
    if (s.t <= m.takeoff.t + 1e-9) lift = &s;
  EXPECT_NE(lift, nullptr) << task;
  if (lift) f.h_sim = simulatedMomentum(robot, *lift);
  // ... and at the plan's t2, before the 3-6 ms in which the wheels let go.
  const TelemetrySample* at_t2 = nullptr;
  for (const TelemetrySample& s : recorder.samples())
    if (s.t <= p.takeoff.t + 1e-9) at_t2 = &s;
  std::string parts_json, impulse_json = "null";
  if (at_t2) {
    // Simbody's H minus the plan's at the same instants, split (MomentumParts): the last sample
    // at or before t2 (t2 is half-way between control instants, so its state is the push's,
    // before the first braking step) and 10, 20, 50 and 100 ms before it (one sample per 1 ms
    // control period).
    const auto& all = recorder.samples();
    const std::ptrdiff_t i_t2 = at_t2 - all.data();
    for (const int back_ms : {100, 50, 20, 10, 0}) {
      const std::ptrdiff_t i = i_t2 - back_ms;
      if (i < 0) continue;
      const int k = static_cast<int>(std::lround(all[i].t / r.plan.dt));
      if (!parts_json.empty()) parts_json += ", ";
      const MomentumParts parts = momentumParts(robot, r.plan, k, all[i]);
      const PitchRateClosure pr = pitchRateClosure(robot, r.plan, k, all[i]);
      // The parts are exact splits: they sum to the difference (up to the central differences).
      double sum = 0.0;
      for (int n = 0; n < MomentumParts::kParts; ++n) sum += parts.h[n];
      EXPECT_NEAR(sum, parts.h.back(), 5e-4) << task << " t " << all[i].t;
      EXPECT_NEAR(pr.joints + pr.contact + pr.posture, pr.measured, 1e-3) << task;
      parts_json += toJson(all[i].t, parts, pr);
    }
    const MomentImpulse mi = momentImpulse(robot, r.plan, all, static_cast<std::size_t>(i_t2));
    std::ostringstream o;
    o << std::setprecision(4) << "{\"dh\": [" << mi.dh_plan << ", " << mi.dh_sim
      << "], \"impulse\": [" << mi.impulse_plan << ", " << mi.impulse_sim
      << "], \"fz_front\": " << mi.fz_front << ", \"fz_hind\": " << mi.fz_hind
      << ", \"fx\": " << mi.fx << ", \"lever\": " << mi.lever << "}";
    impulse_json = o.str();
    // The sample instant: the plan's H at t2 less its H at the sample's instant.
    const int k_s = static_cast<int>(std::lround(at_t2->t / r.plan.dt));
    f.h_plan_instant = f.h_plan - plannedMomentum(robot, r.plan, k_s);
    f.h_sim_t2 = simulatedMomentum(robot, *at_t2);
    f.vz_sim_t2 = at_t2->v_WC.z();
    for (const Eigen::Vector3d& w : at_t2->wheel_force_W) f.fz_sim_t2 += w.z();
  }
  // The tail's impulse from the CoM's vertical momentum (the contact forces, 1 ms samples of a
  // force that falls by 40 % within the first, overstate it by F(t2) / 2 ms as a sum): from the
  // last sample at or before t2 to Simbody's lift-off, less gravity's and the push's up to t2.
  if (at_t2 && lift) {
    const double mass = robot.calcCompositeInertia(JointVec::Zero()).mass;
    const double g = planner::PlannerSettings{}.gravity;
    f.tail_impulse_sim = mass * (lift->v_WC.z() - at_t2->v_WC.z() + g * (lift->t - at_t2->t)) -
                         f.fz_sim_t2 * (p.takeoff.t - at_t2->t);
  }
  // The touchdown pitch that the momentum gap alone makes: Simbody's flight momentum less the
  // plan's, over Simbody's pitch inertia from its lift-off to its touchdown (the rest of the
  // touchdown pitch error is the legs' flight motion and the attitude at lift-off).
  if (lift) {
    const auto& all = recorder.samples();
    double prev_inv = 0.0;
    for (std::size_t i = static_cast<std::size_t>(lift - all.data()); i < all.size(); ++i) {
      if (all[i].t > m.touchdown.t + 1e-9) break;
      const double inv = 1.0 / robot.calcCompositeInertia(toJointVec(all[i].q)).inertia_com(1, 1);
      if (&all[i] != lift) f.td_pitch_from_dh += 0.5 * (prev_inv + inv) * (all[i].t - all[i - 1].t);
      prev_inv = inv;
    }
    f.td_pitch_from_dh *= f.h_sim - f.h_plan_flight;
    // ... and the attitude at Simbody's lift-off against the plan's row at that instant.
    const Eigen::Matrix3d R = lift->q_WB.toRotationMatrix();
    const int k = std::min(static_cast<int>(std::lround(lift->t / r.plan.dt)),
                           static_cast<int>(r.plan.centroidal.size()) - 1);
    f.lift_pitch_error = calcUnwrappedPitch(R, 0.0) - r.plan.centroidal[k].pitch;
    // ... and the touchdown's instant: the plan's pitch at Simbody's touchdown less at its own.
    const int k_td = std::min(static_cast<int>(std::lround(m.touchdown.t / r.plan.dt)),
                              static_cast<int>(r.plan.centroidal.size()) - 1);
    f.td_instant_pitch = r.plan.centroidal[k_td].pitch - p.touchdown.state.pitch;
  }
  f.apex_plan = p.apex.state.z;
  f.apex_sim = m.apex.state.z;
  f.td_pitch_plan = p.touchdown.state.pitch;
  f.td_pitch_sim = m.touchdown.state.pitch;
  f.td_dx_plan = p.touchdown.state.x;
  f.td_dx_sim = m.touchdown.state.x;
  std::cout << "{\"task\": \"" << f.task << "\", \"seed\": " << seed << ", \"v0\": " << f.v0
            << ", \"t2\": [" << std::setprecision(9) << f.t2_plan << std::setprecision(6) << ", "
            << f.t2_sim << "], \"vx\": [" << f.vx_plan << ", " << f.vx_sim << "], \"vz\": ["
            << f.vz_plan << ", " << f.vz_sim << "], \"h\": [" << f.h_plan << ", " << f.h_sim
            << "], \"h_sim_t2\": " << f.h_sim_t2 << ", \"h_plan_flight\": " << f.h_plan_flight
            << ", \"f_t2\": [" << f.fx_t2 << ", " << f.fz_t2 << "], \"sim_t2\": [" << f.vz_sim_t2
            << ", " << f.fz_sim_t2 << ", " << f.tail_impulse_sim << "], \"apex\": [" << f.apex_plan
            << ", " << f.apex_sim << "], \"td_pitch\": [" << f.td_pitch_plan << ", "
            << f.td_pitch_sim << "], \"td_pitch_from_dh\": " << f.td_pitch_from_dh
            << ", \"lift_pitch_error\": " << f.lift_pitch_error
            << ", \"td_instant_pitch\": " << f.td_instant_pitch << ", \"td_dx\": [" << f.td_dx_plan
            << ", " << f.td_dx_sim << "], \"h_plan_instant\": " << f.h_plan_instant
            << ", \"h_flight\": [" << f.h_flight_plan << ", " << f.h_flight_sim
            << "], \"rounds\": " << f.rounds << ", \"h_parts\": [" << parts_json
            << "], \"h_impulse\": " << impulse_json
            << ", \"passed\": " << (f.passed ? "true" : "false") << "}" << std::endl;
  return f;
}

// The momentum function itself: a rigid robot (joints at rest) spinning at w about y has
// H = I_com w, the composite inertia of robot_model.
TEST(TakeoffFidelity, MomentumOfARigidSpinIsTheCompositeInertia) {
  const auto robot = model::RobotModel::loadDefault();
  JointVec q = JointVec::Zero();
  q[model::jointIndex(model::Leg::LF, model::JointKind::HFE)] = 0.6;
  q[model::jointIndex(model::Leg::LH, model::JointKind::KFE)] = -1.1;
  const Eigen::Vector3d w(0.3, -2.0, 0.5);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d H = angularMomentumAboutCom(robot, R, w, q, JointVec::Zero());
  const model::Inertia I = robot.calcCompositeInertia(q);
  const Eigen::Vector3d expected = R * I.inertia_com * R.transpose() * w;
  EXPECT_LT((H - expected).norm(), 1e-9 * expected.norm());
}

// The plan's own take-off obeys the centroidal dynamics: the change of the whole robot's
// angular momentum about its CoM (links, joints and wheels' spin, from the plan's rows) equals
// the moment of its ground forces integrated over the take-off.
// With the stance momentum off (the default, a rigid body in stance) it does not: the same
// check misses by 0.9-1.4 kg m^2/s (docs/planner.md, "Stance momentum"). The check ends at t2,
// before the unloading tail, which is off here so that the plans are those the bound was set
// on: with the tail the DE's plans are other ones, on which the E(t) interpolation misses by
// 0.005 / 0.024 / 0.026 (14, 4.6, 7.7 %; session 14).
TEST(TakeoffFidelity, PlannedMomentumFollowsTheGroundForces) {
  const auto robot = model::RobotModel::loadDefault();
  planner::PlannerSettings settings = plannerSettings(true, false);
  settings.takeoff_unload_s = 0.0;
  const planner::JumpPlanner planner(robot, settings);
  for (const char* task : {"forward_hw", "forward", "vertical"}) {
    const planner::Scenario sc = planner::makePreset(planner, task);
    planner::PlanOptions opts;
    opts.seed = 7;
    opts.threads = 2;
    const planner::JumpPlan plan = planner.plan(sc.task, sc.initial, opts).plan;
    const int n = static_cast<int>(std::floor(plan.t2 / plan.dt + 1e-9));
    double impulse = 0.0;  // trapezoid rule over the rows
    for (int k = 1; k <= n; ++k)
      impulse +=
          0.5 * (plannedMoment(robot, plan, k - 1) + plannedMoment(robot, plan, k)) * plan.dt;
    const double change = plannedMomentum(robot, plan, n) - plannedMomentum(robot, plan, 0);
    std::cout << task << ": momentum change " << change << ", moment impulse " << impulse
              << std::endl;
    // The E(t) interpolation's error; the rigid-body model of sessions 1-9 missed by 0.9-1.4.
    EXPECT_NEAR(change, impulse, 0.005 + 0.03 * std::abs(change)) << task;
  }
}

// The presets against Simbody (default settings), with the legs braking from their take-off
// speeds (session 11), the take-off's feed-forward carrying the legs' own dynamics (session
// 13), the lift-off's unloading tail (session 14) held to the executor's next control instant
// (session 16; docs/planner.md, "The lift-off's unloading tail"), the touchdown as the first
// wheel on the ground (session 15) and the wheels delivering the plan's traction (session 17,
// ExecutorSettings::takeoff_wheel_kd; docs/planner.md, "The wheels' traction in the push") and
// the balanced stance (session 18: the feed-forward's pair forces make the moment the motion
// needs, and the unloading tail takes that moment; docs/planner.md, "The balanced stance").
// At planner seeds 1 (sim_jump's default and issue 22's done-when) and 7: the lift-off CoM
// velocity at Simbody's lift-off within 0.5 % (issue 22's target is 1 %; 0.2-0.3 %, session 17
// 0.28-0.88 %, session 16 0.39-2.06 %), the touchdown pitch within 0.03 rad (+0.005, -0.010,
// +0.002 at seed 1; +0.020, -0.004, +0.002 at seed 7), the CoM apex within 1 cm (-4 to -6 mm)
// and the touchdown dx within 2.5 cm (-1.7, -1.8, +0.0 and -2.4, -2.3, +0.0 cm; session 17
// -1.97, -1.34, +0.83 and -1.95, -1.08, +0.85).
// Session 20 (the executor's momentum feedback and flight gains 300 / 6; docs/planner.md, "The
// take-off's momentum feedback"): touchdown pitch +0.002, -0.014, +0.000 and +0.012, -0.010,
// +0.001 rad, dx -0.9, -0.9, +0.1 and -1.5, -1.5, +0.0 cm, and the lift-off momentum of
// forward_hw and vertical within 6 % of the plan's flight momentum (5.6, 2.1 and 2.6, 3.1 %;
// 5.1-9.0 % without the feedback). Forward's flight momentum, -0.21 kg m^2/s, is too small
// for a relative bound (17-23 %, -0.038 to -0.048 kg m^2/s).
// Session 23 (the wheels' margins at the loaded tyre's rate, PlannerSettings::
// tyre_rolling_radius_ratio): forward_hw's seed 1 lands 0.21 rad nose-up (its target allows
// 0.25), with a flight momentum of -0.36 kg m^2/s, so the momentum bound is absolute: 0.035
// kg m^2/s on forward_hw and vertical (0.032, 0.007 and 0.019, 0.010 at seeds 1, 7).
// Each case prints one line of JSON.
TEST(TakeoffFidelity, PresetsAgreeWithTheSimulation) {
  for (const std::uint64_t seed : {1, 7})
    for (const char* task : {"forward_hw", "forward", "vertical"}) {
      const Fidelity f = measure(task, std::nullopt, seed);
      SCOPED_TRACE(std::string(task) + " seed " + std::to_string(seed));
      EXPECT_TRUE(f.passed);
      const double speed = std::hypot(f.vx_plan, f.vz_plan);
      EXPECT_LE(std::hypot(f.vx_sim - f.vx_plan, f.vz_sim - f.vz_plan), 0.005 * speed);
      EXPECT_LE(std::abs(f.apex_sim - f.apex_plan), 0.01);
      EXPECT_LE(std::abs(f.td_pitch_sim - f.td_pitch_plan), 0.03);
      EXPECT_LE(std::abs(f.td_dx_sim - f.td_dx_plan), 0.025);
      if (std::string(task) != "forward") {
        EXPECT_LE(std::abs(f.h_sim - f.h_plan_flight), 0.035);
      }
    }
}

// The grid's cases: the presets at their own run-up speed (nullopt) and at two others.
const std::vector<std::pair<std::string, std::optional<double>>> kGridCases = {
    {"forward_hw", std::nullopt}, {"forward_hw", 2.0}, {"forward_hw", 3.3},
    {"forward", std::nullopt},    {"forward", 2.5},    {"forward", 3.3},
    {"vertical", std::nullopt},   {"vertical", 0.5},   {"vertical", 1.0}};

// Issue 22's item 3 over the grid at seeds 1-5 (45 plans, about 2 s; the bench below prints
// the same cases' figures): on every plan Simbody verifies, the lift-off CoM velocity within
// 1 %, the CoM apex within 1 cm and the touchdown dx within 3 cm; the touchdown pitch within
// 0.03 rad on at least 90 % of them and within 0.05 on every one (session 33: 39 of 42, the
// others forward, down to -0.036: with the flight attitude's braking and tuck integrated by
// Simpson's rule the flight no longer makes up for forward's lift-off momentum deficit); the
// lift-off momentum of forward_hw and vertical within 0.04 kg m^2/s of the plan's flight
// momentum (at most 0.034, vertical; within 3 % on 18 of the 45). Forward's is not bounded: its
// flight momentum (-0.3 to +0.15 kg m^2/s) is too small for 3 %, and it misses by -0.03 to
// -0.09 (docs/planner.md, "The tyre's lag"). At least 38 of the 45 plans verify (42 in session 33;
// the others: forward_hw at 3.3 m/s, whose wheels reach their no-load speed, and two plans
// that end infeasible or past a knee's torque).
TEST(TakeoffFidelity, GridAgreesWithTheSimulation) {
  int verified = 0, pitch_within = 0;
  for (const auto& [task, v0] : kGridCases)
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      const Fidelity f = measure(task, v0, seed);
      if (!f.passed) continue;
      ++verified;
      SCOPED_TRACE(task + " v0 " + std::to_string(f.v0) + " seed " + std::to_string(seed));
      const double speed = std::hypot(f.vx_plan, f.vz_plan);
      EXPECT_LE(std::hypot(f.vx_sim - f.vx_plan, f.vz_sim - f.vz_plan), 0.01 * speed);
      EXPECT_LE(std::abs(f.apex_sim - f.apex_plan), 0.01);
      EXPECT_LE(std::abs(f.td_dx_sim - f.td_dx_plan), 0.03);
      const double pitch_error = std::abs(f.td_pitch_sim - f.td_pitch_plan);
      EXPECT_LE(pitch_error, 0.05);
      pitch_within += pitch_error <= 0.03;
      if (task != "forward") {
        EXPECT_LE(std::abs(f.h_sim - f.h_plan_flight), 0.04);
      }
    }
  EXPECT_GE(verified, 38);
  EXPECT_GE(pitch_within, 0.9 * verified) << pitch_within << " of " << verified;
}

// Issue 22's item 3 with the lift-off correction (sim::planWithLiftOffCorrection, up to three
// plans after the first; docs/planner.md, "The lift-off correction") over the same 45 cases,
// about 8 s: on every plan Simbody verifies, the lift-off CoM velocity within 1 %, the
// touchdown pitch within 0.03 rad, the apex within 1 cm and the touchdown dx within 3 cm; and
// where the iteration converged (its chosen round within the correction's tolerances, all but
// at most two), the flight's angular momentum (JumpEvent::momentum, the wheels as point
// masses: what turns the body in flight) within 3 % or the correction's own tolerance (0.01
// kg m^2/s; forward_hw's flights carry 0.02-0.1 kg m^2/s). Session 32: 43 of 45 verify (41
// without the correction), the momentum is within 3 % on 35 (5 without), the touchdown pitch
// within 0.03 on all verified. Session 33: forward_hw at 3.3 m/s, seed 1, alternates between a
// verified plan 0.032 kg m^2/s off and converged ones Simbody refuses (its wheels at their
// no-load speed), and keeps the verified one.
TEST(TakeoffFidelity, CorrectedGridMeetsTheTargets) {
  int verified = 0, momentum_within = 0, not_converged = 0;
  for (const auto& [task, v0] : kGridCases)
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      const Fidelity f = measure(task, v0, seed, false, 3);
      if (!f.passed) continue;
      ++verified;
      SCOPED_TRACE(task + " v0 " + std::to_string(f.v0) + " seed " + std::to_string(seed));
      const double speed = std::hypot(f.vx_plan, f.vz_plan);
      EXPECT_LE(std::hypot(f.vx_sim - f.vx_plan, f.vz_sim - f.vz_plan), 0.01 * speed);
      const double dh = std::abs(f.h_flight_sim - f.h_flight_plan);
      if (f.residual_ratio <= 1.0)
        EXPECT_LE(dh, std::max(0.03 * std::abs(f.h_flight_plan), 0.01));
      else
        ++not_converged;
      momentum_within += dh <= 0.03 * std::abs(f.h_flight_plan);
      EXPECT_LE(std::abs(f.td_pitch_sim - f.td_pitch_plan), 0.03);
      EXPECT_LE(std::abs(f.apex_sim - f.apex_plan), 0.01);
      EXPECT_LE(std::abs(f.td_dx_sim - f.td_dx_plan), 0.03);
    }
  EXPECT_GE(verified, 42);
  EXPECT_LE(not_converged, 2);
  EXPECT_GE(momentum_within, 30);
}

// The tyre's dissipation (Hunt-Crossley c, docs/sim.md "Contact": 0.8 s/m, assumed) acts in
// the unloading tail, not in the push (docs/takeoff-fidelity.md, "Session 35"). The same plan in
// Simbody at c = 0.4 and 1.2: Simbody's momentum at the plan's t2 moves by little, its tail (the
// lift-off's less t2's) by ten times as much. Seed 7, session 35 (vertical / forward): at t2
// by 0.006 / 0.005; tails 0.106 against 0.047 and 0.112 against 0.050; flight momentum 0.440
// against 0.394 and 0.560 against 0.513 kg m^2/s (plans 0.439, 0.576).
TEST(TakeoffFidelity, TheTyresDissipationActsInTheUnloadingTail) {
  for (const char* task : {"vertical", "forward"}) {
    SCOPED_TRACE(task);
    Fidelity at[2];
    const double c[2] = {0.4, 1.2};
    for (int i = 0; i < 2; ++i) {
      VerifierSettings s = verifierSettings();
      s.sim.contact.dissipation_s_m = c[i];
      at[i] = measure(task, std::nullopt, 7, false, 0, false, s);
      ASSERT_TRUE(at[i].passed);
    }
    ASSERT_EQ(at[0].h_flight_plan, at[1].h_flight_plan);  // one plan
    EXPECT_LE(std::abs(at[0].h_sim_t2 - at[1].h_sim_t2), 0.01);
    const double tail_less = at[0].h_sim - at[0].h_sim_t2;
    const double tail_more = at[1].h_sim - at[1].h_sim_t2;
    EXPECT_GE(tail_less - tail_more, 0.025);
    EXPECT_GE(at[0].h_flight_sim - at[1].h_flight_sim, 0.025);
    std::printf("%s: H at t2 %.4f / %.4f, tails %.4f / %.4f, flight %.4f / %.4f (plan %.4f)\n",
                task, at[0].h_sim_t2, at[1].h_sim_t2, tail_less, tail_more, at[0].h_flight_sim,
                at[1].h_flight_sim, at[0].h_flight_plan);
  }
}

// The flight the drives can fly (postures.drive_limited_tuck, physics.flight_feedforward; docs/
// planner.md, "The drive-limited tuck") with the lift-off correction, on the presets at seeds 1
// and 7: Simbody flies the plan's flight. Session 34: touchdown pitch within 0.005 rad, its
// "flight legs" part (what is left once the momentum, the lift-off attitude and the touchdown
// instant are taken out) within 0.011; the flight momentum within 3.1 % (forward_hw seed 7,
// 0.008 kg m^2/s: its flights carry 0.2); apex within 6.3 mm, dx within 1.2 cm. With the
// smoothstep tuck and no feed-forward, the service's settings asked the front knees for 60
// rad/s, and the legs' lag was most of the corrected plans' 0.02 rad (session 33).
TEST(TakeoffFidelity, DriveLimitedFlightWithTheCorrectionFliesThePlan) {
  for (const std::uint64_t seed : {1, 7})
    for (const char* task : {"forward_hw", "forward", "vertical"}) {
      const Fidelity f = measure(task, std::nullopt, seed, false, 2, true);
      SCOPED_TRACE(std::string(task) + " seed " + std::to_string(seed));
      EXPECT_TRUE(f.passed);
      const double pitch_error = f.td_pitch_sim - f.td_pitch_plan;
      EXPECT_LE(std::abs(pitch_error), 0.02);
      const double flight_legs =
          pitch_error - f.td_pitch_from_dh - f.lift_pitch_error - f.td_instant_pitch;
      EXPECT_LE(std::abs(flight_legs), 0.015);
      EXPECT_LE(std::abs(f.h_flight_sim - f.h_flight_plan),
                std::max(0.03 * std::abs(f.h_flight_plan), 0.01));
      EXPECT_LE(std::abs(f.apex_sim - f.apex_plan), 0.01);
      EXPECT_LE(std::abs(f.td_dx_sim - f.td_dx_plan), 0.02);
    }
}

// The grid of scripts/bench-takeoff-fidelity.sh (WJ_FIDELITY_BENCH=1; skipped otherwise):
// seeds 1..WJ_FIDELITY_SEEDS (default 3) of kGridCases, with the stance momentum if
// WJ_FIDELITY_STANCE_MOMENTUM=1.
// Prints one JSON line per case; checks nothing but that each plan verifies in Simbody.
TEST(TakeoffFidelity, BenchGrid) {
  const char* bench = std::getenv("WJ_FIDELITY_BENCH");
  if (!bench || std::string(bench) != "1") GTEST_SKIP() << "set WJ_FIDELITY_BENCH=1";
  const char* seeds_env = std::getenv("WJ_FIDELITY_SEEDS");
  const int seeds = seeds_env ? std::atoi(seeds_env) : 3;
  for (const auto& [task, v0] : kGridCases)
    for (int seed = 1; seed <= seeds; ++seed)
      measure(task, v0, static_cast<std::uint64_t>(seed), stanceMomentumFromEnv());
}

}  // namespace
}  // namespace wj::sim
