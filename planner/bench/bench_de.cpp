// Micro-benchmark: our DE (SHADE, CurrentToPBest1Bin) against pagmo2's sade (variant 2 =
// rand/1/exp, jDE adaptation) on Rosenbrock-10 with the same evaluation budget.
//
// Every benchmark iteration is one full solve with its own seed (1, 2, ...), so the counters are
// medians over seeds: final_cost (best cost at the end of the budget) and wall_ms (wall time of one
// solve). "Cheap" is the plain Rosenbrock function (about 20 ns per evaluation: the solver's own
// overhead dominates); "Heavy" adds about 20 us of busy work per evaluation, the order of a
// jump-model rollout, where the parallel evaluation pays off. pagmo's sade evaluates serially.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <utility>
#include <vector>

#include <pagmo/algorithm.hpp>
#include <pagmo/algorithms/sade.hpp>
#include <pagmo/population.hpp>
#include <pagmo/problem.hpp>
#include <pagmo/types.hpp>

#include "planner/de/differential_evolution.h"

namespace {

namespace de = wj::planner::de;

constexpr int kDimension = 10;
constexpr int kPopulation = 40;
constexpr double kLower = -5.0;
constexpr double kUpper = 10.0;

/// Rosenbrock's function, sum of 100 (x_{i+1} - x_i^2)^2 + (1 - x_i)^2; minimum 0 at x = 1.
template <typename Vector>
double rosenbrock(const Vector& x, int heavy_iterations) {
  double sum = 0.0;
  for (int i = 0; i + 1 < kDimension; ++i) {
    const double a = x[i + 1] - x[i] * x[i];
    const double b = 1.0 - x[i];
    sum += 100.0 * a * a + b * b;
  }
  // Busy work standing in for an expensive model; does not change the value.
  double work = sum;
  for (int k = 0; k < heavy_iterations; ++k) {
    work = work * 0.999999 + 1e-9;
    benchmark::DoNotOptimize(work);
  }
  return sum;
}

class Rosenbrock final : public de::Problem {
 public:
  explicit Rosenbrock(int heavy_iterations) : heavy_iterations_(heavy_iterations) {}
  int dimension() const override { return kDimension; }
  Eigen::VectorXd lowerBounds() const override {
    return Eigen::VectorXd::Constant(kDimension, kLower);
  }
  Eigen::VectorXd upperBounds() const override {
    return Eigen::VectorXd::Constant(kDimension, kUpper);
  }
  de::Fitness evaluate(const Eigen::Ref<const Eigen::VectorXd>& x,
                       de::Workspace& /*ws*/) const override {
    return {rosenbrock(x, heavy_iterations_), true};
  }

 private:
  int heavy_iterations_;
};

/// The same function as a pagmo user-defined problem.
struct PagmoRosenbrock {
  int heavy_iterations = 0;
  pagmo::vector_double fitness(const pagmo::vector_double& x) const {
    return {rosenbrock(x, heavy_iterations)};
  }
  std::pair<pagmo::vector_double, pagmo::vector_double> get_bounds() const {
    return {pagmo::vector_double(kDimension, kLower), pagmo::vector_double(kDimension, kUpper)};
  }
};

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

/// One solve per iteration with seeds 1, 2, ...; reports medians of final cost and wall time.
template <typename Solve>
void runSolves(benchmark::State& state, Solve&& solve) {
  std::vector<double> costs;
  std::vector<double> wall_ms;
  std::int64_t evaluations = 0;
  std::uint64_t seed = 1;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const auto [cost, evals] = solve(seed++);
    wall_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
    costs.push_back(cost);
    evaluations = evals;
  }
  state.counters["final_cost"] = median(costs);
  state.counters["wall_ms"] = median(wall_ms);
  state.counters["evaluations"] = static_cast<double>(evaluations);
}

/// Arguments: evaluation budget, heavy iterations per evaluation, threads.
void BM_WjShade(benchmark::State& state) {
  const Rosenbrock problem(static_cast<int>(state.range(1)));
  de::Settings settings;
  settings.population_size = kPopulation;
  settings.strategy = de::Strategy::CurrentToPBest1Bin;
  settings.adaptation = de::Adaptation::SHADE;
  settings.initialization = de::Initialization::Uniform;
  settings.max_generations = 1'000'000;
  settings.max_evaluations = state.range(0);
  settings.threads = static_cast<int>(state.range(2));
  settings.keep_log = false;
  runSolves(state, [&](std::uint64_t seed) {
    settings.seed = seed;
    const de::Result result = de::Solver(settings).solve(problem);
    return std::pair{result.best.cost, result.evaluations};
  });
}

/// Arguments: evaluation budget, heavy iterations per evaluation.
void BM_PagmoSade(benchmark::State& state) {
  const auto budget = static_cast<unsigned>(state.range(0));
  // pagmo evaluates the initial population, then NP trials per generation.
  const unsigned generations = budget / kPopulation - 1;
  runSolves(state, [&](std::uint64_t seed) {
    pagmo::problem problem{PagmoRosenbrock{static_cast<int>(state.range(1))}};
    pagmo::population population{problem, kPopulation, static_cast<unsigned>(seed)};
    // variant 2 (rand/1/exp), adaptation 1 (jDE); ftol = xtol = 0 so that the budget is spent.
    pagmo::algorithm algorithm{
        pagmo::sade(generations, 2u, 1u, 0.0, 0.0, false, static_cast<unsigned>(seed))};
    population = algorithm.evolve(population);
    return std::pair{population.champion_f()[0],
                     static_cast<std::int64_t>(population.get_problem().get_fevals())};
  });
}

constexpr std::int64_t kCheapBudget = 100'000;
constexpr std::int64_t kHeavyBudget = 10'000;
constexpr std::int64_t kHeavyIterations = 8'000;

BENCHMARK(BM_WjShade)
    ->ArgNames({"budget", "heavy", "threads"})
    ->Args({kCheapBudget, 0, 1})
    ->Args({kCheapBudget, 0, 2})
    ->Args({kHeavyBudget, kHeavyIterations, 1})
    ->Args({kHeavyBudget, kHeavyIterations, 2})
    ->Iterations(11)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK(BM_PagmoSade)
    ->ArgNames({"budget", "heavy"})
    ->Args({kCheapBudget, 0})
    ->Args({kHeavyBudget, kHeavyIterations})
    ->Iterations(11)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
