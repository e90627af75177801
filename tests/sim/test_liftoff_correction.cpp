// The lift-off correction (sim::planWithLiftOffCorrection; docs/planner.md, "The lift-off
// correction"): the residual's arithmetic, the settings' checks, and the forward preset planned
// with it against Simbody.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "planner/presets.h"
#include "sim/liftoff_correction.h"

namespace wj::sim {
namespace {

// Simbody's lift-off less the plan's flight at Simbody's instant: the plan's vz falls
// ballistically from its t2 to Simbody's lift-off; vx and the momentum are the flight's.
TEST(LiftOffCorrection, ResidualIsSimbodysLiftOffLessThePlansFlight) {
  planner::JumpPlan plan;
  plan.predicted.takeoff.t = 0.2;
  plan.predicted.takeoff.state.vx = 3.0;
  plan.predicted.takeoff.state.vz = 2.0;
  plan.predicted.takeoff.momentum = 0.5;
  VerificationReport report;
  report.took_off = true;
  report.measured.takeoff.t = 0.205;
  report.measured.takeoff.state.vx = 2.99;
  report.measured.takeoff.state.vz = 1.94;
  report.measured.takeoff.momentum = 0.47;
  const planner::LiftOffCorrection r = measureLiftOffResidual(plan, report, 9.81);
  EXPECT_NEAR(r.vx, -0.01, 1e-12);
  EXPECT_NEAR(r.vz, 1.94 - (2.0 - 9.81 * 0.005), 1e-12);
  EXPECT_NEAR(r.momentum, -0.03, 1e-12);
}

TEST(LiftOffCorrection, SettingsAreCheckedByName) {
  const auto refused = [](LiftOffCorrectionSettings s, const std::string& field) {
    try {
      s.validate();
      ADD_FAILURE() << field << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  LiftOffCorrectionSettings s;
  s.max_rounds = 11;
  refused(s, "liftoff_correction.max_rounds");
  s = {};
  s.velocity_tolerance = 0.0;
  refused(s, "liftoff_correction.velocity_tolerance");
  s = {};
  s.momentum_tolerance = std::nan("");
  refused(s, "liftoff_correction.momentum_tolerance");
  EXPECT_NO_THROW(LiftOffCorrectionSettings{}.validate());
}

// The forward preset (planner seed 1): the model alone leaves Simbody's lift-off momentum 0.04
// kg m^2/s (4 x the tolerance) more nose-down than the plan's; corrected, the chosen plan's
// lift-off is Simbody's within the tolerances, it verifies, and its correction is the sum of
// the residuals before it (the fixed-point iteration). Simbody's flight keeps the momentum
// the residual is measured on (the wheels spin free).
TEST(LiftOffCorrection, ForwardPresetMeetsTheTolerances) {
  const auto robot = model::RobotModel::loadDefault();
  const planner::JumpPlanner planner(robot, planner::PlannerSettings{});
  const planner::Scenario sc = planner::makePreset(planner, "forward");
  planner::PlanOptions options;
  options.seed = 1;
  options.threads = 2;
  const Verifier verifier(robot, VerifierSettings{});
  const Scenario scenario = scenarioForTask(sc.task);
  int verifications = 0;
  const VerifyPlan verify = [&](const planner::JumpPlan& plan) {
    ++verifications;
    return verifier.verify(plan, scenario);
  };
  const CorrectedPlan c =
      planWithLiftOffCorrection(planner, verify, sc.task, sc.initial, options, {});
  ASSERT_GE(c.rounds.size(), 2u);
  EXPECT_EQ(verifications, static_cast<int>(c.rounds.size()));
  EXPECT_GT(c.rounds[0].residual_ratio, 2.0);
  EXPECT_LT(c.rounds[0].residual.momentum, -0.02);
  const CorrectionRound& chosen = c.rounds[c.chosen];
  EXPECT_LE(chosen.residual_ratio, 1.0);
  EXPECT_TRUE(chosen.passed);
  EXPECT_TRUE(chosen.feasible);
  EXPECT_TRUE(c.report.passed);
  planner::LiftOffCorrection sum;
  for (int k = 0; k < c.chosen; ++k) {
    sum.vx += c.rounds[k].residual.vx;
    sum.vz += c.rounds[k].residual.vz;
    sum.momentum += c.rounds[k].residual.momentum;
  }
  EXPECT_NEAR(chosen.correction.momentum, sum.momentum, 1e-12);
  EXPECT_NEAR(chosen.correction.vz, sum.vz, 1e-12);
  EXPECT_EQ(c.result.plan.liftoff_correction.momentum, chosen.correction.momentum);
  const planner::LiftOffCorrection r =
      measureLiftOffResidual(c.result.plan, c.report, planner.settings().gravity);
  EXPECT_EQ(r.momentum, chosen.residual.momentum);  // the report is the chosen plan's
  EXPECT_NEAR(c.report.measured.touchdown.momentum, c.report.measured.takeoff.momentum, 0.01);

  // No rounds: the planner's own plan, verified once.
  LiftOffCorrectionSettings none;
  none.max_rounds = 0;
  verifications = 0;
  const CorrectedPlan alone =
      planWithLiftOffCorrection(planner, verify, sc.task, sc.initial, options, none);
  EXPECT_EQ(verifications, 1);
  EXPECT_EQ(alone.rounds.size(), 1u);
  EXPECT_TRUE(alone.result.plan.liftoff_correction.isZero());
  EXPECT_EQ(alone.result.u, planner.plan(sc.task, sc.initial, options).u);
}

}  // namespace
}  // namespace wj::sim
