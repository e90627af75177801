// The SQP solver on the centroidal problem: convergence, constraint satisfaction, the
// published policy and its feedback gains, warm starts and allocation-free policy copies.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <thread>

#include "nmpc/locomotion_controller.h"
#include "nmpc/reference.h"
#include "nmpc/sqp_solver.h"
#include "nmpc_test_util.h"

// Counts heap allocations of the whole process by interposing glibc's malloc, to check that
// copying and evaluating a policy allocates nothing. Off under the sanitizers.
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#define WJ_COUNT_MALLOC 1
extern "C" void* __libc_malloc(std::size_t size);
namespace {
std::atomic<std::int64_t> g_malloc_calls{0};
}
extern "C" void* malloc(std::size_t size) noexcept {
  g_malloc_calls.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}
#endif

namespace wj::nmpc {
namespace {

class SqpTest : public ::testing::Test {
 protected:
  SqpTest()
      : model_(test::loadRobot()),
        generator_(model_, ReferenceSettings{}),
        standing_(standingState(0.0)) {}

  // Standing still at the reference height over flat ground, at x = `x_m`.
  State standingState(double x_m) const {
    State x = State::Zero();
    x.segment<kNumLegJoints>(state_index::kJoints) = model_.nominalJoints();
    x[state_index::kPos] = x_m;
    x[state_index::kPos + 2] = ReferenceSettings{}.base_height_m + model_.comOffset().z();
    return x;
  }

  Targets makeTargets(double t0, const State& x0, const SpeedCommand& command, Gait gait) const {
    Targets targets;
    targets.gait.setGait(0.0, gait);
    generator_.update(t0, x0, command, targets.terrain, 1.0, targets.reference);
    return targets;
  }

  SqpSolver makeSolver(int iterations, double horizon_s = 1.0) const {
    SqpSettings s;
    s.max_iterations = iterations;
    s.horizon_s = horizon_s;
    return SqpSolver(s, CentroidalOcp(model_, ProblemSettings{}));
  }

