// Tests of the generic Differential Evolution solver (planner/de): convergence on standard test
// functions, determinism across thread counts, warm start, every stopping criterion, input
// validation and feasibility bookkeeping.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "error_of.h"
#include "planner/de/differential_evolution.h"

// Counts heap allocations of the whole process (operator new, Eigen and libgomp all end in malloc)
// by interposing glibc's malloc, to check that a generation allocates nothing. Off under the
// sanitizers, which interpose malloc themselves.
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#define WJ_TEST_COUNTS_MALLOC 1
#endif

#if WJ_TEST_COUNTS_MALLOC
extern "C" void* __libc_malloc(std::size_t size);
namespace {
std::atomic<std::int64_t> g_malloc_calls{0};
}  // namespace
extern "C" void* malloc(std::size_t size) noexcept {
  g_malloc_calls.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}
#endif

namespace wj::planner::de {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Box-bounded problem with the same bounds in every dimension and a cost given as a function.
class FunctionProblem : public Problem {
 public:
  using Cost = std::function<double(const Eigen::Ref<const Eigen::VectorXd>&)>;
  FunctionProblem(int dimension, double lower, double upper, Cost cost)
      : lower_(Eigen::VectorXd::Constant(dimension, lower)),
        upper_(Eigen::VectorXd::Constant(dimension, upper)),
        cost_(std::move(cost)) {}
  FunctionProblem(Eigen::VectorXd lower, Eigen::VectorXd upper, Cost cost)
      : lower_(std::move(lower)), upper_(std::move(upper)), cost_(std::move(cost)) {}
  int dimension() const override { return static_cast<int>(lower_.size()); }
  Eigen::VectorXd lowerBounds() const override { return lower_; }
  Eigen::VectorXd upperBounds() const override { return upper_; }
  Fitness evaluate(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace&) const override {
    return {cost_(x), true};
  }

 private:
  Eigen::VectorXd lower_;
  Eigen::VectorXd upper_;
  Cost cost_;
};

double sphere(const Eigen::Ref<const Eigen::VectorXd>& x) {
  return x.squaredNorm();
}

double rosenbrock(const Eigen::Ref<const Eigen::VectorXd>& x) {
  double sum = 0.0;
  for (Eigen::Index i = 0; i + 1 < x.size(); ++i) {
    const double a = x(i + 1) - x(i) * x(i);
    const double b = 1.0 - x(i);
    sum += 100.0 * a * a + b * b;
  }
  return sum;
}

double rastrigin(const Eigen::Ref<const Eigen::VectorXd>& x) {
  double sum = 10.0 * static_cast<double>(x.size());
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    sum += x(i) * x(i) - 10.0 * std::cos(2.0 * std::numbers::pi * x(i));
  }
  return sum;
}

/// Sphere whose feasible set is x(0) >= 0.8 (in [0, 1]^dim); infeasible candidates cost a penalty
/// above every feasible cost. Optionally never feasible. Declared not thread-safe, so the solver
/// evaluates it serially in batch order, and the test can replay the first feasible evaluation.
class FeasibilityProblem : public Problem {
 public:
  explicit FeasibilityProblem(bool ever_feasible) : ever_feasible_(ever_feasible) {}
  int dimension() const override { return 3; }
  Eigen::VectorXd lowerBounds() const override { return Eigen::VectorXd::Zero(3); }
  Eigen::VectorXd upperBounds() const override { return Eigen::VectorXd::Ones(3); }
  bool isThreadSafe() const override { return false; }
  Fitness evaluate(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace&) const override {
    ++count_;
    const int busy = ++in_flight_;
    max_in_flight_ = std::max(max_in_flight_.load(), busy);
    const bool feasible = ever_feasible_ && x(0) >= 0.8;
    if (feasible && first_feasible_count_ < 0) first_feasible_count_ = count_;
    --in_flight_;
    const double cost = x.squaredNorm();
    return {feasible ? cost : 100.0 + (0.8 - x(0)) + cost, feasible};
  }
  std::int64_t firstFeasibleCount() const { return first_feasible_count_; }
  int maxInFlight() const { return max_in_flight_; }

 private:
  bool ever_feasible_;
  mutable std::int64_t count_ = 0;
  mutable std::int64_t first_feasible_count_ = -1;
  mutable std::atomic<int> in_flight_{0};
  mutable std::atomic<int> max_in_flight_{0};
};

/// Workspace that detects being used by two threads at once.
struct GuardedWorkspace : Workspace {
  std::atomic<bool> busy{false};
};

