#include "planner/presets.h"

#include <cmath>
#include <stdexcept>

namespace wj::planner {

std::vector<std::string> presetNames() {
  return {"forward", "forward_hw", "vertical", "backflip", "platform"};
}

double comHeightForBaseHeight(const model::RobotModel& robot, const Eigen::VectorXd& q,
                              double base_height) {
  return base_height + robot.calcCompositeInertia(q).com.z();
}

Scenario makePreset(const JumpPlanner& planner, const std::string& name, std::optional<double> v0) {
  const auto& s = planner.settings();
  Scenario sc;
  sc.name = name;
  sc.initial.q = planner.standPosture();
  Eigen::VectorXd q_land = sc.initial.q;
  for (const model::Leg leg : model::kLegs) {
    q_land[model::jointIndex(leg, model::JointKind::HFE)] = s.landing_hfe_rad;
    q_land[model::jointIndex(leg, model::JointKind::KFE)] = s.landing_kfe_rad;
  }
  const double z_land = JumpModel::standingComHeight(planner.robot(), q_land);
  if (name == "forward") {
    // Paper Sec. IV-B: run-up at 3 m/s, over a 0.25 m wall, landing upright.
    sc.initial.v0 = v0.value_or(3.0);
    sc.task.mode = TakeoffMode::Simultaneous;
    // Land upright beyond the wall (the rear wheel past its far face is a constraint of the
    // obstacle class); 1.9 m of CoM travel is what a 3 m/s run-up gives for a jump this high.
    // Touchdown 0.3 rad nose-up, hind wheels first: level (0 +- 0.25 rad) is out of reach in
    // this model (the front wheels cannot pull the nose down: normal force binds), and the
    // multibody simulation lands the 0.3 rad touchdown upright (docs/planner.md, "What the
    // presets give").
    sc.task.obstacle = BoxObstacle{1.2, 1.3, 0.25};
    sc.task.target = {1.9, z_land, 0.3, TargetEvent::Touchdown};
  } else if (name == "forward_hw") {
    // Paper Sec. V-B, hardware: the same run-up over a 0.12 m obstacle.
    sc.initial.v0 = v0.value_or(3.0);
    sc.task.mode = TakeoffMode::Simultaneous;
    sc.task.obstacle = BoxObstacle{1.2, 1.3, 0.12};
    sc.task.target = {1.9, z_land, 0.0, TargetEvent::Touchdown};
  } else if (name == "vertical") {
    // Paper Sec. V-B: target base apex 0.7 m from standing (hardware reached 0.5 m).
    sc.initial.v0 = v0.value_or(0.0);
    sc.task.mode = TakeoffMode::Simultaneous;
    sc.task.target = {0.0, comHeightForBaseHeight(planner.robot(), q_land, 0.7), 0.0,
                      TargetEvent::Apex};
  } else if (name == "backflip") {
    // Paper Sec. IV-B: a full backward rotation landing about 0.55 m behind, two-step take-off.
    sc.initial.v0 = v0.value_or(0.0);
    sc.task.mode = TakeoffMode::TwoStep;
    sc.task.target = {-0.55, z_land, 2.0 * M_PI, TargetEvent::Touchdown};
  } else if (name == "platform") {
    // Beyond the paper: from the forward run-up onto a 0.25 m platform (a kerb, a step); all
    // four wheels land on its top. Its near face is 1.6 m ahead: with the forward preset's
    // 1.2 m no seed finds a plan (the envelope binds at the end of the push), with 1.5 and
    // 1.6 m 5 of 5 seeds do (plan_jump, session 9). The target height is the standing height
    // on the top; the touchdown is the first wheel on it (the hind wheels at the 0.2 rad
    // nose-up landing), as in the simulation (docs/planner.md, "Touchdown").
    sc.initial.v0 = v0.value_or(3.0);
    sc.task.mode = TakeoffMode::Simultaneous;
    sc.task.obstacle = BoxObstacle{1.6, 1.6 + kPlatformLength, kPlatformHeight};
    sc.task.target = {2.0, z_land + kPlatformHeight, 0.2, TargetEvent::Touchdown};
  } else {
    throw std::invalid_argument(
        "preset '" + name + "' is not one of forward, forward_hw, vertical, backflip, platform");
  }
  return sc;
}

}  // namespace wj::planner
