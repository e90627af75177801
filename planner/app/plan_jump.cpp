// plan_jump: plans one jump with the DE + polish planner and prints the result (text or JSON).
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "planner/jump_planner.h"
#include "planner/plan_report.h"
#include "planner/presets.h"

namespace {

std::vector<double> parseList(const std::string& text, std::size_t n, const std::string& flag) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw std::invalid_argument(flag + ": '" + item + "' is not a number");
    }
  }
  if (v.size() != n)
    throw std::invalid_argument(flag + " takes " + std::to_string(n) + " comma-separated numbers");
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace wj::planner;
  CLI::App app{"Plans a jump of the wheeled-legged robot (DE over a planar rigid body + polish)."};
  std::string task_name, target_text, event_text = "apex", obstacle_text, config, mode_text;
  std::string actuators = wj::model::kDefaultActuatorsFile;
  std::optional<double> v0;
  std::uint64_t seed = 1;
  int threads = 2;
  std::optional<std::int64_t> max_evals;
  bool json = false, no_polish = false, log = false;
  auto* task_opt =
      app.add_option("--task", task_name, "preset: forward | forward_hw | vertical | backflip");
  auto* target_opt =
      app.add_option("--target", target_text, "custom target dx,z,pitch [m, m, rad] of the CoM");
  app.add_option("--event", event_text, "what --target describes: apex | touchdown")
      ->needs(target_opt);
  // A preset carries its own target: a --target beside it would be ignored, so it is refused.
  task_opt->excludes(target_opt);
  app.add_option("--mode", mode_text, "take-off: simultaneous | two-step (default per preset)");
  app.add_option("--v0", v0, "run-up speed [m/s]");
  app.add_option("--obstacle", obstacle_text, "box obstacle x0,x1,height [m]");
  app.add_option("--seed", seed, "DE seed");
  app.add_option("--threads", threads, "DE evaluation threads")->check(CLI::Range(1, 64));
  app.add_option("--max-evals", max_evals, "DE evaluation budget")
      ->check(CLI::Range(100, 10000000));
  app.add_option("--config", config, "planner settings YAML (defaults if omitted)");
  app.add_option("--actuators", actuators,
                 "actuator file in the models folder (or a path), e.g. actuators-57nm.yaml");
  app.add_flag("--no-polish", no_polish, "skip the polish (polish.solver: sqp or ipopt)");
  app.add_flag("--json", json, "print JSON");
  app.add_flag("--log", log, "add the DE's per-generation log (last attempt) to the output");
  CLI11_PARSE(app, argc, argv);

  try {
    PlannerSettings settings =
        config.empty() ? PlannerSettings{} : PlannerSettings::fromYaml(config);
    const JumpPlanner planner(wj::model::RobotModel::loadDefault(actuators), settings);
    Scenario sc;
    if (!task_name.empty()) {
      sc = makePreset(planner, task_name, v0);
    } else if (!target_text.empty()) {
      const auto t = parseList(target_text, 3, "--target");
      sc.name = "custom";
      sc.initial.q = planner.standPosture();
      sc.initial.v0 = v0.value_or(0.0);
      if (event_text != "apex" && event_text != "touchdown")
        throw std::invalid_argument("--event must be apex or touchdown, got '" + event_text + "'");
      sc.task.target = {t[0], t[1], t[2],
                        event_text == "apex" ? TargetEvent::Apex : TargetEvent::Touchdown};
    } else {
      throw std::invalid_argument("give --task or --target");
    }
    if (!obstacle_text.empty()) {
      const auto o = parseList(obstacle_text, 3, "--obstacle");
      sc.task.obstacle = BoxObstacle{o[0], o[1], o[2]};
    }
    if (!mode_text.empty()) {
      if (mode_text != "simultaneous" && mode_text != "two-step")
        throw std::invalid_argument("--mode must be simultaneous or two-step, got '" + mode_text +
                                    "'");
      sc.task.mode = mode_text == "two-step" ? TakeoffMode::TwoStep : TakeoffMode::Simultaneous;
    }
    PlanOptions opts;
    opts.seed = seed;
    opts.threads = threads;
    if (no_polish) opts.polish = false;
    if (max_evals) opts.max_evaluations = *max_evals;
    const PlannerResult r = planner.plan(sc.task, sc.initial, opts);
    nlohmann::json j = reportJson(sc, r);
    if (log) {
      nlohmann::json rows = nlohmann::json::array();
      for (const auto& g : r.de.log)
        rows.push_back({{"generation", g.generation},
                        {"evaluations", g.evaluations},
                        {"best_cost", g.best_cost},
                        {"mean_cost", g.mean_cost},
                        {"best_feasible", g.best_feasible},
                        {"mean_F", g.mean_F},
                        {"mean_CR", g.mean_CR},
                        {"elapsed_ms", 1e3 * g.elapsed_s}});
      j["log"] = std::move(rows);
    }
    if (json) {
      std::cout << j.dump(2) << "\n";
    } else {
      std::cout << reportText(sc, r);
      if (log) {
        std::cout << "  generation  evaluations     best cost     mean cost  feasible  F     CR\n";
        for (const auto& g : r.de.log) {
          char line[160];
          std::snprintf(line, sizeof line, "  %10d  %11lld  %12.6g  %12.6g  %-8s  %.2f  %.2f\n",
                        g.generation, static_cast<long long>(g.evaluations), g.best_cost,
                        g.mean_cost, g.best_feasible ? "yes" : "no", g.mean_F, g.mean_CR);
          std::cout << line;
        }
      }
    }
    return r.evaluation.feasible ? 0 : 3;
  } catch (const std::exception& e) {
    std::cerr << "plan_jump: " << e.what() << "\n";
    return 2;
  }
}
