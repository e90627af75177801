// A jump onto a platform, planned by the planner and executed in Simbody on the platform as
// terrain: all four wheels land on its top, the robot ends upright at its standing height
// above the top; the same plan over flat ground lands lower and later than it predicts.
#include <gtest/gtest.h>

#include <filesystem>

#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "sim/verifier.h"
#include "test_robot.h"

namespace wj::sim {
namespace {

using wj::test::loadRobot;

TEST(PlatformLanding, TaskScenarioIsAPlatformTerrainOrAWallObstacle) {
  const auto robot = loadRobot();
  const planner::JumpPlanner planner(robot, planner::PlannerSettings{});
  const Scenario platform = scenarioForTask(planner::makePreset(planner, "platform").task);
  ASSERT_EQ(platform.terrain.boxes.size(), 1u);
  EXPECT_FALSE(platform.terrain.boxes[0].obstacle);
  EXPECT_DOUBLE_EQ(platform.terrain.heightAt(2.0, 0.0), planner::kPlatformHeight);
  EXPECT_DOUBLE_EQ(platform.terrain.heightAt(1.0, 0.0), 0.0);
  const Scenario wall = scenarioForTask(planner::makePreset(planner, "forward").task);
  ASSERT_EQ(wall.terrain.boxes.size(), 1u);
  EXPECT_TRUE(wall.terrain.boxes[0].obstacle);
  EXPECT_TRUE(scenarioForTask(planner::makePreset(planner, "vertical").task).terrain.boxes.empty());
}

TEST(PlatformLanding, PlannedJumpLandsOnTheStepInSimbody) {
  const auto robot = loadRobot();
  const planner::JumpPlanner planner(robot, planner::PlannerSettings{});
  const planner::Scenario sc = planner::makePreset(planner, "platform");
  planner::PlanOptions o;
  o.seed = 1;
  const planner::PlannerResult r = planner.plan(sc.task, sc.initial, o);
  ASSERT_TRUE(r.evaluation.feasible) << r.summary;

  const Verifier verifier(robot, VerifierSettings{});
  const VerificationReport v = verifier.verify(r.plan, scenarioForTask(sc.task));
  for (const auto& reason : v.reasons) ADD_FAILURE() << reason;
  EXPECT_TRUE(v.passed);
  EXPECT_TRUE(v.landed_upright);
  EXPECT_FALSE(v.base_contact);
  EXPECT_FALSE(v.leg_contact);
  // First contact on the top, where the plan puts it, and standing on the top at the end.
  EXPECT_NEAR(v.measured.touchdown.state.z, r.evaluation.predicted.touchdown.state.z, 0.05);
  EXPECT_GT(v.measured.touchdown.state.x, sc.task.obstacle->x_min);
  EXPECT_NEAR(v.final_base_height_m, v.nominal_base_height_m, 0.06);

  // Without the platform the robot falls 0.25 m further: the verifier sees the touchdown
  // after the plan's and far below it.
  const VerificationReport flat = verifier.verify(r.plan, Scenario{});
  EXPECT_LT(flat.measured.touchdown.state.z,
            r.evaluation.predicted.touchdown.state.z - 0.8 * planner::kPlatformHeight);
}

}  // namespace
}  // namespace wj::sim
