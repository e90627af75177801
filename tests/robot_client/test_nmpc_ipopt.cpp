// The SQP's converged solution against Ipopt on the same nonlinear program: rolling with a
// disturbed start over the full 1 s horizon, and trotting over a short horizon in which a
// diagonal pair swings down to touchdown (swing constraints active). The Gauss-Newton SQP
// converges linearly and only where the constraints' curvature weighted by their multipliers is
// small against the cost Hessian; lift-offs of fast swings are outside that (docs/nmpc.md).
#include <gtest/gtest.h>

#include <algorithm>

#include "nmpc/ipopt_reference.h"
#include "nmpc/reference.h"
#include "nmpc/sqp_solver.h"
#include "nmpc_test_util.h"

namespace wj::nmpc {
namespace {

struct Case {
  const char* name;
  Gait gait;
  double speed;
  double horizon_s;
};

class IpoptComparison : public ::testing::TestWithParam<Case> {};

TEST_P(IpoptComparison, SqpConvergesToTheIpoptSolution) {
  const Case c = GetParam();
  const CentroidalModel model(test::loadRobot());
  SqpSettings sqp;
  sqp.horizon_s = c.horizon_s;
  sqp.max_iterations = 300;
  sqp.step_tolerance = 1e-9;
  sqp.constraint_tolerance = 1e-10;
  const CentroidalOcp ocp(model, ProblemSettings{});
  GaitSettings gait_settings;
  gait_settings.trot_period_s = 0.4;  // LF+RH swing through the horizon, touch down at its end
  Targets targets;
  targets.gait = GaitSchedule(gait_settings, Gait::Roll);
  targets.gait.setGait(-0.05, c.gait);
  State x0 = State::Zero();
  x0.segment<kNumLegJoints>(state_index::kJoints) = model.nominalJoints();
  x0[state_index::kPos + 2] = 0.35 + model.comOffset().z();
  x0[state_index::kTheta + 1] = 0.03;
  x0[state_index::kVel] = c.speed;
  x0[state_index::kOmega + 1] = -0.2;
  SpeedCommand command;
  command.v_start_m_s = c.speed;
  command.v_target_m_s = c.speed + 0.5;
  ReferenceGenerator(model, ReferenceSettings{})
      .update(0.0, x0, command, targets.terrain, sqp.horizon_s, targets.reference);

  SqpSolver solver(sqp, ocp);
  const SqpStatus status = solver.solve(0.0, x0, targets);
  ASSERT_EQ(status, SqpStatus::Converged)
      << toString(status) << " after " << solver.stats().iterations;
  const IpoptReferenceResult ip = solveWithIpopt(sqp, ocp, 0.0, x0, targets);
  ASSERT_TRUE(ip.solved) << ip.status;
  EXPECT_LT(ip.violation, 1e-8);
  EXPECT_NEAR(ip.cost, solver.stats().cost, 1e-8 * std::max(1.0, std::abs(ip.cost)));
  double dx = 0.0, df = 0.0, dqd = 0.0;
  for (int k = 0; k <= solver.numIntervals(); ++k)
    dx = std::max(dx, (ip.x[k] - solver.states()[k]).cwiseAbs().maxCoeff());
  for (int k = 0; k < solver.numIntervals(); ++k) {
    df = std::max(df, (ip.u[k] - solver.inputs()[k]).head<12>().cwiseAbs().maxCoeff());
    dqd = std::max(dqd, (ip.u[k] - solver.inputs()[k]).tail<12>().cwiseAbs().maxCoeff());
  }
  EXPECT_LT(dx, 1e-5) << "states";
  EXPECT_LT(df, 1e-3) << "forces [N]";
  EXPECT_LT(dqd, 1e-4) << "joint velocities [rad/s]";
  RecordProperty("ipopt_iterations", ip.iterations);
  RecordProperty("sqp_iterations", solver.stats().iterations);
}

INSTANTIATE_TEST_SUITE_P(Gaits, IpoptComparison,
                         ::testing::Values(Case{"roll", Gait::Roll, 1.0, 1.0},
                                           Case{"trot", Gait::Trot, 0.5, 0.15}),
                         [](const ::testing::TestParamInfo<Case>& param_info) {
                           return std::string(param_info.param.name);
                         });

}  // namespace
}  // namespace wj::nmpc
