// The service's lift-off correction (verification.liftoff_correction_rounds; docs/planner.md,
// "The lift-off correction"), through the PlanningCore with the Simbody verifier: a miss plans
// again with the flight started from the lift-off its verification measured and answers the
// corrected plan; the hit that follows rebuilds the same plan from the cache entry's
// correction; a backflip is never corrected; with the rounds at 0 nothing is.
#include <gtest/gtest.h>

#include <future>
#include <memory>
#include <string>

#include "planner/liftoff_correction.h"
#include "server/planning_core.h"
#include "server_test_util.h"

namespace wj::server {
namespace {

ServerConfig configWithRounds(int rounds) {
  ServerConfig config = test::verifyingDefaultsConfig();
  config.verification.liftoff_correction_rounds = rounds;
  return config;
}

// Forward (seed 1): the model alone leaves Simbody's lift-off momentum 0.04 kg m^2/s below the
// plan's; the corrected answer's verification measures its lift-off within the tolerances.
TEST(LiftOffCorrectionService, AMissAnswersTheCorrectedPlanAndAHitRebuildsIt) {
  if (!simVerifierAvailable()) GTEST_SKIP() << "built without the sim component";
  const ServerConfig config = configWithRounds(2);
  const model::RobotModel robot = model::RobotModel::loadDefault();
  PlanningCore core(config, robot, planner::PlannerSettings{},
                    makeSimVerifier(robot, config.verification), nullptr);
  const PlanRequest request = test::presetRequest(core, "forward", 1, "liftoff");
  const PlanOutcome miss = test::ask(core, request);
  ASSERT_FALSE(miss.error.has_value()) << miss.error->what();
  const PlanAnswer& a = miss.answer;
  EXPECT_EQ(a.source, PlanSource::CacheMiss);
  EXPECT_EQ(a.verification.status, VerificationStatus::Passed);
  EXPECT_LT(a.plan.liftoff_correction.momentum, -0.02);
  const planner::LiftOffCorrection residual = planner::liftOffResidual(
      a.plan, a.verification.simulated.takeoff, planner::PlannerSettings{}.gravity);
  EXPECT_LE(planner::liftOffResidualRatio(a.plan, residual, planner::kLiftOffVelocityTolerance,
                                          planner::kLiftOffMomentumTolerance),
            1.0);
  EXPECT_GE(a.verification.candidates_verified, 2);

  const PlanOutcome hit = test::ask(core, request);
  ASSERT_FALSE(hit.error.has_value());
  EXPECT_EQ(hit.answer.source, PlanSource::CacheHit);
  EXPECT_EQ(hit.answer.plan.liftoff_correction.momentum, a.plan.liftoff_correction.momentum);
  EXPECT_EQ(hit.answer.plan.predicted.touchdown.state.pitch,
            a.plan.predicted.touchdown.state.pitch);
  ASSERT_EQ(hit.answer.plan.numSamples(), a.plan.numSamples());
  EXPECT_EQ(hit.answer.plan.q, a.plan.q);
}

TEST(LiftOffCorrectionService, NeitherABackflipNorAServiceWithoutRoundsIsCorrected) {
  if (!simVerifierAvailable()) GTEST_SKIP() << "built without the sim component";
  const model::RobotModel robot = model::RobotModel::loadDefault();
  for (const int rounds : {0, 2}) {
    const ServerConfig config = configWithRounds(rounds);
    PlanningCore core(config, robot, planner::PlannerSettings{},
                      makeSimVerifier(robot, config.verification), nullptr);
    for (const char* name : {"forward", "backflip"}) {
      if (rounds == 2 && std::string(name) == "forward") continue;  // the test above
      SCOPED_TRACE(std::string(name) + " rounds " + std::to_string(rounds));
      const PlanOutcome miss = test::ask(core, test::presetRequest(core, name, 1, "liftoff"));
      ASSERT_FALSE(miss.error.has_value()) << miss.error->what();
      EXPECT_TRUE(miss.answer.plan.liftoff_correction.isZero());
    }
  }
}

}  // namespace
}  // namespace wj::server