/// Sphere that counts evaluations and workspaces, checks the bounds and the exclusive use of each
/// workspace, and can raise a cancel flag after a number of evaluations.
class InstrumentedProblem : public Problem {
 public:
  InstrumentedProblem(Eigen::VectorXd lower, Eigen::VectorXd upper)
      : lower_(std::move(lower)), upper_(std::move(upper)) {}
  int dimension() const override { return static_cast<int>(lower_.size()); }
  Eigen::VectorXd lowerBounds() const override { return lower_; }
  Eigen::VectorXd upperBounds() const override { return upper_; }
  std::unique_ptr<Workspace> createWorkspace() const override {
    ++workspaces;
    return std::make_unique<GuardedWorkspace>();
  }
  Fitness evaluate(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace& ws) const override {
    auto& guarded = dynamic_cast<GuardedWorkspace&>(ws);
    if (guarded.busy.exchange(true)) shared_workspace = true;
    if ((x.array() < lower_.array()).any() || (x.array() > upper_.array()).any()) {
      out_of_bounds = true;
    }
    const auto n = ++evaluations;
    if (cancel != nullptr && n >= cancel_after) cancel->store(true);
    guarded.busy.store(false);
    return {x.squaredNorm(), true};
  }

  mutable std::atomic<std::int64_t> evaluations{0};
  mutable std::atomic<int> workspaces{0};
  mutable std::atomic<bool> out_of_bounds{false};
  mutable std::atomic<bool> shared_workspace{false};
  std::atomic<bool>* cancel = nullptr;
  std::int64_t cancel_after = 0;

 private:
  Eigen::VectorXd lower_;
  Eigen::VectorXd upper_;
};

Settings quickSettings() {
  Settings s;
  s.population_size = 20;
  s.max_generations = 50;
  s.seed = 7;
  return s;
}

// ----------------------------------------------------------------------------------------------
// Convergence

struct ConvergenceCase {
  Adaptation adaptation;
  Strategy strategy;
  int population_size;
};

std::string caseName(const ::testing::TestParamInfo<ConvergenceCase>& case_info) {
  return std::string(toString(case_info.param.adaptation)) + "_" +
         std::string(toString(case_info.param.strategy));
}

class RosenbrockTest : public ::testing::TestWithParam<ConvergenceCase> {};

TEST_P(RosenbrockTest, ReachesTheMinimumWithinTheBudget) {
  const FunctionProblem problem(5, -5.0, 10.0, rosenbrock);
  for (const std::uint64_t seed : {1, 2, 3}) {
    Settings s;
    s.adaptation = GetParam().adaptation;
    s.strategy = GetParam().strategy;
    s.population_size = GetParam().population_size;
    s.max_generations = 100000;
    s.max_evaluations = 60000;
    s.target_cost = 1e-7;
    s.seed = seed;
    const Result r = Solver(s).solve(problem);
    EXPECT_LT(r.best.cost, 1e-6) << "seed " << seed;
    EXPECT_EQ(r.stop_reason, StopReason::TargetReached) << "seed " << seed;
    EXPECT_TRUE(r.best_x.isApprox(Eigen::VectorXd::Ones(5), 1e-3)) << "seed " << seed;
  }
}

// Evaluations to 1e-7 over seeds 1..10 on this implementation: about 6k (SHADE), 16k-23k (jDE).
INSTANTIATE_TEST_SUITE_P(
    de, RosenbrockTest,
    ::testing::Values(ConvergenceCase{Adaptation::JDE, Strategy::Rand1Bin, 40},
                      ConvergenceCase{Adaptation::JDE, Strategy::CurrentToPBest1Bin, 40},
                      ConvergenceCase{Adaptation::JDE, Strategy::Rand2Bin, 20},
                      ConvergenceCase{Adaptation::SHADE, Strategy::CurrentToPBest1Bin, 30},
                      ConvergenceCase{Adaptation::SHADE, Strategy::CurrentToBest1Bin, 30}),
    caseName);

class RastriginTest : public ::testing::TestWithParam<ConvergenceCase> {};

TEST_P(RastriginTest, FindsTheGlobalOptimumForMostSeeds) {
  // Multimodal: a run may end in a local minimum. Over seeds 1..20 both configurations found the
  // global optimum every time; 9 of the 10 seeds below is the honest bar with one spare.
  const FunctionProblem problem(5, -5.12, 5.12, rastrigin);
  int successes = 0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    Settings s;
    s.adaptation = GetParam().adaptation;
    s.strategy = GetParam().strategy;
    s.population_size = GetParam().population_size;
    s.max_generations = 100000;
    s.max_evaluations = 40000;
    s.target_cost = 1e-7;
    s.seed = seed;
    const Result r = Solver(s).solve(problem);
    if (r.best.cost < 1e-6) ++successes;
  }
  EXPECT_GE(successes, 9);
}

INSTANTIATE_TEST_SUITE_P(de, RastriginTest,
                         ::testing::Values(ConvergenceCase{Adaptation::JDE, Strategy::Rand1Bin, 50},
                                           ConvergenceCase{Adaptation::SHADE,
                                                           Strategy::CurrentToPBest1Bin, 50}),
                         caseName);

