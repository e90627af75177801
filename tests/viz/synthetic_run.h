#pragma once
// A small made-up jump for the viewer tests (no simulation): the robot stands, rolls, leaves the
// ground with (vx, vz), flies ballistically with a fixed posture and lands. The pose is exact
// by construction, so that the pictures can be checked against it.
#include <algorithm>
#include <cmath>

#include "viz/recording.h"

namespace wj::viz::testing {

struct SyntheticJump {
  double vx = 1.5;      ///< forward speed throughout [m/s]; 0: a jump in place
  double vz = 2.2;      ///< vertical CoM speed at lift-off [m/s]
  double t_lift = 0.4;  ///< lift-off [s]
  double t_end = 1.5;   ///< end of the run [s]
  double dt = 0.002;    ///< frame period [s]
  bool wall = true;     ///< a 0.25 m wall under the apex
};

/// The posture used throughout (every leg: HFE 0.6, KFE -1.2 rad).
inline Eigen::VectorXd syntheticPosture() {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(model::kNumJoints);
  for (const model::Leg leg : model::kLegs) {
    q[model::jointIndex(leg, model::JointKind::HFE)] = 0.6;
    q[model::jointIndex(leg, model::JointKind::KFE)] = -1.2;
  }
  return q;
}

inline Recording makeSyntheticJump(const model::RobotModel& robot, const SyntheticJump& s) {
  const Eigen::VectorXd q = syntheticPosture();
  // CoM height with the wheels on the ground: CoM above the lowest wheel centre by its depth.
  const Frame probe = makePlanarFrame(robot, 0.0, 0.0, 0.0, 0.0, q);
  Eigen::VectorXd qv = q;
  const auto X = robot.calcLinkPoses(qv);
  double lowest = 0.0;
  for (const model::Leg leg : model::kLegs)
    lowest = std::min(
        lowest,
        (probe.p_WB + X[robot.joint(leg, model::JointKind::Wheel).child_link].translation()).z());
  const double z_stand = -lowest + robot.wheelRadius();
  const double g = 9.81;
  const double t_land = s.t_lift + 2.0 * s.vz / g;
  Recording rec;
  rec.title = s.vx > 0.0 ? "synthetic forward jump" : "synthetic vertical jump";
  for (int k = 0; s.dt * k <= s.t_end + 1e-9; ++k) {
    const double t = s.dt * k;
    const double tf = std::clamp(t - s.t_lift, 0.0, t_land - s.t_lift);
    const double z = z_stand + s.vz * tf - 0.5 * g * tf * tf;
    Frame f = makePlanarFrame(robot, t, s.vx * t, z, 0.0, q);
    const double wheel_rate = s.vx / robot.wheelRadius();
    for (const model::Leg leg : model::kLegs) {
      f.q[model::jointIndex(leg, model::JointKind::Wheel)] = wheel_rate * t;
      f.qd[model::jointIndex(leg, model::JointKind::Wheel)] = wheel_rate;
      f.tau[model::jointIndex(leg, model::JointKind::KFE)] = t < s.t_lift ? -30.0 : 0.0;
    }
    f.phase = t < s.t_lift - 0.2 ? "roll"
              : t < s.t_lift     ? "takeoff"
              : t < t_land       ? "flight"
                                 : "landing";
    rec.planned_com.push_back({t, f.p_WC + Eigen::Vector3d(0.0, 0.0, 0.01)});
    rec.frames.push_back(std::move(f));
  }
  rec.jump_start_t = s.t_lift - 0.2;
  rec.touchdown_t = t_land;
  if (s.wall) {
    const double x_apex = s.vx * (s.t_lift + s.vz / g);
    rec.boxes.push_back(
        {Eigen::Vector3d(x_apex - 0.05, -1.0, 0.0), Eigen::Vector3d(x_apex + 0.05, 1.0, 0.25)});
  }
  return rec;
}

}  // namespace wj::viz::testing
