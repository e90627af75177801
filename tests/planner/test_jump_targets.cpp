// The planner's drive model setting (the paper's constant torque against the envelope) and
// its jump targets above the take-off ground (a platform landed on).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "error_of.h"
#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "test_robot.h"

namespace wj::planner {
namespace {

using wj::test::robot;

double margin(const Evaluation& ev, ConstraintClass c) {
  return ev.margins[static_cast<int>(c)].worst;
}

TEST(PlannerSettings, ActuatorModelIsReadAndCheckedByName) {
  EXPECT_EQ(PlannerSettings().actuator_model, ActuatorModel::Envelope);
  EXPECT_EQ(PlannerSettings::fromYamlString("physics: {actuator_model: constant_torque}\n")
                .actuator_model,
            ActuatorModel::ConstantTorque);
  {
    const std::string error = test::errorOf<std::runtime_error>(
        [] { return PlannerSettings::fromYamlString("physics: {actuator_model: none}\n"); });
    EXPECT_THAT(error, test::HasSubstr("physics.actuator_model"));
    EXPECT_THAT(error, test::HasSubstr("constant_torque, envelope"));
  }
  PlannerSettings s;
  s.actuator_model = static_cast<ActuatorModel>(7);
  EXPECT_THROW(s.validate(), std::invalid_argument);
}

// The same fast vertical take-off under both drive models: with the envelope the knee's
// available torque falls past the corner speed (20 rad/s), so its margin is below the peak
// torque's; with the paper's constant torque the two classes give the same margin.
TEST(JumpModel, ConstantTorqueDropsTheTorqueSpeedEnvelope) {
  const JumpPlanner planner(robot(), PlannerSettings{});
  const Scenario sc = makePreset(planner, "vertical");
  PlanOptions o;
  o.seed = 3;  // seed 1's knee stays at 17 rad/s since the braking is checked at the lift-off
  o.polish = false;
  o.max_evaluations = 1500;
  const PlannerResult r = planner.plan(sc.task, sc.initial, o);
  ASSERT_TRUE(r.evaluation.valid);
  ASSERT_GT(r.evaluation.max_abs_speed_rad_s[2], 21.0) << "the knee must pass the corner speed";

  PlannerSettings paper;
  paper.actuator_model = ActuatorModel::ConstantTorque;
  const JumpModel envelope_model(robot(), PlannerSettings{}, sc.task, sc.initial);
  const JumpModel paper_model(robot(), paper, sc.task, sc.initial);
  Evaluation with_envelope, constant;
  envelope_model.evaluate(r.u, with_envelope);
  paper_model.evaluate(r.u, constant);
  ASSERT_TRUE(with_envelope.valid && constant.valid);
  // Same trajectory, same torques: only the limit differs.
  EXPECT_DOUBLE_EQ(with_envelope.max_abs_torque_nm[2], constant.max_abs_torque_nm[2]);
  EXPECT_DOUBLE_EQ(margin(constant, ConstraintClass::ActuatorEnvelope),
                   margin(constant, ConstraintClass::JointTorque));
  EXPECT_LT(margin(with_envelope, ConstraintClass::ActuatorEnvelope),
            margin(constant, ConstraintClass::ActuatorEnvelope) - 1.0);
}

// A touchdown target over the box means landing on it; over the ground beyond, clearing it.
TEST(JumpTask, APlatformIsAnObstacleTheTouchdownIsOver) {
  const JumpPlanner planner(robot(), PlannerSettings{});
  EXPECT_TRUE(makePreset(planner, "platform").task.landsOnObstacle());
  EXPECT_FALSE(makePreset(planner, "forward").task.landsOnObstacle());
  EXPECT_FALSE(makePreset(planner, "vertical").task.landsOnObstacle());
  JumpTask low = makePreset(planner, "platform").task;
  low.target.height = 0.2;  // below the 0.25 m top
  EXPECT_THAT(test::errorOf<std::invalid_argument>([&] { return low.validate(); }),
              test::HasSubstr("task.target.height"));
}

class PlatformPlan : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    static const JumpPlanner planner(robot(), PlannerSettings{});
    planner_ = &planner;
    scenario_ = makePreset(planner, "platform");
    PlanOptions o;
    o.seed = 1;
    result_ = planner.plan(scenario_.task, scenario_.initial, o);
  }
  Evaluation evaluateWith(const JumpTask& task) const {
    const JumpModel m(robot(), planner_->settings(), task, scenario_.initial);
    Evaluation ev;
    m.evaluate(result_.u, ev);
    return ev;
  }
  static const JumpPlanner* planner_;
  static Scenario scenario_;
  static PlannerResult result_;
};
const JumpPlanner* PlatformPlan::planner_ = nullptr;
Scenario PlatformPlan::scenario_;
PlannerResult PlatformPlan::result_;