TEST(de_Convergence, FixedVariablesStayPut) {
  Eigen::VectorXd lower = Eigen::VectorXd::Constant(6, -3.0);
  Eigen::VectorXd upper = Eigen::VectorXd::Constant(6, 3.0);
  lower(1) = upper(1) = 0.3;
  lower(4) = upper(4) = -2.0;
  const FunctionProblem problem(lower, upper, sphere);
  for (const Initialization init :
       {Initialization::Uniform, Initialization::LatinHypercube, Initialization::OppositionBased}) {
    Settings s = quickSettings();
    s.initialization = init;
    s.max_generations = 300;
    const Result r = Solver(s).solve(problem);
    for (Eigen::Index c = 0; c < r.population.cols(); ++c) {
      EXPECT_EQ(r.population(1, c), 0.3);
      EXPECT_EQ(r.population(4, c), -2.0);
    }
    EXPECT_NEAR(r.best.cost, 0.09 + 4.0, 1e-8) << toString(init);
  }
}

TEST(de_Convergence, EveryStrategyKeepsCandidatesInTheBox) {
  // An asymmetric box with the optimum outside it pushes mutants across the bounds.
  const Eigen::VectorXd lower = (Eigen::VectorXd(4) << 1.0, -1.0, 0.5, 2.0).finished();
  const Eigen::VectorXd upper = (Eigen::VectorXd(4) << 2.0, 3.0, 0.75, 2.5).finished();
  for (const Strategy strategy :
       {Strategy::Rand1Bin, Strategy::Best1Bin, Strategy::CurrentToBest1Bin, Strategy::Rand2Bin,
        Strategy::CurrentToPBest1Bin}) {
    for (const Adaptation adaptation : {Adaptation::None, Adaptation::JDE, Adaptation::SHADE}) {
      const InstrumentedProblem problem(lower, upper);
      Settings s = quickSettings();
      s.strategy = strategy;
      s.adaptation = adaptation;
      s.F = 1.5;  // large steps: many mutants leave the box
      s.max_generations = 200;
      const Result r = Solver(s).solve(problem);
      EXPECT_FALSE(problem.out_of_bounds.load())
          << toString(strategy) << " " << toString(adaptation);
      EXPECT_NEAR(r.best.cost, 1.0 + 0.25 + 4.0, 1e-3) << toString(strategy);
    }
  }
}

TEST(de_Adaptation, ParametersStayInTheirRanges) {
  const FunctionProblem problem(5, -5.0, 10.0, rosenbrock);
  for (const Adaptation adaptation : {Adaptation::None, Adaptation::JDE, Adaptation::SHADE}) {
    for (const int memory : {0, 3}) {
      Settings s = quickSettings();
      s.adaptation = adaptation;
      s.shade_memory_size = memory;
      s.F = 0.7;
      s.CR = 0.3;
      s.max_generations = 100;
      const Result r = Solver(s).solve(problem);
      SCOPED_TRACE(toString(adaptation));
      EXPECT_EQ(r.log.front().mean_F, 0.7);
      EXPECT_EQ(r.log.front().mean_CR, 0.3);
      for (const GenerationLog& g : r.log) {
        if (adaptation == Adaptation::None) {
          EXPECT_DOUBLE_EQ(g.mean_F, 0.7);
          EXPECT_DOUBLE_EQ(g.mean_CR, 0.3);
        }
        EXPECT_GT(g.mean_F, 0.0);
        EXPECT_LE(g.mean_F, 1.0);
        EXPECT_GE(g.mean_CR, 0.0);
        EXPECT_LE(g.mean_CR, 1.0);
      }
      if (adaptation != Adaptation::None) {
        EXPECT_NE(r.log.back().mean_F, 0.7);  // the parameters did adapt
      }
    }
  }
}

// ----------------------------------------------------------------------------------------------
// Determinism and threads

void expectSameRun(const Result& a, const Result& b) {
  ASSERT_EQ(a.log.size(), b.log.size());
  for (std::size_t g = 0; g < a.log.size(); ++g) {
    EXPECT_EQ(a.log[g].generation, b.log[g].generation);
    EXPECT_EQ(a.log[g].evaluations, b.log[g].evaluations);
    EXPECT_EQ(a.log[g].best_cost, b.log[g].best_cost) << "generation " << g;
    EXPECT_EQ(a.log[g].mean_cost, b.log[g].mean_cost) << "generation " << g;
    EXPECT_EQ(a.log[g].best_feasible, b.log[g].best_feasible);
    EXPECT_EQ(a.log[g].mean_F, b.log[g].mean_F);
    EXPECT_EQ(a.log[g].mean_CR, b.log[g].mean_CR);
  }
  EXPECT_EQ(a.best_x, b.best_x);
  EXPECT_EQ(a.population, b.population);
  EXPECT_EQ(a.evaluations, b.evaluations);
  EXPECT_EQ(a.stop_reason, b.stop_reason);
}

struct DeterminismCase {
  Adaptation adaptation;
  Initialization initialization;
  Strategy strategy;
};

