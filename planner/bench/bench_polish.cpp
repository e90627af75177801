// Micro-benchmarks of the two inner costs of a cold solve, per preset (Google Benchmark):
//   BM_Evaluate  one JumpModel::evaluate of a DE candidate (no cut-off), what every DE trial
//                costs on one thread;
//   BM_Polish    the polish alone, from the DE's best of a seed (no polish in the DE run), with
//                the solver of `polish.solver` (arg 1: 0 = sqp, 1 = ipopt) and the goal the
//                planner gives it (closest_approach for a best that meets every constraint
//                and misses the target, else meet_target).
// The DE points are computed once per preset (seeds 1..5, 2 threads) before timing; each
// benchmark iteration takes the next seed's point, so a run of 10 iterations covers every seed
// twice. Counters: median wall time of one call (eval_us / polish_ms) and, for the polish, the
// median iterations.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <string>
#include <vector>

#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"

namespace {

using namespace wj::planner;
using Clock = std::chrono::steady_clock;

constexpr int kSeeds = 5;

const JumpPlanner& planner() {
  static const JumpPlanner p(wj::model::RobotModel::loadDefault(), PlannerSettings{});
  return p;
}

/// The DE's best of seeds 1..kSeeds without polish, per preset (computed on first use).
const std::vector<Eigen::VectorXd>& dePoints(const std::string& preset) {
  static std::map<std::string, std::vector<Eigen::VectorXd>> cache;
  auto it = cache.find(preset);
  if (it != cache.end()) return it->second;
  const Scenario sc = makePreset(planner(), preset);
  std::vector<Eigen::VectorXd> points;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    PlanOptions o;
    o.seed = static_cast<std::uint64_t>(seed);
    o.threads = 2;
    o.polish = false;
    points.push_back(planner().plan(sc.task, sc.initial, o).u);
  }
  return cache.emplace(preset, std::move(points)).first->second;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

const std::vector<std::string>& presets() {
  static const std::vector<std::string> names = presetNames();
  return names;
}

/// Arg 0: preset index in presetNames().
void BM_Evaluate(benchmark::State& state) {
  const std::string& preset = presets()[static_cast<std::size_t>(state.range(0))];
  const auto& points = dePoints(preset);
  const Scenario sc = makePreset(planner(), preset);
  const JumpModel model(planner().robot(), planner().settings(), sc.task, sc.initial);
  Evaluation ev;
  std::size_t k = 0;
  for (auto _ : state) {
    model.evaluate(points[k++ % points.size()], ev);
    benchmark::DoNotOptimize(ev.cost);
  }
  state.SetLabel(preset);
}

/// Arg 0: preset index; arg 1: 0 = sqp, 1 = ipopt; arg 2: threads sharing the Jacobians.
/// Counters: median polish time, iterations, and cost of the polished point (its evaluation is
/// not timed; the planner keeps the point only if that cost is lower than the DE's).
void BM_Polish(benchmark::State& state) {
  const std::string& preset = presets()[static_cast<std::size_t>(state.range(0))];
  const auto& points = dePoints(preset);
  PlannerSettings s = planner().settings();
  s.polish_solver = state.range(1) == 0 ? PolishSolver::Sqp : PolishSolver::Ipopt;
  const Scenario sc = makePreset(planner(), preset);
  const JumpModel model(planner().robot(), s, sc.task, sc.initial);
  std::vector<PolishGoal> goals;
  for (const auto& x : points) {
    Evaluation ev;
    model.evaluate(x, ev);
    goals.push_back(polishGoalFor(ev));
  }
  const int threads = static_cast<int>(state.range(2));
  std::vector<double> ms, iterations, costs;
  std::size_t k = 0;
  for (auto _ : state) {
    Eigen::VectorXd u;
    int it = 0;
    const std::size_t j = k++ % points.size();
    const auto t0 = Clock::now();
    benchmark::DoNotOptimize(polishCandidate(model, points[j], u, &it, 0, goals[j], threads));
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    iterations.push_back(it);
    state.PauseTiming();
    Evaluation ev;
    model.evaluate(u, ev);
    costs.push_back(ev.cost);
    state.ResumeTiming();
  }
  state.counters["polish_ms"] = median(ms);
  state.counters["iterations"] = median(iterations);
  state.counters["cost"] = median(costs);
  state.SetLabel(preset + (state.range(1) == 0 ? " sqp " : " ipopt ") + std::to_string(threads) +
                 (threads == 1 ? " thread" : " threads"));
}

BENCHMARK(BM_Evaluate)->DenseRange(0, 3)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Polish)
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1}, {1, 2}})
    ->Iterations(10)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
