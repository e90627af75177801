// postures.wall_extend_start_fraction: when the legs of a jump over a wall start extending to
// the landing posture (docs/robust.md, "The nominal touchdown pitch"), and the robot client's
// service settings that use it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "test_robot.h"

namespace wj::planner {
namespace {

using model::JointKind;
using model::Leg;

using wj::test::robot;

// A jump the task's planner finds with the defaults (seed 1, no polish).
Eigen::VectorXd plannedU(const Scenario& sc) {
  const JumpPlanner planner(robot(), PlannerSettings{});
  PlanOptions o;
  o.seed = 1;
  o.threads = 1;
  o.polish = false;
  return planner.plan(sc.task, sc.initial, o).u;
}

// The hind KFE reference of `u`'s plan at `fraction` of its flight's schedule (the ballistic
// CoM's time down to the standing height; the touchdown t3, the first wheel down, comes before
// it: docs/planner.md, "Touchdown"), at t3 at the latest.
double flightSchedule(const JumpModel& m, const JumpPlan& plan) {
  const PlanarState& to = plan.predicted.takeoff.state;
  const double g = m.settings().gravity;
  const double z_td = m.constants().landing_surface + m.landingHeight();
  return (to.vz + std::sqrt(to.vz * to.vz + 2 * g * (to.z - z_td))) / g;
}

double hindKneeAt(const JumpModel& m, const Eigen::VectorXd& u, double fraction) {
  const JumpPlan plan = m.buildPlan(u);
  const double t = std::min(plan.t2 + fraction * flightSchedule(m, plan), plan.t3);
  const int k = static_cast<int>(std::lround(t / plan.dt));
  return plan.q(k, model::jointIndex(Leg::LH, JointKind::KFE));
}

// A wall jump's legs hold the tuck until wall_extend_start_fraction; a platform's landing and a
// jump without an obstacle keep extend_start_fraction, so their evaluations do not move at all.
TEST(WallExtension, MovesOnlyTheFlightOfAJumpOverAWall) {
  const JumpPlanner defaults(robot(), PlannerSettings{});
  for (const char* task : {"forward", "platform", "vertical"}) {
    SCOPED_TRACE(task);
    const bool wall = std::string(task) == "forward";
    const Scenario sc = makePreset(defaults, task);
    const Eigen::VectorXd u = plannedU(sc);
    PlannerSettings late;
    late.wall_extend_start_fraction = 0.7;
    const JumpModel m0(robot(), PlannerSettings{}, sc.task, sc.initial);
    const JumpModel m1(robot(), late, sc.task, sc.initial);
    Evaluation e0, e1;
    m0.evaluate(u, e0);
    m1.evaluate(u, e1);
    ASSERT_TRUE(e0.valid && e1.valid);
    // At 65 % of the flight the default legs are extending; a wall's are still tucked.
    const double k0 = hindKneeAt(m0, u, 0.65), k1 = hindKneeAt(m1, u, 0.65);
    EXPECT_GT(k0, late.tuck_kfe_rad + 0.1);
    if (wall) {
      EXPECT_NEAR(k1, late.tuck_kfe_rad, 1e-9);
      EXPECT_NE(e1.predicted.touchdown.state.pitch, e0.predicted.touchdown.state.pitch);
    } else {
      EXPECT_EQ(k1, k0);
      EXPECT_EQ(e1.cost, e0.cost);
      EXPECT_EQ(e1.predicted.touchdown.state.pitch, e0.predicted.touchdown.state.pitch);
    }
    // Every task's legs are in the landing posture after extend_end_fraction (0.9), if the
    // touchdown comes after it: the platform's first wheel is down before (its CoM falls slowly),
    // with the hind knee still 0.04 rad from the landing posture.
    const JumpPlan plan1 = m1.buildPlan(u);
    if (plan1.t3 >= plan1.t2 + late.extend_end_fraction * flightSchedule(m1, plan1))
      EXPECT_NEAR(hindKneeAt(m1, u, 0.95), late.landing_kfe_rad, 1e-9);
    else
      EXPECT_EQ(task, std::string("platform"));
  }
}

TEST(WallExtension, SettingIsReadAndRangeChecked) {
  const PlannerSettings s =
      PlannerSettings::fromYamlString("postures: {wall_extend_start_fraction: 0.6}\n");
  EXPECT_DOUBLE_EQ(s.wall_extend_start_fraction, 0.6);
  EXPECT_DOUBLE_EQ(PlannerSettings{}.wall_extend_start_fraction, 0.55);
  // Not before the tuck's end (0.25), not after the extension's end (0.9).
  for (const char* bad : {"0.2", "0.9", "1.2"}) {
    SCOPED_TRACE(bad);
    try {
      (void)PlannerSettings::fromYamlString(std::string("postures: {wall_extend_start_fraction: ") +
                                            bad + "}\n");
      ADD_FAILURE() << "accepted";
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find("postures.wall_extend_start_fraction"),
                std::string::npos)
          << e.what();
    }
  }
}

// The robot client's service settings (config/planner_settings.yaml): the forward preset's
// plans meet the target's touchdown pitch (0.3 rad; with the extension from 55 % of the flight
// the polish could not, and the plans landed 0.33-0.39 rad) and keep the 5 cm margin.
TEST(WallExtension, ServiceSettingsLandTheForwardJumpAtTheTargetPitch) {
  const PlannerSettings s = PlannerSettings::fromYaml(WJ_CONFIG_DIR "/planner_settings.yaml");
  EXPECT_DOUBLE_EQ(s.wall_extend_start_fraction, 0.65);
  const JumpPlanner planner(robot(), s);
  const Scenario sc = makePreset(planner, "forward");
  PlanOptions o;
  o.seed = 3;
  o.threads = 1;
  const PlannerResult r = planner.plan(sc.task, sc.initial, o);
  ASSERT_TRUE(r.evaluation.feasible) << r.summary;
  EXPECT_NEAR(r.evaluation.predicted.touchdown.state.pitch - sc.initial.pitch,
              sc.task.target.pitch_change, 0.005);
  EXPECT_GE(r.evaluation.predicted.min_obstacle_clearance, 0.05);
}

}  // namespace
}  // namespace wj::planner