class DeterminismTest : public ::testing::TestWithParam<DeterminismCase> {};

TEST_P(DeterminismTest, SameSeedGivesTheSameRunAtOneAndTwoThreads) {
  const FunctionProblem problem(5, -5.0, 10.0, rosenbrock);
  Settings s = quickSettings();
  s.adaptation = GetParam().adaptation;
  s.initialization = GetParam().initialization;
  s.strategy = GetParam().strategy;
  s.max_generations = 200;
  s.max_evaluations = 733;  // ends on a partial generation
  s.threads = 1;
  const Result one = Solver(s).solve(problem);
  s.threads = 2;
  const Result two = Solver(s).solve(problem);
  EXPECT_EQ(one.stop_reason, StopReason::MaxEvaluations);
  expectSameRun(one, two);
}

// Every strategy, adaptation and initialization appears at least once.
INSTANTIATE_TEST_SUITE_P(
    de, DeterminismTest,
    ::testing::Values(
        DeterminismCase{Adaptation::None, Initialization::Uniform, Strategy::Rand1Bin},
        DeterminismCase{Adaptation::JDE, Initialization::LatinHypercube, Strategy::Best1Bin},
        DeterminismCase{Adaptation::SHADE, Initialization::OppositionBased,
                        Strategy::CurrentToPBest1Bin},
        DeterminismCase{Adaptation::JDE, Initialization::Uniform, Strategy::Rand2Bin},
        DeterminismCase{Adaptation::SHADE, Initialization::LatinHypercube,
                        Strategy::CurrentToBest1Bin}),
    [](const ::testing::TestParamInfo<DeterminismCase>& case_info) {
      return std::string(toString(case_info.param.adaptation)) + "_" +
             std::string(toString(case_info.param.initialization)) + "_" +
             std::string(toString(case_info.param.strategy));
    });

/// Rosenbrock whose bounded evaluation adds the terms one by one and stops as soon as the sum
/// exceeds the bound (every term is >= 0, so the partial sum is a lower bound). Counts the terms.
class BoundedRosenbrock : public Problem {
 public:
  int dimension() const override { return 6; }
  Eigen::VectorXd lowerBounds() const override { return Eigen::VectorXd::Constant(6, -5.0); }
  Eigen::VectorXd upperBounds() const override { return Eigen::VectorXd::Constant(6, 10.0); }
  Fitness evaluate(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace& ws) const override {
    return evaluateBounded(x, ws, kInf);
  }
  Fitness evaluateBounded(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace&,
                          double bound) const override {
    double sum = 0.0;
    for (Eigen::Index i = 0; i + 1 < x.size(); ++i) {
      const double a = x(i + 1) - x(i) * x(i);
      const double b = 1.0 - x(i);
      sum += 100.0 * a * a + b * b;
      terms_.fetch_add(1, std::memory_order_relaxed);
      if (sum > bound) return {sum, false};
    }
    return {sum, true};
  }
  mutable std::atomic<long> terms_{0};
};

TEST(de_Evaluation, BoundedTrialsMakeTheSameRunWithLessWork) {
  Settings s = quickSettings();
  s.max_generations = 300;
  s.threads = 2;
  s.bounded_trials = false;
  const BoundedRosenbrock full_problem;
  const Result full = Solver(s).solve(full_problem);
  s.bounded_trials = true;
  const BoundedRosenbrock bounded_problem;
  const Result bounded = Solver(s).solve(bounded_problem);
  expectSameRun(full, bounded);
  EXPECT_EQ(full.best_x, bounded.best_x);
  EXPECT_EQ(full.evaluations, bounded.evaluations);
  // Trials that lose to their parent stop early: fewer terms computed for the same run.
  EXPECT_LT(bounded_problem.terms_.load(), full_problem.terms_.load() * 9 / 10);
}

TEST(de_Determinism, DifferentSeedsGiveDifferentRuns) {
  const FunctionProblem problem(5, -5.0, 10.0, rosenbrock);
  Settings s = quickSettings();
  const Result a = Solver(s).solve(problem);
  s.seed = 8;
  const Result b = Solver(s).solve(problem);
  EXPECT_NE(a.best_x, b.best_x);
  EXPECT_NE(a.log.front().best_cost, b.log.front().best_cost);
}

TEST(de_Evaluation, WorkspacesAreCreatedOncePerSolveAndNeverShared) {
  const InstrumentedProblem problem(Eigen::VectorXd::Constant(4, -1.0),
                                    Eigen::VectorXd::Constant(4, 1.0));
  Settings s = quickSettings();
  s.threads = 2;
  s.max_generations = 10;
  Solver(s).solve(problem);
  EXPECT_EQ(problem.workspaces.load(), 2);
  EXPECT_FALSE(problem.shared_workspace.load());
}

TEST(de_Evaluation, NotThreadSafeProblemIsEvaluatedSerially) {
  const FeasibilityProblem problem(true);
  Settings s = quickSettings();
  s.threads = 2;
  Solver(s).solve(problem);
  EXPECT_EQ(problem.maxInFlight(), 1);
}