TEST_F(PlatformPlan, LandsOnTopAtTheTargetHeight) {
  ASSERT_TRUE(result_.evaluation.feasible) << result_.summary;
  const JumpOutcome& p = result_.evaluation.predicted;
  // Touchdown is the first wheel on the top (the hind pair, nose-up), before the CoM comes
  // down to the target height (standing on the top), above the box.
  EXPECT_GE(p.touchdown.state.z, scenario_.task.target.height - 1e-9);
  EXPECT_LT(p.touchdown.state.z, scenario_.task.target.height + 0.05);
  EXPECT_GT(p.touchdown.state.x, scenario_.task.obstacle->x_min);
  EXPECT_GE(margin(result_.evaluation, ConstraintClass::ObstacleClearance), 0.0);
}

TEST_F(PlatformPlan, TheLandingHeightSetsTheFlightTime) {
  ASSERT_TRUE(result_.evaluation.valid);
  // The same take-off landing on the ground beyond instead: the CoM falls 0.25 m further.
  JumpTask ground = scenario_.task;
  ground.obstacle.reset();
  ground.target.height -= kPlatformHeight;
  const Evaluation on_top = evaluateWith(scenario_.task), below = evaluateWith(ground);
  const PlanarState& to = on_top.predicted.takeoff.state;
  const double g = PlannerSettings{}.gravity;
  const auto flight = [&](double z_td) {
    return (to.vz + std::sqrt(to.vz * to.vz + 2.0 * g * (to.z - z_td))) / g;
  };
  // ... or the apex, if the CoM never rises above z_td.
  const auto flight_down_to = [&](double z_td) {
    return to.z + to.vz * to.vz / (2.0 * g) > z_td ? flight(z_td) : std::max(to.vz, 0.0) / g;
  };
  // The first wheel is down no later than the CoM at the standing height (t2 + Tf), and no
  // earlier than the CoM within the landing posture's reach of the surface (the lowest any
  // wheel can be below the CoM, at any pitch; seed 1 lands 0.32 rad nose-up, its hind wheels
  // down 59 ms before the CoM reaches the standing height).
  const double t_top = on_top.predicted.touchdown.t - on_top.predicted.takeoff.t;
  const double t_ground = below.predicted.touchdown.t - below.predicted.takeoff.t;
  const double reach = JumpModel(robot(), planner_->settings(), scenario_.task, scenario_.initial)
                           .constants()
                           .touchdown_reach;
  const double z_land = scenario_.task.target.height - kPlatformHeight;  // on the ground
  EXPECT_LE(t_top, flight(scenario_.task.target.height) + 1e-9);
  EXPECT_GE(t_top, flight_down_to(kPlatformHeight + reach) - 1e-9);
  EXPECT_GT(reach, z_land);
  EXPECT_LE(t_ground, flight(ground.target.height) + 1e-9);
  EXPECT_GE(t_ground, flight_down_to(reach) - 1e-9);
  EXPECT_GT(below.predicted.touchdown.t, on_top.predicted.touchdown.t + 0.05);
}

TEST_F(PlatformPlan, WheelsOffEitherEdgeViolateTheObstacleClass) {
  ASSERT_TRUE(result_.evaluation.feasible);
  const double x_td = result_.evaluation.predicted.touchdown.state.x;
  // The near face just behind the CoM at touchdown: the hind wheels land short of the top.
  JumpTask short_of = scenario_.task;
  short_of.obstacle->x_min = x_td - 0.05;
  short_of.target.dx = x_td;
  EXPECT_LT(margin(evaluateWith(short_of), ConstraintClass::ObstacleClearance), -0.05);
  // The far face just ahead of the CoM: the front wheels land beyond the top.
  JumpTask beyond = scenario_.task;
  beyond.obstacle->x_max = x_td + 0.05;
  beyond.target.dx = x_td - 0.01;
  EXPECT_LT(margin(evaluateWith(beyond), ConstraintClass::ObstacleClearance), -0.05);
  // As a wall to clear (the touchdown target beyond its far face), the same box is hit.
  JumpTask wall = scenario_.task;
  wall.obstacle->x_max = 4.0;
  wall.target.dx = 4.5;
  EXPECT_FALSE(wall.landsOnObstacle());
  EXPECT_LT(margin(evaluateWith(wall), ConstraintClass::ObstacleClearance), 0.0);
}

}  // namespace
}  // namespace wj::planner