  CentroidalModel model_;
  ReferenceGenerator generator_;
  State standing_;
};

TEST_F(SqpTest, HorizonAndGridFollowTheSettings) {
  const SqpSolver solver = makeSolver(1);
  EXPECT_EQ(solver.numIntervals(), 67);  // 1.0 s / 0.015 s, rounded up
  EXPECT_NEAR(solver.dt() * solver.numIntervals(), 1.0, 1e-12);
}

TEST_F(SqpTest, StandingConvergesToSharedWeightAndNoMotion) {
  SqpSolver solver = makeSolver(50);
  const Targets targets = makeTargets(0.0, standing_, {}, Gait::Roll);
  const SqpStatus status = solver.solve(0.0, standing_, targets);
  EXPECT_EQ(status, SqpStatus::Converged) << toString(status);
  EXPECT_LT(solver.stats().violation, 1e-6);
  const double mg = model_.mass() * model_.settings().gravity_m_s2;
  const Input& u0 = solver.inputs()[10];
  double fz = 0.0;
  for (int leg = 0; leg < kNumLegs; ++leg) fz += u0[input_index::force(leg) + 2];
  EXPECT_NEAR(fz, mg, 0.01 * mg);
  // The barriers bias the optimum slightly away from the reference (interior-point bias):
  // the legs creep by less than a degree, the body by less than a millimetre.
  for (int k = 0; k < solver.numIntervals(); ++k)
    EXPECT_LT(solver.inputs()[k].tail<kNumLegJoints>().cwiseAbs().maxCoeff(), 0.1);
  EXPECT_LT((solver.states().back() - standing_).segment<6>(0).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_LT((solver.states().back() - standing_).tail<kNumLegJoints>().cwiseAbs().maxCoeff(), 0.01);
}

TEST_F(SqpTest, DisturbedTrotConvergesAndMeetsEveryEquality) {
  SqpSolver solver = makeSolver(100);
  State x0 = standing_;
  x0[state_index::kPos + 2] -= 0.03;
  x0[state_index::kTheta + 1] = 0.1;
  x0[state_index::kVel + 1] = 0.3;
  x0[state_index::kOmega] = 0.5;
  SpeedCommand command;
  command.v_start_m_s = command.v_target_m_s = 0.5;
  const Targets targets = makeTargets(0.0, x0, command, Gait::Trot);
  const SqpStatus status = solver.solve(0.0, x0, targets);
  EXPECT_EQ(status, SqpStatus::Converged) << toString(status) << " " << solver.stats().iterations;
  EXPECT_LT(solver.stats().violation, 1e-6);
  // Swing wheels carry no force and follow the spline; stance wheels roll without slip.
  const CentroidalOcp& ocp = solver.problem();
  for (int k = 0; k < solver.numIntervals(); ++k) {
    const NodeTargets& node = solver.nodeTargets()[k];
    ModelData data;
    ocp.model().updateData(solver.states()[k], data);
    for (int leg = 0; leg < kNumLegs; ++leg) {
      const Eigen::Vector3d v =
          ocp.model().calcWheelVelocity(leg, solver.states()[k], solver.inputs()[k], data);
      if (node.contact[leg]) {
        EXPECT_NEAR(v.z(), 0.0, 1e-6);
        EXPECT_GE(ocp.calcFrictionMargin(solver.inputs()[k].segment<3>(input_index::force(leg)),
                                         node.normal),
                  0.0);
      } else {
        EXPECT_LT(solver.inputs()[k].segment<3>(input_index::force(leg)).norm(), 1e-6);
        // Paper Eq. 7 with the height feedback: n.v = v_swing + k (height error).
        EXPECT_NEAR(v.z(),
                    node.swing_normal_velocity[leg] +
                        ocp.settings().swing_position_gain *
                            ocp.calcSwingHeightError(node, leg, solver.states()[k], data),
                    1e-6);
      }
    }
  }
}

TEST_F(SqpTest, RealTimeIterationsReachTheConvergedSolution) {
  SqpSolver full = makeSolver(100), rti = makeSolver(1);
  State x0 = standing_;
  x0[state_index::kVel] = 0.4;
  SpeedCommand command;
  command.v_start_m_s = command.v_target_m_s = 1.0;
  const Targets targets = makeTargets(0.0, x0, command, Gait::Roll);
  ASSERT_EQ(full.solve(0.0, x0, targets), SqpStatus::Converged);
  for (int i = 0; i < 40; ++i) rti.solve(0.0, x0, targets);  // same time: shift is the identity
  double worst = 0.0;
  for (int k = 0; k < full.numIntervals(); ++k)
    worst = std::max(worst, (full.inputs()[k] - rti.inputs()[k]).cwiseAbs().maxCoeff());
  EXPECT_LT(worst, 1e-4);
}

TEST_F(SqpTest, FeedbackGainPredictsTheSolutionSensitivity) {
  // K_0 dx0 against the change of the converged first input under a small change of x0. The
  // Gauss-Newton Hessian omits the constraints' curvature, so agreement is to first order in
  // the multipliers only: a loose tolerance.
  SqpSolver solver = makeSolver(200);
  const State x0 = standing_;
  const Targets targets = makeTargets(0.0, x0, {}, Gait::Roll);
  ASSERT_EQ(solver.solve(0.0, x0, targets), SqpStatus::Converged);
  solver.solve(0.0, x0, targets);  // one more: the gains of the converged point
  const Input u_base = solver.inputs()[0];
  const InputStateMatrix K = solver.policy().gainAt(0);
  std::mt19937 rng(5);
  std::normal_distribution<double> nd(0.0, 1.0);
  State dx = State::Zero();
  for (int i = 0; i < 12; ++i) dx[i] = 1e-4 * nd(rng);
  SqpSolver perturbed = makeSolver(200);
  ASSERT_EQ(perturbed.solve(0.0, x0 + dx, targets), SqpStatus::Converged);
  const Input du = perturbed.inputs()[0] - u_base;
  EXPECT_LT((K * dx - du).norm(), 0.2 * du.norm()) << (K * dx).transpose() << "\n"
                                                   << du.transpose();
}

TEST_F(SqpTest, PolicyInterpolatesStatesHoldsInputsAndAppliesFeedback) {
  SqpSolver solver = makeSolver(5);
  const Targets targets = makeTargets(0.3, standing_, {}, Gait::Trot);
  solver.solve(0.3, standing_, targets);
  const Policy& p = solver.policy();
  EXPECT_DOUBLE_EQ(p.startTime(), 0.3);
  EXPECT_EQ(p.numIntervals(), solver.numIntervals());
  State x;
  Input u;
  const double t = 0.3 + 2.5 * solver.dt();
  p.calcState(t, x);
  EXPECT_LT((x - 0.5 * (solver.states()[2] + solver.states()[3])).norm(), 1e-12);
  p.calcFeedforward(t, u);
  EXPECT_LT((u - solver.inputs()[2]).norm(), 1e-12);
  Input u_fb;
  State x_off = x;
  x_off[state_index::kPos + 2] += 0.01;
  p.calcInput(t, x_off, u_fb);
  EXPECT_LT((u_fb - u - 0.01 * p.gainAt(2).col(state_index::kPos + 2)).norm(), 1e-9);
  // Beyond the horizon: clamped.
  p.calcState(100.0, x);
  EXPECT_LT((x - solver.states().back()).norm(), 1e-12);
}

TEST_F(SqpTest, PolicyCopyAndEvaluationDoNotAllocate) {
  SqpSolver solver = makeSolver(1);
  const Targets targets = makeTargets(0.0, standing_, {}, Gait::Roll);
  solver.solve(0.0, standing_, targets);
  Policy buffer(solver.numIntervals());
  State x = standing_;
  Input u;
#ifdef WJ_COUNT_MALLOC
  const std::int64_t before = g_malloc_calls.load();
#endif
  for (int i = 0; i < 100; ++i) {
    buffer.copyFrom(solver.policy());
    buffer.calcInput(0.001 * i, x, u);
  }
#ifdef WJ_COUNT_MALLOC
  EXPECT_EQ(g_malloc_calls.load() - before, 0);
#endif
  EXPECT_THROW(Policy(3).copyFrom(solver.policy()), std::length_error);
}

TEST_F(SqpTest, ControlPeriodOfTheLocomotionControllerDoesNotAllocate) {
  LocomotionController c(test::loadRobot(), LocomotionSettings{});
  c.setGait(0.0, Gait::Trot);
  c.updateMpc(0.0, standing_);
  model::SensorData sensors;
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int j = 0; j < kLegDofs; ++j)
      sensors.joints[robotJointIndex(leg, j)].q = model_.nominalJoints()[kLegDofs * leg + j];
  model::JointCommands commands{};
#ifdef WJ_COUNT_MALLOC
  const std::int64_t before = g_malloc_calls.load();
#endif
  for (int k = 0; k < 100; ++k) c.calcCommands(0.001 * k, standing_, sensors, commands);
#ifdef WJ_COUNT_MALLOC
  EXPECT_EQ(g_malloc_calls.load() - before, 0);
#endif
  // A new policy is picked up without allocating either.
  c.updateMpc(0.01, standing_);
#ifdef WJ_COUNT_MALLOC
  const std::int64_t after_mpc = g_malloc_calls.load();
#endif
  c.calcCommands(0.011, standing_, sensors, commands);
#ifdef WJ_COUNT_MALLOC
  EXPECT_EQ(g_malloc_calls.load() - after_mpc, 0);
#endif
  EXPECT_DOUBLE_EQ(c.policy().startTime(), 0.01);
  for (const model::JointCommand& cmd : commands) EXPECT_TRUE(std::isfinite(cmd.tau_ff));
}

TEST(PolicyExchange, HandsOverTheLatestPolicyWholeAcrossThreads) {
  // Single thread: nothing before the first publish, then the latest only.
  PolicyExchange exchange(4);
  Policy a(4), out(4);
  EXPECT_FALSE(exchange.fetch(out));
  for (int v = 1; v <= 3; ++v) {
    a.reset(0.1 * v, 0.01, 4);
    exchange.publish(a);
  }
  ASSERT_TRUE(exchange.fetch(out));
  EXPECT_DOUBLE_EQ(out.startTime(), 0.3);
  EXPECT_FALSE(exchange.fetch(out));
  // Two threads: every fetched policy is one published whole (all nodes carry its stamp).
  std::atomic<bool> done{false};
  std::thread producer([&] {
    Policy p(4);
    for (int v = 0; v < 20000; ++v) {
      p.reset(static_cast<double>(v), 0.01, 4);
      for (int k = 0; k <= 4; ++k) p.stateAt(k).setConstant(v);
      for (int k = 0; k < 4; ++k) p.inputAt(k).setConstant(v);
      exchange.publish(p);
    }
    done = true;
  });
  int fetched = 0, torn = 0;
  double last = -1.0;
  for (;;) {
    const bool finished = done.load();
    if (!exchange.fetch(out)) {
      if (finished) break;
      continue;
    }
    ++fetched;
    const double v = out.startTime();
    if (v < last) ++torn;  // never older than what was fetched before
    last = v;
    for (int k = 0; k <= 4; ++k)
      if ((out.stateAt(k).array() != v).any()) ++torn;
    for (int k = 0; k < 4; ++k)
      if ((out.inputAt(k).array() != v).any()) ++torn;
  }
  producer.join();
  EXPECT_GT(fetched, 0);
  EXPECT_EQ(torn, 0);
}

TEST_F(SqpTest, IdenticalRunsGiveIdenticalSolutions) {
  SqpSolver a = makeSolver(3), b = makeSolver(3);
  const Targets targets = makeTargets(0.0, standing_, {}, Gait::Trot);
  for (int i = 0; i < 3; ++i) {
    a.solve(0.01 * i, standing_, targets);
    b.solve(0.01 * i, standing_, targets);
  }
  for (int k = 0; k < a.numIntervals(); ++k) EXPECT_EQ(a.inputs()[k], b.inputs()[k]);
}

}  // namespace
}  // namespace wj::nmpc