TEST(de_Evaluation, EvaluationErrorPropagates) {
  const FunctionProblem problem(3, -1.0, 1.0, [](const auto& x) -> double {
    if (x(0) > 0.9) throw std::runtime_error("model failure");
    return x.squaredNorm();
  });
  Settings s = quickSettings();
  s.threads = 2;
  EXPECT_THROW(Solver(s).solve(problem), std::runtime_error);
}

TEST(de_Evaluation, NanCostRanksLast) {
  const FunctionProblem problem(3, -1.0, 1.0, [](const auto& x) {
    return x(0) < 0.0 ? std::numeric_limits<double>::quiet_NaN() : x.squaredNorm();
  });
  const Result r = Solver(quickSettings()).solve(problem);
  EXPECT_TRUE(std::isfinite(r.best.cost));
  EXPECT_GE(r.best_x(0), 0.0);
}

#if WJ_TEST_COUNTS_MALLOC
TEST(de_Evaluation, GenerationsDoNotAllocate) {
  const FunctionProblem problem(5, -5.0, 10.0, rosenbrock);
  for (const Adaptation adaptation : {Adaptation::None, Adaptation::JDE, Adaptation::SHADE}) {
    for (const int threads : {1, 2}) {
      Settings s = quickSettings();
      s.adaptation = adaptation;
      s.threads = threads;
      s.keep_log = false;
      const auto allocationsOfSolve = [&](int generations) {
        s.max_generations = generations;
        const std::int64_t before = g_malloc_calls.load();
        Solver(s).solve(problem);
        return g_malloc_calls.load() - before;
      };
      allocationsOfSolve(1);  // warm-up: OpenMP creates its thread pool once
      const std::int64_t short_run = allocationsOfSolve(5);
      EXPECT_GT(short_run, 0);  // the counter works: a solve sizes its buffers
      EXPECT_EQ(short_run, allocationsOfSolve(25))
          << toString(adaptation) << ", " << threads << " threads";
    }
  }
}
#endif

// ----------------------------------------------------------------------------------------------
// Warm start

TEST(de_WarmStart, WarmStartAtTheOptimumReturnsImmediately) {
  const Eigen::VectorXd center = (Eigen::VectorXd(3) << 0.25, -1.5, 2.0).finished();
  const FunctionProblem problem(3, -4.0, 4.0,
                                [&](const auto& x) { return (x - center).squaredNorm(); });
  for (const Initialization init :
       {Initialization::Uniform, Initialization::LatinHypercube, Initialization::OppositionBased}) {
    Settings s = quickSettings();
    s.initialization = init;
    s.target_cost = 0.0;
    const Result r = Solver(s).solve(problem, center);
    EXPECT_EQ(r.stop_reason, StopReason::TargetReached);
    EXPECT_EQ(r.generations, 0);
    EXPECT_EQ(r.best_x, center);
    EXPECT_EQ(r.best.cost, 0.0);
    EXPECT_LE(r.evaluations, 2 * s.population_size);
  }
}

TEST(de_WarmStart, WarmStartIsClippedToTheBox) {
  const FunctionProblem problem(2, -1.0, 1.0, [](const auto& x) {
    return (x - Eigen::Vector2d(1.0, -1.0)).squaredNorm();  // optimum at a corner
  });
  Eigen::MatrixXd warm(2, 3);
  warm << 5.0, 0.0, 0.1,  //
      -7.0, 0.0, 0.2;
  Settings s = quickSettings();
  s.target_cost = 0.0;
  const Result r = Solver(s).solve(problem, warm);
  EXPECT_EQ(r.stop_reason, StopReason::TargetReached);
  EXPECT_EQ(r.best_x, Eigen::Vector2d(1.0, -1.0));
}

TEST(de_WarmStart, WarmStartLargerThanThePopulationIsTruncated) {
  const FunctionProblem problem(2, -1.0, 1.0, sphere);
  Settings s = quickSettings();
  s.max_generations = 1;
  const Eigen::MatrixXd warm = Eigen::MatrixXd::Constant(2, 3 * s.population_size, 0.5);
  const Result r = Solver(s).solve(problem, warm);
  EXPECT_EQ(r.evaluations, 2 * s.population_size);
}

// ----------------------------------------------------------------------------------------------
// Stopping criteria

TEST(de_Stopping, StopsAtMaxGenerations) {
  const FunctionProblem problem(4, -5.0, 5.0, sphere);
  Settings s = quickSettings();
  s.max_generations = 7;
  const Result r = Solver(s).solve(problem);
  EXPECT_EQ(r.stop_reason, StopReason::MaxGenerations);
  EXPECT_EQ(r.generations, 7);
  EXPECT_EQ(r.evaluations, 8 * s.population_size);
  ASSERT_EQ(r.log.size(), 8u);
  EXPECT_EQ(r.log.back().generation, 7);
  EXPECT_EQ(r.log.back().evaluations, r.evaluations);
}

