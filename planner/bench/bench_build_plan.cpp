// The cost of JumpModel::buildPlan (the dense references of a plan: every cold plan and every
// regenerated cache hit builds one) on a fixed decision vector, so that two builds of the
// planner are compared on the same plan, and the torques they export.
//
//   bench_build_plan write <preset> <file>   the decision vector of the preset's plan (seed 1,
//       2 threads, with the polish), one line;
//   bench_build_plan read <preset> <file> [repeats] [tau_file]   builds the plan `repeats` times
//       (default 20), then its knots (buildKnots) as often, and prints one JSON line: the median
//       wall time per build of each, the rows and knots, and the sums of their torques' absolute
//       values (equal between builds that export the same torques); with `tau_file`, also
//       writes the dense torques (one row per line, t then the 16 joints, %.17g), so that two
//       builds' rows can be compared joint by joint.
//
// For instruction counts, run `read` with repeats 1 under callgrind with
// --toggle-collect='wj::planner::JumpModel::buildPlan*' (or buildKnots*; docs/planner.md,
// "Stance torques").
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"

namespace {

using namespace wj::planner;

int usage() {
  std::cerr << "usage: bench_build_plan write <preset> <file>\n"
               "       bench_build_plan read <preset> <file> [repeats] [tau_file]\n";
  return 2;
}

int write(const JumpPlanner& planner, const Scenario& sc, const std::string& file) {
  PlanOptions o;
  o.seed = 1;
  o.threads = 2;
  const Eigen::VectorXd u = planner.plan(sc.task, sc.initial, o).u;
  std::ofstream out(file);
  if (!out) {
    std::cerr << "bench_build_plan: cannot write " << file << "\n";
    return 1;
  }
  out.precision(17);
  for (Eigen::Index d = 0; d < u.size(); ++d) out << (d ? " " : "") << u[d];
  out << "\n";
  return 0;
}

int read(const JumpPlanner& planner, const Scenario& sc, const std::string& preset,
         const std::string& file, int repeats, const std::string& tau_file) {
  const JumpModel model(planner.robot(), planner.settings(), sc.task, sc.initial);
  std::ifstream in(file);
  std::vector<double> v;
  for (double x; in >> x;) v.push_back(x);
  if (static_cast<int>(v.size()) != model.dimension()) {
    std::cerr << "bench_build_plan: " << file << " holds " << v.size() << " values, the model has "
              << model.dimension() << "\n";
    return 1;
  }
  const Eigen::VectorXd u =
      Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
  // The evaluation, as the service passes its own (buildPlan then does not evaluate again).
  Evaluation ev;
  model.evaluate(u, ev);
  // `repeats` calls of build, their wall times sorted [us], the last call's plan in `out`.
  const auto timed = [&](auto build, JumpPlan& out) {
    std::vector<double> times;
    for (int r = 0; r < repeats; ++r) {
      const auto start = std::chrono::steady_clock::now();
      out = build();
      const std::chrono::duration<double, std::micro> d = std::chrono::steady_clock::now() - start;
      times.push_back(d.count());
    }
    std::sort(times.begin(), times.end());
    return times;
  };
  JumpPlan plan, knots;
  const std::vector<double> us = timed([&] { return model.buildPlan(u, &ev); }, plan);
  const std::vector<double> knots_us = timed([&] { return model.buildKnots(u, &ev); }, knots);
  if (!tau_file.empty()) {
    std::FILE* f = std::fopen(tau_file.c_str(), "w");
    if (f == nullptr) {
      std::cerr << "bench_build_plan: cannot write " << tau_file << "\n";
      return 1;
    }
    for (int k = 0; k < plan.numSamples(); ++k) {
      std::fprintf(f, "%.17g", k * plan.dt);
      for (Eigen::Index j = 0; j < plan.tau.cols(); ++j) std::fprintf(f, " %.17g", plan.tau(k, j));
      std::fprintf(f, "\n");
    }
    std::fclose(f);
  }
  std::printf(
      "{\"preset\": \"%s\", \"rows\": %d, \"t1_s\": %.4f, \"t2_s\": %.4f, \"repeats\": %d, "
      "\"us_per_build_median\": %.1f, \"tau_abs_sum\": %.12g, \"knots\": %d, "
      "\"us_per_knots_median\": %.1f, \"knots_tau_abs_sum\": %.12g}\n",
      preset.c_str(), plan.numSamples(), plan.t1, plan.t2, repeats, us[us.size() / 2],
      plan.tau.cwiseAbs().sum(), knots.knots.size(), knots_us[knots_us.size() / 2],
      knots.knots.tau.cwiseAbs().sum());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) return usage();
  const std::string mode = argv[1], preset = argv[2], file = argv[3];
  try {
    const JumpPlanner planner(wj::model::RobotModel::loadDefault(), PlannerSettings{});
    const Scenario sc = makePreset(planner, preset);
    if (mode == "write") return write(planner, sc, file);
    if (mode == "read") {
      const int repeats = argc > 4 ? std::stoi(argv[4]) : 20;
      if (repeats < 1) {
        std::cerr << "bench_build_plan: repeats must be at least 1, got " << repeats << "\n";
        return 2;
      }
      return read(planner, sc, preset, file, repeats, argc > 5 ? argv[5] : "");
    }
  } catch (const std::exception& e) {
    std::cerr << "bench_build_plan: " << e.what() << "\n";
    return 1;
  }
  return usage();
}
