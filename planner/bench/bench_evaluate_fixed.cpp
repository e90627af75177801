// The cost of JumpModel::evaluate on a fixed set of decision vectors, so that two builds of the
// planner (before and after a model change) are compared on the same points, not on the
// different candidates their own DE runs would try (issue 22: "DE cost per evaluation").
//
//   bench_evaluate_fixed write <preset> <file> [count]   the points: the DE's best of seeds
//       1..5 (2 threads, no polish) and, around each, count / 5 perturbed copies (Gaussian,
//       0.5 to 20 % of the search box's width, clipped to the box; std::mt19937_64 seed 1), a
//       mix of candidates that are cut off early and ones that reach the cost, as in a DE run;
//   bench_evaluate_fixed read <preset> <file> [repeats]  evaluates every point `repeats` times
//       (default 5) and prints one JSON line: the median wall time per evaluation over the
//       repeats, how many points were valid and feasible, and the sum of their costs (equal
//       between builds whose models agree).
//
// WJ_BENCH_PLANNER_SETTINGS=<yaml>: the planner's settings from that file in place of the
// defaults (a model option's cost on the same points, e.g. physics.tyre_contact_modulus_pa).
//
// For instruction counts, run `read` under callgrind with
// --toggle-collect='wj::planner::JumpModel::evaluate*' and divide by points x repeats
// (scripts/bench-evaluate-fixed.sh).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"

namespace {

using namespace wj::planner;

int usage() {
  std::cerr << "usage: bench_evaluate_fixed write <preset> <file> [count]\n"
               "       bench_evaluate_fixed read <preset> <file> [repeats]\n";
  return 2;
}

int write(const JumpPlanner& planner, const Scenario& sc, const std::string& file, int count) {
  const JumpModel model(planner.robot(), planner.settings(), sc.task, sc.initial);
  const Eigen::VectorXd lo = model.lowerBounds(), hi = model.upperBounds();
  std::mt19937_64 rng(1);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> scale(0.005, 0.2);
  std::ofstream out(file);
  if (!out) {
    std::cerr << "bench_evaluate_fixed: cannot write " << file << "\n";
    return 1;
  }
  out.precision(17);
  constexpr int kSeeds = 5;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    PlanOptions o;
    o.seed = static_cast<std::uint64_t>(seed);
    o.threads = 2;
    o.polish = false;
    const Eigen::VectorXd best = planner.plan(sc.task, sc.initial, o).u;
    for (int i = 0; i < count / kSeeds; ++i) {
      Eigen::VectorXd u = best;
      const double s = i == 0 ? 0.0 : scale(rng);
      for (Eigen::Index d = 0; d < u.size(); ++d)
        u[d] = std::clamp(u[d] + s * (hi[d] - lo[d]) * normal(rng), lo[d], hi[d]);
      for (Eigen::Index d = 0; d < u.size(); ++d) out << (d ? " " : "") << u[d];
      out << "\n";
    }
  }
  return 0;
}

int read(const JumpPlanner& planner, const Scenario& sc, const std::string& preset,
         const std::string& file, int repeats) {
  const JumpModel model(planner.robot(), planner.settings(), sc.task, sc.initial);
  std::ifstream in(file);
  if (!in) {
    std::cerr << "bench_evaluate_fixed: cannot read " << file << "\n";
    return 1;
  }
  std::vector<Eigen::VectorXd> points;
  for (std::string line; std::getline(in, line);) {
    std::istringstream ss(line);
    std::vector<double> v;
    for (double x; ss >> x;) v.push_back(x);
    if (v.empty()) continue;
    if (static_cast<int>(v.size()) != model.dimension()) {
      std::cerr << "bench_evaluate_fixed: a point of " << v.size() << " values, the model has "
                << model.dimension() << "\n";
      return 1;
    }
    points.push_back(
        Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  }
  Evaluation ev;
  int valid = 0, feasible = 0;
  double cost_sum = 0.0;
  std::vector<double> us;
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    for (const Eigen::VectorXd& u : points) {
      model.evaluate(u, ev);
      if (r == 0) {
        valid += ev.valid ? 1 : 0;
        feasible += ev.feasible ? 1 : 0;
        if (ev.valid) cost_sum += ev.cost;
      }
    }
    const std::chrono::duration<double, std::micro> d = std::chrono::steady_clock::now() - start;
    us.push_back(d.count() / static_cast<double>(points.size()));
  }
  std::sort(us.begin(), us.end());
  std::printf(
      "{\"preset\": \"%s\", \"points\": %zu, \"repeats\": %d, \"us_per_eval_median\": %.3f, "
      "\"valid\": %d, \"feasible\": %d, \"cost_sum\": %.9g}\n",
      preset.c_str(), points.size(), repeats, us[us.size() / 2], valid, feasible, cost_sum);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) return usage();
  const std::string mode = argv[1], preset = argv[2], file = argv[3];
  try {
    const char* settings_file = std::getenv("WJ_BENCH_PLANNER_SETTINGS");
    const JumpPlanner planner(
        wj::model::RobotModel::loadDefault(),
        settings_file ? PlannerSettings::fromYaml(settings_file) : PlannerSettings{});
    const Scenario sc = makePreset(planner, preset);
    if (mode == "write") return write(planner, sc, file, argc > 4 ? std::stoi(argv[4]) : 1000);
    if (mode == "read") return read(planner, sc, preset, file, argc > 4 ? std::stoi(argv[4]) : 5);
  } catch (const std::exception& e) {
    std::cerr << "bench_evaluate_fixed: " << e.what() << "\n";
    return 1;
  }
  return usage();
}