TEST(de_Stopping, StopsAtMaxEvaluationsWithAPartialLastGeneration) {
  const FunctionProblem problem(4, -5.0, 5.0, sphere);
  Settings s = quickSettings();
  s.population_size = 10;
  s.max_evaluations = 95;
  const Result r = Solver(s).solve(problem);
  EXPECT_EQ(r.stop_reason, StopReason::MaxEvaluations);
  EXPECT_EQ(r.evaluations, 95);
  EXPECT_EQ(r.generations, 9);
}

TEST(de_Stopping, NeverExceedsMaxEvaluations) {
  for (const Initialization init :
       {Initialization::Uniform, Initialization::LatinHypercube, Initialization::OppositionBased}) {
    for (const std::int64_t budget : {20, 21, 33, 39, 40, 41, 257}) {
      const InstrumentedProblem problem(Eigen::VectorXd::Constant(3, -1.0),
                                        Eigen::VectorXd::Constant(3, 1.0));
      Settings s = quickSettings();
      s.initialization = init;
      s.max_generations = 1000;
      s.max_evaluations = budget;
      s.threads = 2;
      const Result r = Solver(s).solve(problem);
      EXPECT_EQ(r.evaluations, budget) << toString(init);
      EXPECT_EQ(problem.evaluations.load(), budget) << toString(init);
      EXPECT_EQ(r.stop_reason, StopReason::MaxEvaluations);
    }
  }
}

TEST(de_Stopping, OppositionBasedInitializationCostsTwoPopulations) {
  const FunctionProblem problem(3, -1.0, 1.0, sphere);
  Settings s = quickSettings();
  s.initialization = Initialization::OppositionBased;
  s.max_generations = 1;
  const Result r = Solver(s).solve(problem);
  EXPECT_EQ(r.log.front().evaluations, 2 * s.population_size);
  EXPECT_EQ(r.evaluations, 3 * s.population_size);
}

TEST(de_Stopping, StopsAtTheTimeBudget) {
  const FunctionProblem problem(2, -1.0, 1.0, [](const auto& x) {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
    return x.squaredNorm();
  });
  Settings s = quickSettings();
  s.max_generations = 1'000'000;
  s.time_budget_s = 0.05;
  const Result r = Solver(s).solve(problem);
  EXPECT_EQ(r.stop_reason, StopReason::TimeBudget);
  EXPECT_GE(r.elapsed_s, 0.05);
  EXPECT_LT(r.elapsed_s, 1.0);
}

TEST(de_Stopping, StopsAtTheCostTolerance) {
  const FunctionProblem problem(3, -5.0, 5.0, sphere);
  Settings s = quickSettings();
  s.max_generations = 100000;
  s.tolerance = 1e-6;
  const Result r = Solver(s).solve(problem);
  EXPECT_EQ(r.stop_reason, StopReason::Tolerance);
  EXPECT_LT(r.fitness.back().cost - r.fitness.front().cost, 1e-6);
}

TEST(de_Stopping, StopsOnStagnation) {
  const FunctionProblem problem(3, -5.0, 5.0, [](const auto&) { return 1.0; });
  Settings s = quickSettings();
  s.stagnation_generations = 5;
  const Result r = Solver(s).solve(problem);
  EXPECT_EQ(r.stop_reason, StopReason::Stagnation);
  EXPECT_EQ(r.generations, 5);
}

// With a relative stagnation tolerance, slow progress counts as stagnation: on the sphere the
// best keeps dropping every few generations, by less than half within 5 generations late on.
TEST(de_Stopping, StagnationToleranceCountsSlowProgressAsStagnation) {
  const FunctionProblem problem(3, -5.0, 5.0, sphere);
  Settings s = quickSettings();
  s.max_generations = 2000;
  s.stagnation_generations = 5;
  const Result strict = Solver(s).solve(problem);
  s.stagnation_tolerance = 0.5;
  const Result loose = Solver(s).solve(problem);
  EXPECT_EQ(loose.stop_reason, StopReason::Stagnation);
  EXPECT_LT(loose.generations, strict.generations);
  // The last 5 generations lowered the best by less than half of where the window began.
  const auto& log = loose.log;
  ASSERT_GT(log.size(), 6u);
  EXPECT_GT(log.back().best_cost, 0.5 * log[log.size() - 6].best_cost);
}

TEST(de_Stopping, StopsAtTheTargetCost) {
  const FunctionProblem problem(3, -5.0, 5.0, sphere);
  Settings s = quickSettings();
  s.max_generations = 100000;
  s.target_cost = 1e-3;
  const Result r = Solver(s).solve(problem);
  EXPECT_EQ(r.stop_reason, StopReason::TargetReached);
  EXPECT_LE(r.best.cost, 1e-3);
  EXPECT_GT(r.log[r.log.size() - 2].best_cost, 1e-3);
}

