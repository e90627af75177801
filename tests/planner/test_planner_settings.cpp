// The planner's settings file (planner_settings.h): unknown keys refused by name, each key
// read and checked with its range, and the robot client's service settings.
#include <gtest/gtest.h>

#include <string>

#include "error_of.h"
#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "test_robot.h"

namespace wj::planner {
namespace {

using wj::test::robot;

JumpPlanner makePlanner(PlannerSettings s = {}) {
  return JumpPlanner(robot(), s);
}

// The robot client's service settings (config/planner_settings.yaml, docs/robust.md) read
// strictly, and with them the forward preset plans over its wall with the 5 cm margin.
TEST(PlannerSettings, ServiceSettingsPlanTheForwardWallWithTheirMargin) {
  const PlannerSettings s = PlannerSettings::fromYaml(WJ_CONFIG_DIR "/planner_settings.yaml");
  EXPECT_DOUBLE_EQ(s.obstacle_margin_m, 0.05);
  EXPECT_DOUBLE_EQ(s.platform_margin_m, 0.03);
  const JumpPlanner planner = makePlanner(s);
  const Scenario sc = makePreset(planner, "forward");
  PlanOptions o;
  o.seed = 7;
  o.threads = 1;
  const PlannerResult r = planner.plan(sc.task, sc.initial, o);
  ASSERT_TRUE(r.evaluation.feasible) << r.summary;
  EXPECT_GE(r.evaluation.predicted.min_obstacle_clearance, 0.05);
  EXPECT_THROW((void)PlannerSettings::fromYamlString("physics: {platform_margin_m: -0.01}\n"),
               std::runtime_error);
}

TEST(PlannerSettings, YamlFailsOnUnknownKeysAndNamesThem) {
  const PlannerSettings s = PlannerSettings::fromYamlString(
      "physics: {friction_mu: 0.5}\nde: {seed: 9, strategy: rand1bin}\n"
      "bounds: {t1_s: [0.1, 0.3]}\n");
  EXPECT_DOUBLE_EQ(s.friction_mu, 0.5);
  EXPECT_EQ(s.de.seed, 9u);
  EXPECT_EQ(s.de.strategy, de::Strategy::Rand1Bin);
  EXPECT_DOUBLE_EQ(s.t1_s[1], 0.3);
  EXPECT_THAT(test::errorOf<std::runtime_error>(
                  [&] { return PlannerSettings::fromYamlString("physics: {fricton_mu: 0.5}\n"); }),
              test::HasSubstr("physics.fricton_mu"));
  EXPECT_THROW((void)PlannerSettings::fromYamlString("de: {strategy: best9}\n"),
               std::runtime_error);
  EXPECT_THROW((void)PlannerSettings::fromYamlString("physics: {friction_mu: -1}\n"),
               std::runtime_error);
}

TEST(PlannerSettings, UnloadingTailIsReadAndCheckedWithItsRange) {
  EXPECT_DOUBLE_EQ(PlannerSettings().takeoff_unload_s, 0.003);
  EXPECT_DOUBLE_EQ(
      PlannerSettings::fromYamlString("physics: {takeoff_unload_s: 0.0}\n").takeoff_unload_s, 0.0);
  EXPECT_THAT(test::errorOf<std::runtime_error>([] {
                (void)PlannerSettings::fromYamlString("physics: {takeoff_unload_s: 0.05}\n");
              }),
              test::HasSubstr("physics.takeoff_unload_s must be in [0, 0.02]"));
}

TEST(PlannerSettings, TyreIsReadAndCheckedWithItsRange) {
  const PlannerSettings d;
  EXPECT_DOUBLE_EQ(d.tyre_rolling_radius_ratio, 0.99);
  EXPECT_DOUBLE_EQ(d.tyre_slip_stiffness_n_s_m, 370.0);
  const PlannerSettings s = PlannerSettings::fromYamlString(
      "physics: {tyre_rolling_radius_ratio: 1.0, tyre_slip_stiffness_n_s_m: 1.0e12}\n");
  EXPECT_DOUBLE_EQ(s.tyre_rolling_radius_ratio, 1.0);
  EXPECT_DOUBLE_EQ(s.tyre_slip_stiffness_n_s_m, 1e12);
  EXPECT_THAT(
      test::errorOf<std::runtime_error>([] {
        (void)PlannerSettings::fromYamlString("physics: {tyre_rolling_radius_ratio: 0.5}\n");
      }),
      test::HasSubstr("physics.tyre_rolling_radius_ratio must be in [0.8, 1.2], got 0.5"));
  EXPECT_THAT(test::errorOf<std::runtime_error>([] {
                (void)PlannerSettings::fromYamlString("physics: {tyre_slip_stiffness_n_s_m: 0}\n");
              }),
              test::HasSubstr("physics.tyre_slip_stiffness_n_s_m must be > 0"));
  // The tyre's sink: off (the rigid wheel) unless a modulus is given.
  EXPECT_EQ(d.tyre_contact_modulus_pa, 0.0);
  EXPECT_DOUBLE_EQ(PlannerSettings::fromYamlString("physics: {tyre_contact_modulus_pa: 2.83e6}\n")
                       .tyre_contact_modulus_pa,
                   2.83e6);
  EXPECT_THAT(test::errorOf<std::runtime_error>([] {
                (void)PlannerSettings::fromYamlString("physics: {tyre_contact_modulus_pa: 50}\n");
              }),
              test::HasSubstr("physics.tyre_contact_modulus_pa must be 0 (rigid) or in [1e5, "
                              "1e10], got 50"));
}

TEST(PlannerSettings, BalancedStanceIsReadAndCheckedAsABoolean) {
  EXPECT_TRUE(PlannerSettings().balanced_stance);
  EXPECT_FALSE(
      PlannerSettings::fromYamlString("physics: {balanced_stance: false}\n").balanced_stance);
  EXPECT_THAT(test::errorOf<std::runtime_error>([] {
                (void)PlannerSettings::fromYamlString("physics: {balanced_stance: 0.5}\n");
              }),
              test::HasSubstr("physics.balanced_stance"));
}

TEST(PlannerSettings, FlightFeedForwardAndDriveLimitedTuckAreReadAndCheckedAsBooleans) {
  EXPECT_FALSE(PlannerSettings().flight_feedforward);
  EXPECT_FALSE(PlannerSettings().drive_limited_tuck);
  const PlannerSettings s = PlannerSettings::fromYamlString(
      "physics: {flight_feedforward: true}\npostures: {drive_limited_tuck: true}\n");
  EXPECT_TRUE(s.flight_feedforward);
  EXPECT_TRUE(s.drive_limited_tuck);
  EXPECT_THAT(test::errorOf<std::runtime_error>([] {
                (void)PlannerSettings::fromYamlString("physics: {flight_feedforward: 2}\n");
              }),
              test::HasSubstr("physics.flight_feedforward"));
  EXPECT_THAT(test::errorOf<std::runtime_error>([] {
                (void)PlannerSettings::fromYamlString("postures: {drive_limited_tuck: fast}\n");
              }),
              test::HasSubstr("postures.drive_limited_tuck"));
  // Where they belong: a section refuses the other's key.
  EXPECT_THAT(test::errorOf<std::runtime_error>([] {
                (void)PlannerSettings::fromYamlString("physics: {drive_limited_tuck: true}\n");
              }),
              test::HasSubstr("drive_limited_tuck"));
}

TEST(PlannerSettings, StanceMomentumIsReadAndCheckedAsABoolean) {
  EXPECT_FALSE(PlannerSettings().stance_momentum);
  EXPECT_TRUE(
      PlannerSettings::fromYamlString("physics: {stance_momentum: true}\n").stance_momentum);
  EXPECT_THAT(test::errorOf<std::runtime_error>(
                  [] { (void)PlannerSettings::fromYamlString("physics: {stance_momentum: 2}\n"); }),
              test::HasSubstr("physics.stance_momentum"));
}

TEST(PlannerSettings, RestartWhileBudgetIsReadAndCheckedAsABoolean) {
  EXPECT_TRUE(PlannerSettings().de_restart_while_budget);
  EXPECT_FALSE(PlannerSettings::fromYamlString("de: {restart_while_budget: false}\n")
                   .de_restart_while_budget);
  EXPECT_THAT(test::errorOf<std::runtime_error>(
                  [] { (void)PlannerSettings::fromYamlString("de: {restart_while_budget: 3}\n"); }),
              test::HasSubstr("de.restart_while_budget"));
}

TEST(PlannerSettings, ContactChainIsReadAndCheckedByName) {
  EXPECT_EQ(PlannerSettings().contact_chain, ContactChain::FromStart);
  EXPECT_EQ(
      PlannerSettings::fromYamlString("sampling: {contact_chain: from_takeoff}\n").contact_chain,
      ContactChain::FromTakeoff);
  {
    const std::string error = test::errorOf<std::runtime_error>(
        [] { return PlannerSettings::fromYamlString("sampling: {contact_chain: backwards}\n"); });
    EXPECT_THAT(error, test::HasSubstr("sampling.contact_chain"));
    EXPECT_THAT(error, test::HasSubstr("from_start, from_takeoff"));
  }
  PlannerSettings s;
  s.contact_chain = static_cast<ContactChain>(5);
  EXPECT_THROW(s.validate(), std::invalid_argument);
}

TEST(PlannerSettings, PolishSolverIsReadAndCheckedByName) {
  EXPECT_EQ(PlannerSettings().polish_solver, PolishSolver::Sqp);
  EXPECT_EQ(PlannerSettings::fromYamlString("polish: {solver: ipopt}\n").polish_solver,
            PolishSolver::Ipopt);
  EXPECT_EQ(PlannerSettings::fromYamlString("polish: {solver: sqp}\n").polish_solver,
            PolishSolver::Sqp);
  {
    const std::string error = test::errorOf<std::runtime_error>(
        [] { return PlannerSettings::fromYamlString("polish: {solver: snopt}\n"); });
    EXPECT_THAT(error, test::HasSubstr("polish.solver"));
    EXPECT_THAT(error, test::HasSubstr("ipopt, sqp"));
  }
  PlannerSettings s;
  s.polish_solver = static_cast<PolishSolver>(7);
  EXPECT_THROW(s.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace wj::planner
