// The optimal control problem: gait schedule and swing spline, relaxed barrier, cost and
// constraint derivatives against finite differences.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cmath>
#include <random>

#include "nmpc/gait.h"
#include "nmpc/problem.h"
#include "nmpc/relaxed_barrier.h"
#include "nmpc_test_util.h"

namespace wj::nmpc {
namespace {

using test::numericJacobian;
using test::relativeError;

TEST(Gait, RollKeepsEveryWheelDownAndTrotAlternatesDiagonals) {
  GaitSettings s;
  s.trot_period_s = 0.4;
  GaitSchedule gait(s, Gait::Roll);
  gait.setGait(1.0, Gait::Trot);
  gait.setGait(3.0, Gait::Roll);
  for (const double t : {-5.0, 0.0, 0.99, 3.0, 10.0}) {
    const ContactFlags c = gait.contactFlags(t);
    EXPECT_TRUE(c[0] && c[1] && c[2] && c[3]) << t;
  }
  const ContactFlags a = gait.contactFlags(1.05), b = gait.contactFlags(1.25);
  EXPECT_FALSE(a[0]);
  EXPECT_TRUE(a[1]);
  EXPECT_TRUE(a[2]);
  EXPECT_FALSE(a[3]);
  EXPECT_TRUE(b[0]);
  EXPECT_FALSE(b[1]);
  EXPECT_FALSE(b[2]);
  EXPECT_TRUE(b[3]);
  EXPECT_EQ(gait.gaitAt(2.0), Gait::Trot);
  EXPECT_EQ(gait.gaitAt(3.5), Gait::Roll);
}

TEST(Gait, SwingVelocityIsTheDerivativeOfTheSwingBumpAndReturnsToTheGround) {
  GaitSettings s;
  s.trot_period_s = 0.5;
  s.swing_height_m = 0.12;
  GaitSchedule gait(s, Gait::Roll);
  gait.setGait(0.0, Gait::Trot);
  const double h = 1e-6;
  double integral = 0.0, peak = 0.0;
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    const double t = 0.25 * (i + 0.5) / n;
    integral += gait.swingNormalVelocity(0, t) * 0.25 / n;
    peak = std::max(peak, gait.swingHeight(0, t));
    const double num = (gait.swingHeight(0, t + h) - gait.swingHeight(0, t - h)) / (2 * h);
    EXPECT_NEAR(gait.swingNormalVelocity(0, t), num, 1e-6);
  }
  EXPECT_NEAR(integral, 0.0, 1e-9);
  EXPECT_NEAR(peak, 0.12, 1e-5);
  EXPECT_EQ(gait.swingNormalVelocity(1, 0.1), 0.0);  // RF is in stance in the first half
}

TEST(RelaxedBarrier, IsTwiceContinuouslyDifferentiable) {
  const BarrierSettings s{0.1, 2.0};
  const double eps = 1e-7;
  const BarrierValue lo = evalRelaxedBarrier(s, s.delta - eps);
  const BarrierValue hi = evalRelaxedBarrier(s, s.delta + eps);
  EXPECT_NEAR(lo.value, hi.value, 1e-6);
  EXPECT_NEAR(lo.d1, hi.d1, 1e-6);
  EXPECT_NEAR(lo.d2, hi.d2, 1e-6);
  for (const double h : {-3.0, 0.5, 1.9, 2.5, 10.0}) {
    const double d = 1e-5;
    const BarrierValue b = evalRelaxedBarrier(s, h);
    EXPECT_NEAR(b.d1,
                (evalRelaxedBarrier(s, h + d).value - evalRelaxedBarrier(s, h - d).value) / (2 * d),
                1e-7);
    EXPECT_NEAR(b.d2, (evalRelaxedBarrier(s, h + d).d1 - evalRelaxedBarrier(s, h - d).d1) / (2 * d),
                1e-6);
  }
}

class ProblemTest : public ::testing::Test {
 protected:
  ProblemTest() : ocp_(CentroidalModel(test::loadRobot()), ProblemSettings{}) {
    targets_.gait.setGait(0.0, Gait::Trot);
    targets_.terrain.normal = Eigen::Vector3d(0.1, -0.05, 1.0).normalized();
    State ref = State::Zero();
    ref.segment<kNumLegJoints>(state_index::kJoints) = ocp_.model().nominalJoints();
    ref[state_index::kPos + 2] = 0.3;
    targets_.reference.times = {0.0, 1.0};
    targets_.reference.states = {ref, ref};
  }
  CentroidalOcp ocp_;
  Targets targets_;
  std::mt19937 rng_{7};
};

TEST_F(ProblemTest, StageCostQuadraticMatchesFiniteDifferences) {
  for (const double t : {0.1, 0.3}) {  // LF/RH swing, then RF/LH swing
    const NodeTargets node = ocp_.calcNodeTargets(targets_, t);
    State x = test::randomState(ocp_.model(), rng_);
    // Push one joint into the relaxed part of its limit barrier, one force near the cone.
    x[state_index::kJoints + 2] = ocp_.model().jointUpper()[2] - 0.01;
    Input u = test::randomInput(ocp_.model(), rng_);
    u.segment<3>(input_index::force(1)) =
        Eigen::Vector3d(0.55, 0.1, 1.0) * 50.0 + node.normal * 1.0;
    CostQuadratic q;
    ocp_.calcStageCostQuadratic(node, x, u, q);
    EXPECT_NEAR(q.value, ocp_.calcStageCost(node, x, u), 1e-9);
    const auto lx = [&](const Eigen::VectorXd& v) {
      return Eigen::VectorXd::Constant(1, ocp_.calcStageCost(node, State(v), u));
    };
    const auto lu = [&](const Eigen::VectorXd& v) {
      return Eigen::VectorXd::Constant(1, ocp_.calcStageCost(node, x, Input(v)));
    };
    EXPECT_LT(relativeError(q.dx.transpose(), numericJacobian(lx, x)), 1e-6);
    EXPECT_LT(relativeError(q.du.transpose(), numericJacobian(lu, u)), 1e-6);
    // The Hessian is exact here (tracking terms, barriers of linear and of the cone constraint).
    const auto gx = [&](const Eigen::VectorXd& v) {
      CostQuadratic c;
      ocp_.calcStageCostQuadratic(node, State(v), u, c);
      return Eigen::VectorXd(c.dx);
    };
    const auto gu = [&](const Eigen::VectorXd& v) {
      CostQuadratic c;
      ocp_.calcStageCostQuadratic(node, x, Input(v), c);
      return Eigen::VectorXd(c.du);
    };
    EXPECT_LT(relativeError(q.dxx, numericJacobian(gx, x)), 1e-6);
    EXPECT_LT(relativeError(q.duu, numericJacobian(gu, u)), 1e-6);
    // Positive semidefinite.
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<InputMatrix>(q.duu).eigenvalues().minCoeff(), -1e-12);
  }
}