TEST(de_Stopping, TargetNeedsAFeasibleBest) {
  const FeasibilityProblem problem(false);
  Settings s = quickSettings();
  s.target_cost = 1e9;  // every cost is below, none is feasible
  s.max_generations = 3;
  const Result r = Solver(s).solve(problem);
  EXPECT_EQ(r.stop_reason, StopReason::MaxGenerations);
}

TEST(de_Stopping, StopsWhenCancelledBeforehand) {
  const FunctionProblem problem(3, -5.0, 5.0, sphere);
  const std::atomic<bool> cancel{true};
  const Result r = Solver(quickSettings()).solve(problem, Eigen::MatrixXd(), &cancel);
  EXPECT_EQ(r.stop_reason, StopReason::Cancelled);
  EXPECT_EQ(r.generations, 0);
  EXPECT_EQ(r.evaluations, 20);
}

TEST(de_Stopping, StopsWhenCancelledDuringTheRun) {
  InstrumentedProblem problem(Eigen::VectorXd::Constant(3, -1.0),
                              Eigen::VectorXd::Constant(3, 1.0));
  std::atomic<bool> cancel{false};
  problem.cancel = &cancel;
  problem.cancel_after = 105;
  Settings s = quickSettings();
  s.max_generations = 1000;
  s.threads = 2;
  const Result r = Solver(s).solve(problem, Eigen::MatrixXd(), &cancel);
  EXPECT_EQ(r.stop_reason, StopReason::Cancelled);
  EXPECT_EQ(r.evaluations, 120);  // the generation in flight completes
}

// ----------------------------------------------------------------------------------------------
// Feasibility

TEST(de_Feasibility, RecordsTheFirstFeasibleEvaluation) {
  const FeasibilityProblem problem(true);
  Settings s = quickSettings();
  s.max_generations = 100;
  const Result r = Solver(s).solve(problem);
  ASSERT_GT(problem.firstFeasibleCount(), 0);
  EXPECT_EQ(r.first_feasible_evaluations, problem.firstFeasibleCount());
  EXPECT_GE(r.first_feasible_s, 0.0);
  EXPECT_LE(r.first_feasible_s, r.elapsed_s);
  EXPECT_TRUE(r.best.feasible);
  EXPECT_NEAR(r.best_x(0), 0.8, 1e-3);
}

TEST(de_Feasibility, ReportsNoFeasibleCandidate) {
  const FeasibilityProblem problem(false);
  Settings s = quickSettings();
  s.max_generations = 10;
  const Result r = Solver(s).solve(problem);
  EXPECT_EQ(r.first_feasible_evaluations, -1);
  EXPECT_EQ(r.first_feasible_s, -1.0);
  EXPECT_FALSE(r.best.feasible);
  EXPECT_FALSE(r.log.back().best_feasible);
}

TEST(de_Result, FinalPopulationIsSortedBestFirst) {
  const FunctionProblem problem(4, -5.0, 5.0, rastrigin);
  const Result r = Solver(quickSettings()).solve(problem);
  ASSERT_EQ(r.population.cols(), 20);
  ASSERT_EQ(r.fitness.size(), 20u);
  for (std::size_t c = 0; c < r.fitness.size(); ++c) {
    EXPECT_EQ(r.fitness[c].cost, rastrigin(r.population.col(static_cast<Eigen::Index>(c))));
    if (c > 0) {
      EXPECT_LE(r.fitness[c - 1].cost, r.fitness[c].cost);
    }
  }
  EXPECT_EQ(r.best.cost, r.fitness.front().cost);
  EXPECT_EQ(r.best_x, r.population.col(0));
}

// ----------------------------------------------------------------------------------------------
// Validation

void expectInvalidSetting(const std::function<void(Settings&)>& change, const std::string& field) {
  Settings s;
  change(s);
  const std::string message = test::errorOf<std::invalid_argument>([&] { s.validate(); });
  EXPECT_THAT(message, testing::StartsWith(field + " must be"));
  EXPECT_THAT(message, test::HasSubstr("got"));
  EXPECT_THROW(Solver{s}, std::invalid_argument);
}

