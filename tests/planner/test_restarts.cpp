// de.restart_while_budget: a search whose best still violates a constraint after the planned
// restarts goes on with fresh populations while the evaluation budget lasts (docs/planner.md,
// "Restarts"), on the robot client's service settings (config/planner_settings.yaml).
#include <gtest/gtest.h>

#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "test_robot.h"

namespace wj::planner {
namespace {

using wj::test::robot;

PlannerResult planPlatform(bool restart_while_budget, std::uint64_t seed) {
  PlannerSettings s = PlannerSettings::fromYaml(WJ_CONFIG_DIR "/planner_settings.yaml");
  s.de_restart_while_budget = restart_while_budget;
  const JumpPlanner planner(robot(), s);
  const Scenario sc = makePreset(planner, "platform", 3.0);
  PlanOptions o;
  o.seed = seed;
  o.threads = 2;
  return planner.plan(sc.task, sc.initial, o);
}

// The platform at 3 m/s, seed 2: the four planned attempts all stagnate with the actuator
// envelope violated, 3,264 of the 12,000 evaluations spent; the attempts after them find a plan.
TEST(Restarts, GoOnWhileTheBudgetLastsAndTheBestViolatesAConstraint) {
  const PlannerResult planned = planPlatform(false, 2);
  ASSERT_FALSE(planned.evaluation.feasible);
  EXPECT_FALSE(planned.evaluation.constraints_ok) << planned.summary;
  EXPECT_EQ(planned.de_restarts, 3);
  EXPECT_LT(planned.de.evaluations, 6000);

  const PlannerResult more = planPlatform(true, 2);
  EXPECT_TRUE(more.evaluation.feasible) << more.summary;
  EXPECT_GT(more.de_restarts, 3);
  EXPECT_LE(more.de.evaluations, 12000);
}

// A search that ends feasible within its planned attempts is the same search either way.
TEST(Restarts, LeaveASearchThatFindsAPlanAsItWas) {
  const PlannerResult planned = planPlatform(false, 1);
  const PlannerResult more = planPlatform(true, 1);
  ASSERT_TRUE(planned.evaluation.feasible) << planned.summary;
  EXPECT_EQ(planned.u, more.u);
  EXPECT_EQ(planned.de.evaluations, more.de.evaluations);
}

// The budget bounds the attempts: a task no attempt meets (the backflip on the 42 Nm robot,
// from standing) spends the whole budget and stops.
TEST(Restarts, StopWhenTheBudgetIsSpent) {
  PlannerSettings s;
  const JumpPlanner planner(robot(), s);
  const Scenario sc = makePreset(planner, "backflip");
  PlanOptions o;
  o.seed = 1;
  o.threads = 2;
  o.max_evaluations = 4000;
  o.polish = false;
  const PlannerResult r = planner.plan(sc.task, sc.initial, o);
  EXPECT_FALSE(r.evaluation.constraints_ok);
  EXPECT_LE(r.de.evaluations, 4000);
  EXPECT_GT(r.de.evaluations, 4000 - 10 * s.de.population_size);
}

}  // namespace
}  // namespace wj::planner