TEST_F(ProblemTest, TerminalCostQuadraticMatchesFiniteDifferences) {
  const NodeTargets node = ocp_.calcNodeTargets(targets_, 1.0);
  const State x = test::randomState(ocp_.model(), rng_);
  CostQuadratic q;
  ocp_.calcTerminalCostQuadratic(node, x, q);
  EXPECT_NEAR(q.value, ocp_.calcTerminalCost(node, x), 1e-9);
  const auto lx = [&](const Eigen::VectorXd& v) {
    return Eigen::VectorXd::Constant(1, ocp_.calcTerminalCost(node, State(v)));
  };
  EXPECT_LT(relativeError(q.dx.transpose(), numericJacobian(lx, x)), 1e-6);
}

TEST_F(ProblemTest, EqualityJacobiansMatchFiniteDifferences) {
  for (const double t : {0.1, 0.3, 5.0}) {
    Targets targets = targets_;
    targets.gait.setGait(2.0, Gait::Roll);  // t = 5: all wheels down
    const NodeTargets node = ocp_.calcNodeTargets(targets, t);
    const State x = test::randomState(ocp_.model(), rng_);
    const Input u = test::randomInput(ocp_.model(), rng_);
    ModelData data;
    ocp_.model().updateData(x, data);
    EqualityLinearization lin;
    ocp_.calcEqualitiesLinear(node, x, u, data, lin);
    EXPECT_EQ(lin.g.size(), CentroidalOcp::numEqualities(node.contact));
    EqVector g;
    ocp_.calcEqualities(node, x, u, data, g);
    EXPECT_LT((g - lin.g).norm(), 1e-12);
    const auto gx = [&](const Eigen::VectorXd& v) {
      ModelData d;
      ocp_.model().updateData(State(v), d);
      EqVector out;
      ocp_.calcEqualities(node, State(v), u, d, out);
      return Eigen::VectorXd(out);
    };
    const auto gu = [&](const Eigen::VectorXd& v) {
      EqVector out;
      ocp_.calcEqualities(node, x, Input(v), data, out);
      return Eigen::VectorXd(out);
    };
    EXPECT_LT(relativeError(lin.C, numericJacobian(gx, x)), 1e-7) << t;
    EXPECT_LT(relativeError(lin.D, numericJacobian(gu, u)), 1e-8) << t;
    // Full row rank in the input: the solver can eliminate every equality.
    Eigen::FullPivLU<Eigen::MatrixXd> lu(lin.D);
    EXPECT_EQ(lu.rank(), lin.D.rows());
  }
}