TEST(de_Validation, RejectsBadSettings) {
  EXPECT_NO_THROW(Settings{}.validate());
  expectInvalidSetting([](Settings& s) { s.population_size = 3; }, "population_size");
  expectInvalidSetting(
      [](Settings& s) {
        s.strategy = Strategy::Rand2Bin;
        s.population_size = 6;
      },
      "population_size");
  expectInvalidSetting([](Settings& s) { s.F = 0.0; }, "F");
  expectInvalidSetting([](Settings& s) { s.F = 2.5; }, "F");
  expectInvalidSetting([](Settings& s) { s.F = std::nan(""); }, "F");
  expectInvalidSetting([](Settings& s) { s.CR = -0.1; }, "CR");
  expectInvalidSetting([](Settings& s) { s.CR = 1.1; }, "CR");
  expectInvalidSetting([](Settings& s) { s.p_best = 0.0; }, "p_best");
  expectInvalidSetting([](Settings& s) { s.max_generations = 0; }, "max_generations");
  expectInvalidSetting([](Settings& s) { s.max_evaluations = 39; }, "max_evaluations");
  expectInvalidSetting([](Settings& s) { s.time_budget_s = -1.0; }, "time_budget_s");
  expectInvalidSetting([](Settings& s) { s.tolerance = std::nan(""); }, "tolerance");
  expectInvalidSetting([](Settings& s) { s.stagnation_generations = -1; },
                       "stagnation_generations");
  expectInvalidSetting([](Settings& s) { s.stagnation_tolerance = 1.0; }, "stagnation_tolerance");
  expectInvalidSetting([](Settings& s) { s.target_cost = std::nan(""); }, "target_cost");
  expectInvalidSetting([](Settings& s) { s.threads = 0; }, "threads");
  expectInvalidSetting([](Settings& s) { s.shade_memory_size = -2; }, "shade_memory_size");
  expectInvalidSetting([](Settings& s) { s.strategy = static_cast<Strategy>(42); }, "strategy");
  expectInvalidSetting([](Settings& s) { s.adaptation = static_cast<Adaptation>(-1); },
                       "adaptation");
  expectInvalidSetting([](Settings& s) { s.initialization = static_cast<Initialization>(9); },
                       "initialization");

  Settings small;
  small.population_size = 3;
  EXPECT_EQ(test::errorOf<std::invalid_argument>([&] { small.validate(); }),
            "population_size must be >= 5, got 3");
}

void expectInvalidProblem(const Problem& problem, const std::string& needle,
                          const Eigen::MatrixXd& warm_start = Eigen::MatrixXd()) {
  EXPECT_THAT(test::errorOf<std::invalid_argument>(
                  [&] { return Solver(quickSettings()).solve(problem, warm_start); }),
              test::HasSubstr(needle));
}

TEST(de_Validation, RejectsBadBoundsAndWarmStarts) {
  const Eigen::VectorXd lo = Eigen::VectorXd::Zero(3);
  const Eigen::VectorXd hi = Eigen::VectorXd::Ones(3);
  Eigen::VectorXd bad = lo;
  bad(1) = 2.0;
  expectInvalidProblem(FunctionProblem(bad, hi, sphere), "lower bound[1]");
  bad(1) = std::nan("");
  expectInvalidProblem(FunctionProblem(bad, hi, sphere), "lower bound[1] must be finite");
  bad = hi;
  bad(2) = kInf;
  expectInvalidProblem(FunctionProblem(lo, bad, sphere), "upper bound[2] must be finite");
  expectInvalidProblem(FunctionProblem(lo, Eigen::VectorXd::Ones(2), sphere),
                       "Problem::upperBounds().size()");
  expectInvalidProblem(FunctionProblem(0, 0.0, 1.0, sphere), "Problem::dimension()");

  const FunctionProblem good(lo, hi, sphere);
  expectInvalidProblem(good, "warm_start.rows()", Eigen::MatrixXd::Zero(2, 1));
  Eigen::MatrixXd warm = Eigen::MatrixXd::Zero(3, 2);
  warm(2, 1) = std::nan("");
  expectInvalidProblem(good, "warm_start(2, 1) must be finite", warm);
  EXPECT_NO_THROW(Solver(quickSettings()).solve(good, Eigen::MatrixXd::Zero(3, 0)));
}

TEST(de_Validation, NamesEnumerators) {
  EXPECT_EQ(toString(StopReason::MaxGenerations), "MaxGenerations");
  EXPECT_EQ(toString(StopReason::MaxEvaluations), "MaxEvaluations");
  EXPECT_EQ(toString(StopReason::TimeBudget), "TimeBudget");
  EXPECT_EQ(toString(StopReason::Tolerance), "Tolerance");
  EXPECT_EQ(toString(StopReason::Stagnation), "Stagnation");
  EXPECT_EQ(toString(StopReason::TargetReached), "TargetReached");
  EXPECT_EQ(toString(StopReason::Cancelled), "Cancelled");
  EXPECT_EQ(toString(Strategy::Rand1Bin), "Rand1Bin");
  EXPECT_EQ(toString(Strategy::Best1Bin), "Best1Bin");
  EXPECT_EQ(toString(Strategy::CurrentToBest1Bin), "CurrentToBest1Bin");
  EXPECT_EQ(toString(Strategy::Rand2Bin), "Rand2Bin");
  EXPECT_EQ(toString(Strategy::CurrentToPBest1Bin), "CurrentToPBest1Bin");
  EXPECT_EQ(toString(Adaptation::SHADE), "SHADE");
  EXPECT_EQ(toString(Initialization::OppositionBased), "OppositionBased");
}

}  // namespace
}  // namespace wj::planner::de
