// The planner's dense SQP solver on Hock-Schittkowski problems with known optima (Hock &
// Schittkowski, "Test Examples for Nonlinear Programming Codes", 1981), with analytic and with
// forward-difference derivatives (as the polish uses it), and on an infeasible problem.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "dense_sqp.h"

namespace wj::planner {
namespace {

constexpr double kInf = 2e19;

// Forward-difference derivatives of p.value (the polish's scheme: step 1e-7 relative, inward
// at the upper bound).
void useForwardDifferences(DenseSqpProblem& p) {
  p.derivatives = [value = p.value, xu = p.xu](const Eigen::VectorXd& x, double f,
                                               const Eigen::VectorXd& c, Eigen::VectorXd& grad,
                                               Eigen::MatrixXd& jac) {
    grad.resize(x.size());
    jac.resize(c.size(), x.size());
    Eigen::VectorXd xp = x, c1(c.size());
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      const double h = 1e-7 * std::max(1.0, std::abs(x[i]));
      const double step = x[i] + h <= xu[i] ? h : -h;
      xp[i] = x[i] + step;
      double f1 = 0.0;
      if (!value(xp, f1, c1)) return false;
      xp[i] = x[i];
      grad[i] = (f1 - f) / step;
      jac.col(i) = (c1 - c) / step;
    }
    return true;
  };
}

// HS071: min x1 x4 (x1 + x2 + x3) + x3  s.t.  x1 x2 x3 x4 >= 25, sum x_i^2 = 40, 1 <= x <= 5.
DenseSqpProblem hs071() {
  DenseSqpProblem p;
  p.xl = Eigen::VectorXd::Constant(4, 1.0);
  p.xu = Eigen::VectorXd::Constant(4, 5.0);
  p.cl = Eigen::Vector2d(25.0, 40.0);
  p.cu = Eigen::Vector2d(kInf, 40.0);
  p.value = [](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c) {
    f = x[0] * x[3] * (x[0] + x[1] + x[2]) + x[2];
    c.resize(2);
    c[0] = x[0] * x[1] * x[2] * x[3];
    c[1] = x.squaredNorm();
    return true;
  };
  p.derivatives = [](const Eigen::VectorXd& x, double, const Eigen::VectorXd&, Eigen::VectorXd& g,
                     Eigen::MatrixXd& J) {
    g.resize(4);
    g << x[3] * (2 * x[0] + x[1] + x[2]), x[0] * x[3], x[0] * x[3] + 1, x[0] * (x[0] + x[1] + x[2]);
    J.resize(2, 4);
    J << x[1] * x[2] * x[3], x[0] * x[2] * x[3], x[0] * x[1] * x[3], x[0] * x[1] * x[2],
        2 * x.transpose();
    return true;
  };
  return p;
}

DenseSqpSettings converging() {
  DenseSqpSettings s;
  s.max_iterations = 100;
  s.stall_iterations = 0;
  return s;
}

TEST(DenseSqp, Hs071ReachesTheKnownOptimum) {
  const DenseSqpResult r = solveDenseSqp(hs071(), Eigen::Vector4d(1, 5, 5, 1), converging());
  ASSERT_TRUE(r.feasible) << toString(r.status);
  EXPECT_EQ(r.status, SqpStatus::Converged);
  EXPECT_NEAR(r.f, 17.0140173, 1e-6);
  EXPECT_NEAR(r.x[0], 1.0, 1e-4);
  EXPECT_NEAR(r.x[1], 4.7429994, 1e-4);
  EXPECT_NEAR(r.x[2], 3.8211503, 1e-4);
  EXPECT_NEAR(r.x[3], 1.3794082, 1e-4);
  EXPECT_LE(r.violation, 1e-6);
}

TEST(DenseSqp, Hs071WithForwardDifferences) {
  DenseSqpProblem p = hs071();
  useForwardDifferences(p);
  const DenseSqpResult r = solveDenseSqp(p, Eigen::Vector4d(1, 5, 5, 1), converging());
  ASSERT_TRUE(r.feasible) << toString(r.status);
  EXPECT_NEAR(r.f, 17.0140173, 1e-5);
  EXPECT_NEAR(r.x[1], 4.7429994, 1e-3);
}

// HS071 with 100 more constraints: x2 <= 4.5, which binds (HS071's x2* = 4.743), and
// x2 - k/100 x3 <= 10 for k = 1..99, which never bind in [1, 5]^4. The screen leaves the
// latter out of the QPs once the step limit is small enough; the solution is the same.
TEST(DenseSqp, ScreeningRowsThatHoldInTheStepBoxChangesNoSolution) {
  DenseSqpProblem p = hs071();
  constexpr int kExtra = 100;
  p.cl.conservativeResize(2 + kExtra);
  p.cu.conservativeResize(2 + kExtra);
  p.cl.tail(kExtra).setConstant(-kInf);
  p.cu.tail(kExtra).setConstant(10.0);
  p.cu[2] = 4.5;
  p.value = [value = p.value](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c) {
    Eigen::VectorXd c2;
    if (!value(x, f, c2)) return false;
    c.resize(2 + kExtra);
    c.head(2) = c2;
    for (int k = 0; k < kExtra; ++k) c[2 + k] = x[1] - 0.01 * k * x[2];
    return true;
  };
  p.derivatives = [derivatives = p.derivatives](const Eigen::VectorXd& x, double f,
                                                const Eigen::VectorXd& c, Eigen::VectorXd& g,
                                                Eigen::MatrixXd& J) {
    Eigen::MatrixXd J2;
    if (!derivatives(x, f, c.head(2), g, J2)) return false;
    J.setZero(2 + kExtra, 4);
    J.topRows(2) = J2;
    for (int k = 0; k < kExtra; ++k) {
      J(2 + k, 1) = 1.0;
      J(2 + k, 2) = -0.01 * k;
    }
    return true;
  };
  DenseSqpSettings screened = converging(), unscreened = converging();
  screened.screen_rows = true;
  unscreened.screen_rows = false;
  const DenseSqpResult a = solveDenseSqp(p, Eigen::Vector4d(1, 5, 5, 1), screened);
  const DenseSqpResult b = solveDenseSqp(p, Eigen::Vector4d(1, 5, 5, 1), unscreened);
  ASSERT_TRUE(a.feasible) << toString(a.status);
  ASSERT_TRUE(b.feasible) << toString(b.status);
  EXPECT_NEAR(a.x[1], 4.5, 1e-6);
  EXPECT_GT(a.f, 17.0140173 + 1e-3);
  EXPECT_NEAR(a.f, b.f, 1e-6 * b.f);  // the same optimum to the solver's tolerance
  EXPECT_LT((a.x - b.x).lpNorm<Eigen::Infinity>(), 1e-5);
  EXPECT_EQ(b.qp_rows_kept, b.qp_rows_offered);
  EXPECT_GT(b.qp_rows_offered, kExtra * b.qp_solves);
  // Nearly all of the 100 rows go once the steps are short.
  EXPECT_LT(a.qp_rows_kept, a.qp_rows_offered / 2) << a.qp_rows_kept << " of " << a.qp_rows_offered;
}

// HS035: min 9 - 8x1 - 6x2 - 4x3 + 2x1^2 + 2x2^2 + x3^2 + 2x1x2 + 2x1x3
//        s.t. x1 + x2 + 2x3 <= 3, x >= 0.  f* = 1/9 at (4/3, 7/9, 4/9).
TEST(DenseSqp, Hs035ConvexQuadraticWithAnActiveInequality) {
  DenseSqpProblem p;
  p.xl = Eigen::Vector3d::Zero();
  p.xu = Eigen::Vector3d::Constant(kInf);
  p.cl = Eigen::VectorXd::Constant(1, -kInf);
  p.cu = Eigen::VectorXd::Constant(1, 3.0);
  p.value = [](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c) {
    f = 9 - 8 * x[0] - 6 * x[1] - 4 * x[2] + 2 * x[0] * x[0] + 2 * x[1] * x[1] + x[2] * x[2] +
        2 * x[0] * x[1] + 2 * x[0] * x[2];
    c.resize(1);
    c[0] = x[0] + x[1] + 2 * x[2];
    return true;
  };
  p.derivatives = [](const Eigen::VectorXd& x, double, const Eigen::VectorXd&, Eigen::VectorXd& g,
                     Eigen::MatrixXd& J) {
    g.resize(3);
    g << -8 + 4 * x[0] + 2 * x[1] + 2 * x[2], -6 + 4 * x[1] + 2 * x[0], -4 + 2 * x[2] + 2 * x[0];
    J.resize(1, 3);
    J << 1, 1, 2;
    return true;
  };
  const DenseSqpResult r = solveDenseSqp(p, Eigen::Vector3d::Constant(0.5), converging());
  ASSERT_TRUE(r.feasible) << toString(r.status);
  EXPECT_NEAR(r.f, 1.0 / 9.0, 1e-7);
  EXPECT_NEAR(r.x[0], 4.0 / 3.0, 1e-4);
  EXPECT_NEAR(r.x[1], 7.0 / 9.0, 1e-4);
  EXPECT_NEAR(r.x[2], 4.0 / 9.0, 1e-4);
}

// HS004: min (x1 + 1)^3 / 3 + x2  s.t.  x1 >= 1, x2 >= 0: both bounds active, f* = 8/3.
TEST(DenseSqp, Hs004OptimumOnTheBounds) {
  DenseSqpProblem p;
  p.xl = Eigen::Vector2d(1.0, 0.0);
  p.xu = Eigen::Vector2d(kInf, kInf);
  p.value = [](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c) {
    f = std::pow(x[0] + 1, 3) / 3 + x[1];
    c.resize(0);
    return true;
  };
  p.derivatives = [](const Eigen::VectorXd& x, double, const Eigen::VectorXd&, Eigen::VectorXd& g,
                     Eigen::MatrixXd& J) {
    g = Eigen::Vector2d(std::pow(x[0] + 1, 2), 1.0);
    J.resize(0, 2);
    return true;
  };
  const DenseSqpResult r = solveDenseSqp(p, Eigen::Vector2d(1.125, 0.125), converging());
  ASSERT_TRUE(r.feasible) << toString(r.status);
  EXPECT_NEAR(r.f, 8.0 / 3.0, 1e-8);
  EXPECT_NEAR(r.x[0], 1.0, 1e-8);
  EXPECT_NEAR(r.x[1], 0.0, 1e-8);
}

// min f(x) s.t. c(x) = 0 over two free variables, with forward-difference derivatives.
template <class F, class C>
DenseSqpProblem twoVariablesOneEquality(F f, C c) {
  DenseSqpProblem p;
  p.xl = Eigen::Vector2d::Constant(-kInf);
  p.xu = Eigen::Vector2d::Constant(kInf);
  p.cl = p.cu = Eigen::VectorXd::Zero(1);
  p.value = [f, c](const Eigen::VectorXd& x, double& fx, Eigen::VectorXd& cx) {
    fx = f(x);
    cx.resize(1);
    cx[0] = c(x);
    return true;
  };
  useForwardDifferences(p);
  return p;
}

// HS006: min (1 - x1)^2  s.t.  10 (x2 - x1^2) = 0, from (-1.2, 1): f* = 0 at (1, 1).
TEST(DenseSqp, Hs006NonlinearEquality) {
  const DenseSqpProblem p =
      twoVariablesOneEquality([](const Eigen::VectorXd& x) { return (1 - x[0]) * (1 - x[0]); },
                              [](const Eigen::VectorXd& x) { return 10 * (x[1] - x[0] * x[0]); });
  DenseSqpSettings st = converging();
  st.print = std::getenv("WJ_SQP_PRINT") != nullptr;
  const DenseSqpResult r = solveDenseSqp(p, Eigen::Vector2d(-1.2, 1.0), st);
  ASSERT_TRUE(r.feasible) << toString(r.status);
  EXPECT_NEAR(r.f, 0.0, 1e-8);
  EXPECT_NEAR(r.x[0], 1.0, 1e-4);
  EXPECT_NEAR(r.x[1], 1.0, 1e-4);
}

// The stall rule (the polish's: 3 iterations without a 0.1 % drop of the best feasible f)
// counts from the first feasible point. Here every point the solver visits is feasible (a
// linear equality, met at the start and kept by every step), and the step limit (0.1, doubling)
// makes the way to the optimum (5, 5) take several iterations of steadily falling f.
TEST(DenseSqp, StallCountStartsAtTheFirstFeasiblePoint) {
  const DenseSqpProblem p = twoVariablesOneEquality(
      [](const Eigen::VectorXd& x) {
        return (x[0] - 5) * (x[0] - 5) + 2 * (x[1] - 5) * (x[1] - 5);
      },
      [](const Eigen::VectorXd& x) { return x[0] - x[1]; });
  DenseSqpSettings st;
  st.max_iterations = 100;
  st.stall_iterations = 3;
  st.print = std::getenv("WJ_SQP_PRINT") != nullptr;
  const DenseSqpResult r = solveDenseSqp(p, Eigen::Vector2d(0.0, 0.0), st);
  ASSERT_TRUE(r.feasible) << toString(r.status);
  EXPECT_NEAR(r.x[0], 5.0, 1e-3) << toString(r.status) << " after " << r.iterations;
  EXPECT_NEAR(r.x[1], 5.0, 1e-3);
}

// x1^2 + x2^2 <= 1 and x1 + x2 >= 3 have no common point.
// |x|^2 <= 1 and x0 + x1 >= 3: no point meets both (the unit disk reaches x0 + x1 = 1.41).
DenseSqpProblem outsideTheUnitDisk() {
  DenseSqpProblem p;
  p.xl = Eigen::Vector2d::Constant(-10);
  p.xu = Eigen::Vector2d::Constant(10);
  p.cl = Eigen::Vector2d(-kInf, 3.0);
  p.cu = Eigen::Vector2d(1.0, kInf);
  p.value = [](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c) {
    f = x[0] - x[1];
    c.resize(2);
    c << x.squaredNorm(), x[0] + x[1];
    return true;
  };
  useForwardDifferences(p);
  return p;
}

TEST(DenseSqp, InfeasibleProblemEndsNotFeasible) {
  const DenseSqpProblem p = outsideTheUnitDisk();
  const DenseSqpResult r = solveDenseSqp(p, Eigen::Vector2d(0.3, -2.0), converging());
  EXPECT_FALSE(r.feasible);
  EXPECT_GT(r.violation, 0.1);
  EXPECT_NE(r.status, SqpStatus::Converged);
  ASSERT_EQ(r.x.size(), 2);
  EXPECT_TRUE(r.x.allFinite());
}

// A target out of reach (the vertical and backflip presets): the solver stops as soon as the
// violation has settled and the linearisation sees no way down, not at max_iterations.
TEST(DenseSqp, LocallyInfeasibleProblemStopsOnceTheViolationSettles) {
  const DenseSqpProblem p = outsideTheUnitDisk();
  DenseSqpSettings st = converging();
  st.max_iterations = 200;
  const DenseSqpResult r = solveDenseSqp(p, Eigen::Vector2d(0.3, -2.0), st);
  EXPECT_EQ(r.status, SqpStatus::LocallyInfeasible) << toString(r.status);
  EXPECT_LT(r.iterations, 50);
  EXPECT_FALSE(r.feasible);
  // No point meets both rows (the unit disk reaches x0 + x1 = 1.41 at most). At the start both
  // are violated (|x|^2 = 4.09, x0 + x1 = -1.7: max violation 4.7); the solver must have
  // settled well below that.
  EXPECT_LT(r.violation, 2.5);
  st.infeasible_iterations = 0;
  EXPECT_NE(solveDenseSqp(p, Eigen::Vector2d(0.3, -2.0), st).status, SqpStatus::LocallyInfeasible);
}

TEST(DenseSqp, NoValueAtTheStartIsAnEvaluationFailure) {
  DenseSqpProblem p = hs071();
  p.value = [](const Eigen::VectorXd&, double&, Eigen::VectorXd&) { return false; };
  const DenseSqpResult r = solveDenseSqp(p, Eigen::Vector4d(1, 5, 5, 1));
  EXPECT_EQ(r.status, SqpStatus::EvaluationFailed);
  EXPECT_FALSE(r.feasible);
}

TEST(DenseSqp, ReturnsTheBestFeasiblePointAndStopsOnStall) {
  // Few iterations and the stall rule: whatever the last iterate, the result meets the
  // constraints and its objective is the lowest of the feasible points seen.
  DenseSqpSettings s;
  s.max_iterations = 6;
  s.stall_iterations = 1;
  const DenseSqpResult r = solveDenseSqp(hs071(), Eigen::Vector4d(1, 5, 5, 1), s);
  if (r.feasible) {
    Eigen::VectorXd c;
    double f = 0.0;
    ASSERT_TRUE(hs071().value(r.x, f, c));
    EXPECT_EQ(f, r.f);
    EXPECT_GE(c[0], 25.0 - 1e-6);
    EXPECT_NEAR(c[1], 40.0, 1e-6);
  }
  EXPECT_LE(r.iterations, 6);
}

TEST(DenseSqp, Deterministic) {
  DenseSqpProblem p = hs071();
  useForwardDifferences(p);
  const DenseSqpResult a = solveDenseSqp(p, Eigen::Vector4d(1, 5, 5, 1));
  const DenseSqpResult b = solveDenseSqp(p, Eigen::Vector4d(1, 5, 5, 1));
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.status, b.status);
}

}  // namespace
}  // namespace wj::planner