TEST_F(ProblemTest, NodeTargetsShareTheWeightAmongStanceWheels) {
  const NodeTargets roll = ocp_.calcNodeTargets(targets_, -1.0);
  const NodeTargets trot = ocp_.calcNodeTargets(targets_, 0.1);
  const double mg = ocp_.model().mass() * ocp_.model().settings().gravity_m_s2;
  double sum_roll = 0.0, sum_trot = 0.0;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    sum_roll += roll.u_ref[input_index::force(leg) + 2];
    sum_trot += trot.u_ref[input_index::force(leg) + 2];
  }
  EXPECT_NEAR(sum_roll, mg, 1e-9);
  EXPECT_NEAR(sum_trot, mg, 1e-9);
  EXPECT_EQ(trot.u_ref[input_index::force(0) + 2], 0.0);  // LF swings
  EXPECT_NE(trot.swing_normal_velocity[0], 0.0);
}

TEST_F(ProblemTest, SwingSplineBlendsLiftoffAndTouchdownHeights) {
  // LF swings over [0, 0.25) with trot period 0.5: lift off at 0, land on a 0.1 m block.
  Targets targets = targets_;
  targets.swings[0][0] = SwingHeights{0.0, 0.25, 0.0, 0.1};
  targets.num_swings[0] = 1;
  const double H = targets.gait.settings().swing_height_m, h = 1e-6;
  for (double t = 0.005; t < 0.25; t += 0.01) {
    const NodeTargets node = ocp_.calcNodeTargets(targets, t);
    const double num = (ocp_.calcNodeTargets(targets, t + h).swing_height[0] -
                        ocp_.calcNodeTargets(targets, t - h).swing_height[0]) /
                       (2 * h);
    EXPECT_NEAR(node.swing_normal_velocity[0], num, 1e-6) << t;
  }
  EXPECT_NEAR(ocp_.calcNodeTargets(targets, 1e-9).swing_height[0], 0.0, 1e-9);
  EXPECT_NEAR(ocp_.calcNodeTargets(targets, 0.25 - 1e-9).swing_height[0], 0.1, 1e-6);
  EXPECT_NEAR(ocp_.calcNodeTargets(targets, 0.125).swing_height[0], 0.05 + H, 1e-9);
  // Without an entry the swing is over level ground: the bump alone.
  EXPECT_NEAR(ocp_.calcNodeTargets(targets_, 0.125).swing_height[0], H, 1e-9);
  EXPECT_NEAR(calcTerrainHeight({TerrainBox{1.0, 2.0, -1.0, 1.0, 0.1}}, 1.5, 0.0), 0.1, 1e-12);
  EXPECT_EQ(calcTerrainHeight({TerrainBox{1.0, 2.0, -1.0, 1.0, 0.1}}, 0.5, 0.0), 0.0);
}

TEST(TerrainPlane, SlopeRisesAlongX) {
  const TerrainPlane p = TerrainPlane::slope(0.3);
  EXPECT_NEAR(p.heightAt(1.0, 5.0), std::tan(0.3), 1e-12);
  EXPECT_NEAR(p.normal.norm(), 1.0, 1e-12);
  EXPECT_NEAR(TerrainPlane::flat(0.2).heightAt(3.0, -1.0), 0.2, 1e-12);
}

}  // namespace
}  // namespace wj::nmpc
