// bench_planner: measures the jump planner in one run and prints JSON (issue targets):
//  - cold solve (DE + polish, no verification) of the three presets at 1 and 2 threads;
//  - a warm-started solve from a neighbouring run-up speed;
//  - the feasibility rate over a grid of run-up speeds (v0 = 0..3 m/s step 0.25, 10 seeds);
//  - pagmo2's de and sade on the same objective with the same evaluation budget and seeds:
//    time to the first feasible candidate and final cost, against our DE.
//  - polish_ab: the polish solvers (polish.solver sqp, ipopt) A/B, interleaved seed by seed: cold
//    solves at 2 threads, and each solver's polish alone from the same DE point (DE without
//    polish).
//  - backflip: the knee peak-torque sweep (42, 47, 52, 57 Nm): cold backflip solves per knee
//    torque, the smallest torque at which a flip is planned (docs/backflip.md).
// Usage: bench_planner [--quick] [--only cold|warm|grid|pagmo|backflip|polish_ab]
//                      [--polish-solver sqp|ipopt] [--actuators FILE] [--config FILE]
//                      > result.json
// --actuators: the actuator file of the robot (models folder), e.g. actuators-57nm.yaml.
// --config: planner settings YAML in place of the defaults (--polish-solver still applies), e.g.
// config/backflip-42nm.yaml for the 42 Nm flip's cold solves (--only backflip).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <pagmo/algorithm.hpp>
#include <pagmo/algorithms/de.hpp>
#include <pagmo/algorithms/sade.hpp>
#include <pagmo/population.hpp>
#include <pagmo/problem.hpp>
#include <string>
#include <thread>
#include <vector>

#include "planner/jump_planner.h"
#include "planner/presets.h"

namespace {

using namespace wj::planner;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

double median(std::vector<double> v) {
  if (v.empty()) return -1.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Records when the first feasible candidate was evaluated (shared between pagmo's copies).
struct Tracker {
  Clock::time_point start = Clock::now();
  std::atomic<long> evaluations{0};
  std::atomic<long> first_feasible_evaluations{-1};
  std::atomic<double> first_feasible_s{-1.0};
  std::atomic<bool> any_feasible{false};
};

// The jump objective as a pagmo user-defined problem (same JumpModel, same cost).
struct PagmoJump {
  std::shared_ptr<const JumpModel> model;
  std::shared_ptr<Tracker> tracker;
  pagmo::vector_double fitness(const pagmo::vector_double& x) const {
    Evaluation ev;
    model->evaluate(Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<long>(x.size())), ev);
    const long n = ++tracker->evaluations;
    if (ev.feasible && !tracker->any_feasible.exchange(true)) {
      tracker->first_feasible_evaluations = n;
      tracker->first_feasible_s =
          std::chrono::duration<double>(Clock::now() - tracker->start).count();
    }
    return {ev.cost};
  }
  std::pair<pagmo::vector_double, pagmo::vector_double> get_bounds() const {
    const auto& lo = model->lowerBounds();
    const auto& hi = model->upperBounds();
    return {{lo.data(), lo.data() + lo.size()}, {hi.data(), hi.data() + hi.size()}};
  }
};

json runPagmo(const std::string& algo, const JumpPlanner& planner, const Scenario& sc,
              unsigned seed, long budget, int pop) {
  auto model =
      std::make_shared<const JumpModel>(planner.robot(), planner.settings(), sc.task, sc.initial);
  auto tracker = std::make_shared<Tracker>();
  pagmo::problem prob{PagmoJump{model, tracker}};
  const unsigned gens = static_cast<unsigned>(std::max<long>(1, budget / pop - 1));
  pagmo::algorithm alg =
      algo == "sade" ? pagmo::algorithm{pagmo::sade(gens, 2u, 1u, 1e-30, 1e-30, false, seed)}
                     : pagmo::algorithm{pagmo::de(gens, 0.8, 0.9, 2u, 1e-30, 1e-30, seed)};
  tracker->start = Clock::now();
  pagmo::population population{prob, static_cast<pagmo::population::size_type>(pop), seed};
  population = alg.evolve(population);
  const double wall = std::chrono::duration<double>(Clock::now() - tracker->start).count();
  return {{"feasible", tracker->any_feasible.load()},
          {"first_feasible_s", tracker->first_feasible_s.load()},
          {"first_feasible_evaluations", tracker->first_feasible_evaluations.load()},
          {"final_cost", population.champion_f()[0]},
          {"evaluations", tracker->evaluations.load()},
          {"wall_s", wall}};
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  std::string only;
  std::string actuators = wj::model::kDefaultActuatorsFile, config;
  PolishSolver solver = PlannerSettings{}.polish_solver;
  bool solver_given = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else if (std::strcmp(argv[i], "--only") == 0 && i + 1 < argc) {
      only = argv[++i];
      if (only != "cold" && only != "warm" && only != "grid" && only != "pagmo" &&
          only != "backflip" && only != "polish_ab") {
        std::cerr << "bench_planner: --only takes cold, warm, grid, pagmo, backflip or polish_ab, "
                     "got '"
                  << only << "'\n";
        return 2;
      }
    } else if (std::strcmp(argv[i], "--actuators") == 0 && i + 1 < argc) {
      actuators = argv[++i];
    } else if (std::strcmp(argv[i], "--config") == 0 && i + 1 < argc) {
      config = argv[++i];
    } else if (std::strcmp(argv[i], "--polish-solver") == 0 && i + 1 < argc) {
      const std::string name = argv[++i];
      if (name != "sqp" && name != "ipopt") {
        std::cerr << "bench_planner: --polish-solver takes sqp or ipopt, got '" << name << "'\n";
        return 2;
      }
      solver = name == "sqp" ? PolishSolver::Sqp : PolishSolver::Ipopt;
      solver_given = true;
    } else {
      std::cerr << "usage: bench_planner [--quick] "
                   "[--only cold|warm|grid|pagmo|backflip|polish_ab] [--polish-solver sqp|ipopt] "
                   "[--actuators FILE] [--config FILE]\n";
      return 2;
    }
  }
  auto part = [&only](const char* name) {
    return only == name || (only.empty() && std::strcmp(name, "polish_ab") != 0);
  };
  const int runs = quick ? 3 : 10;
  const int grid_seeds = quick ? 3 : 10;
  PlannerSettings settings = config.empty() ? PlannerSettings{} : PlannerSettings::fromYaml(config);
  if (solver_given) settings.polish_solver = solver;
  const JumpPlanner planner(wj::model::RobotModel::loadDefault(actuators), settings);
  json out;
  out["actuators_file"] = actuators;
  out["planner_settings_file"] = config.empty() ? json("defaults") : json(config);
  out["polish_solver"] = toString(settings.polish_solver);
  out["machine_threads"] = static_cast<int>(std::thread::hardware_concurrency());
  // libgomp reads it at start-up: spinning (the default) or sleeping at the DE's barriers.
  const char* wait_policy = std::getenv("OMP_WAIT_POLICY");
  out["omp_wait_policy"] = wait_policy ? wait_policy : "unset (libgomp default: spin, then sleep)";

  // 1. Cold solves of the presets.
  for (const auto& name : part("cold") ? presetNames() : std::vector<std::string>{}) {
    const Scenario sc = makePreset(planner, name);
    for (const int threads : {1, 2}) {
      std::vector<double> total, de_ms, polish_ms;
      int feasible = 0;
      for (int s = 1; s <= runs; ++s) {
        PlanOptions o;
        o.seed = static_cast<std::uint64_t>(s);
        o.threads = threads;
        const PlannerResult r = planner.plan(sc.task, sc.initial, o);
        total.push_back(r.total_ms);
        de_ms.push_back(r.de_ms);
        polish_ms.push_back(r.polish_ms);
        feasible += r.evaluation.feasible;
      }
      out["cold_solve"][name][std::to_string(threads) + "_threads"] = {
          {"median_ms", median(total)},
          {"median_de_ms", median(de_ms)},
          {"median_polish_ms", median(polish_ms)},
          {"max_ms", *std::max_element(total.begin(), total.end())},
          {"feasible", feasible},
          {"runs", runs}};
    }
  }

  // 1b. The polish solvers A/B (2 threads), interleaved seed by seed (the order alternates) so
  // that a machine shared with other work loads both alike.
  if (part("polish_ab")) {
    const PolishSolver solvers[2] = {PolishSolver::Sqp, PolishSolver::Ipopt};
    std::vector<JumpPlanner> planners;
    for (const PolishSolver ps : solvers) {
      PlannerSettings s = planner.settings();
      s.polish_solver = ps;
      planners.emplace_back(planner.robot(), s);
    }
    for (const auto& name : presetNames()) {
      const Scenario sc = makePreset(planner, name);
      struct Stats {
        std::vector<double> total, de_ms, polish_ms, cost, iterations, alone_ms, alone_cost,
            alone_iterations;
        int feasible = 0, improved = 0, alone_improved = 0, alone_feasible = 0;
      } st[2];
      for (int seed = 1; seed <= runs; ++seed) {
        PlanOptions o;
        o.seed = static_cast<std::uint64_t>(seed);
        o.threads = 2;
        for (int k = 0; k < 2; ++k) {
          const int j = (seed + k) % 2;
          const PlannerResult r = planners[j].plan(sc.task, sc.initial, o);
          st[j].total.push_back(r.total_ms);
          st[j].de_ms.push_back(r.de_ms);
          st[j].polish_ms.push_back(r.polish_ms);
          st[j].cost.push_back(r.final_cost);
          st[j].iterations.push_back(r.polish_iterations);
          st[j].feasible += r.evaluation.feasible;
          st[j].improved += r.polish == PolishOutcome::Improved;
        }
        // The polish alone, from the DE's best without any polish (same point for both).
        PlanOptions no_polish = o;
        no_polish.polish = false;
        const PlannerResult de_only = planner.plan(sc.task, sc.initial, no_polish);
        const JumpModel model(planner.robot(), planner.settings(), sc.task, sc.initial);
        for (int k = 0; k < 2; ++k) {
          const int j = (seed + k) % 2;
          const JumpModel mj(planner.robot(), planners[j].settings(), sc.task, sc.initial);
          Eigen::VectorXd u;
          int iterations = 0;
          const auto t = Clock::now();
          const PolishOutcome out_j = polishCandidate(mj, de_only.u, u, &iterations);
          st[j].alone_ms.push_back(
              std::chrono::duration<double, std::milli>(Clock::now() - t).count());
          st[j].alone_iterations.push_back(iterations);
          Evaluation ev;
          model.evaluate(u, ev);
          const bool better = out_j != PolishOutcome::Failed && ev.cost < de_only.evaluation.cost &&
                              (ev.feasible || !de_only.evaluation.feasible);
          st[j].alone_improved += better;
          st[j].alone_feasible += better ? ev.feasible : de_only.evaluation.feasible;
          st[j].alone_cost.push_back(better ? ev.cost : de_only.evaluation.cost);
        }
      }
      for (int j = 0; j < 2; ++j)
        out["polish_ab"][name][toString(solvers[j])] = {
            {"median_ms", median(st[j].total)},
            {"median_de_ms", median(st[j].de_ms)},
            {"median_polish_ms", median(st[j].polish_ms)},
            {"median_final_cost", median(st[j].cost)},
            {"median_polish_iterations", median(st[j].iterations)},
            {"feasible", st[j].feasible},
            {"polish_improved", st[j].improved},
            {"polish_alone_median_ms", median(st[j].alone_ms)},
            {"polish_alone_median_iterations", median(st[j].alone_iterations)},
            {"polish_alone_median_cost", median(st[j].alone_cost)},
            {"polish_alone_improved", st[j].alone_improved},
            {"polish_alone_feasible", st[j].alone_feasible},
            {"runs", runs}};
    }
  }

  // 2. Warm start from a neighbouring run-up speed (what the cache does on a miss).
  if (part("warm")) {
    std::vector<double> warm_ms, cold_ms, warm_de_ms, warm_polish_ms, warm_evaluations;
    int feasible = 0, polish_improved = 0, target_met_exactly = 0;
    for (int s = 1; s <= runs; ++s) {
      const Scenario base = makePreset(planner, "forward_hw", 3.0);
      PlanOptions o;
      o.seed = static_cast<std::uint64_t>(s);
      const PlannerResult r0 = planner.plan(base.task, base.initial, o);
      const Scenario next = makePreset(planner, "forward_hw", 3.05);
      o.warm_start = r0.u;
      o.seed = static_cast<std::uint64_t>(100 + s);
      const PlannerResult r1 = planner.plan(next.task, next.initial, o);
      warm_ms.push_back(r1.total_ms);
      warm_de_ms.push_back(r1.de_ms);
      warm_polish_ms.push_back(r1.polish_ms);
      warm_evaluations.push_back(static_cast<double>(r1.de.evaluations));
      cold_ms.push_back(r0.total_ms);
      feasible += r1.evaluation.feasible;
      polish_improved += r1.polish == PolishOutcome::Improved;
      target_met_exactly += std::abs(r1.evaluation.err_dx) < 1e-5;
    }
    out["warm_start"] = {{"task", "forward_hw 3.00 -> 3.05 m/s"},
                         {"median_ms", median(warm_ms)},
                         {"median_de_ms", median(warm_de_ms)},
                         {"median_polish_ms", median(warm_polish_ms)},
                         {"median_evaluations", median(warm_evaluations)},
                         {"polish_improved", polish_improved},
                         {"dx_within_1e-5_m", target_met_exactly},
                         {"cold_median_ms", median(cold_ms)},
                         {"feasible", feasible},
                         {"runs", runs}};
  }

  // 3. Feasibility over a grid of run-up speeds, forward_hw preset (0.12 m obstacle at 1.2 m).
  if (part("grid")) {
    json grid = json::array();
    int counted_runs = 0, counted_feasible = 0;
    for (int k = 0; k <= 12; ++k) {
      const double v0 = 0.25 * k;
      const Scenario sc = makePreset(planner, "forward_hw", v0);
      int feasible = 0;
      for (int s = 1; s <= grid_seeds; ++s) {
        PlanOptions o;
        o.seed = static_cast<std::uint64_t>(s);
        feasible += planner.plan(sc.task, sc.initial, o).evaluation.feasible;
      }
      grid.push_back({{"v0", v0}, {"feasible", feasible}, {"seeds", grid_seeds}});
      if (feasible > 0) {
        counted_runs += grid_seeds;
        counted_feasible += feasible;
      }
    }
    out["grid"] = {{"task", "forward_hw"},
                   {"points", grid},
                   {"rate_where_any_seed_feasible",
                    counted_runs ? static_cast<double>(counted_feasible) / counted_runs : 0.0}};
  }

  // 4. Against pagmo2 at equal evaluation budgets and seeds (DE only, no polish).
  if (part("pagmo")) {
    const long budget = planner.settings().de.max_evaluations;
    const int pop = planner.settings().de.population_size;
    for (const auto& name : presetNames()) {
      const Scenario sc = makePreset(planner, name);
      std::vector<double> ours_first, ours_wall, sade_first, sade_wall, de_first, ours_cost,
          sade_cost, de_cost, full_wall;
      int ours_feasible = 0, sade_feasible = 0, de_feasible = 0;
      for (int s = 1; s <= runs; ++s) {
        PlanOptions o;
        o.seed = static_cast<std::uint64_t>(s);
        o.threads = 2;
        o.polish = false;
        PlannerSettings no_early_stop = planner.settings();
        no_early_stop.de.target_cost = -std::numeric_limits<double>::infinity();
        no_early_stop.de.stagnation_generations = 0;
        no_early_stop.de_restarts = 0;  // one attempt over the whole budget, as pagmo's
        const JumpPlanner full(planner.robot(), no_early_stop);
        const PlannerResult r = full.plan(sc.task, sc.initial, o);
        ours_feasible += r.de.first_feasible_evaluations >= 0;
        if (r.de.first_feasible_s >= 0) ours_first.push_back(r.de.first_feasible_s * 1e3);
        ours_wall.push_back(r.de_ms);
        ours_cost.push_back(r.de_cost);
        // The same run with every trial evaluated in full (no cut-off at the parent's cost).
        PlannerSettings no_cut_off = no_early_stop;
        no_cut_off.de.bounded_trials = false;
        full_wall.push_back(
            JumpPlanner(planner.robot(), no_cut_off).plan(sc.task, sc.initial, o).de_ms);
        const json ps = runPagmo("sade", planner, sc, static_cast<unsigned>(s), budget, pop);
        sade_feasible += ps["feasible"].get<bool>();
        if (ps["feasible"].get<bool>())
          sade_first.push_back(ps["first_feasible_s"].get<double>() * 1e3);
        sade_wall.push_back(ps["wall_s"].get<double>() * 1e3);
        sade_cost.push_back(ps["final_cost"].get<double>());
        const json pd = runPagmo("de", planner, sc, static_cast<unsigned>(s), budget, pop);
        de_feasible += pd["feasible"].get<bool>();
        if (pd["feasible"].get<bool>())
          de_first.push_back(pd["first_feasible_s"].get<double>() * 1e3);
        de_cost.push_back(pd["final_cost"].get<double>());
      }
      out["vs_pagmo"][name] = {
          {"budget_evaluations", budget},
          {"ours_2_threads",
           {{"feasible_runs", ours_feasible},
            {"median_first_feasible_ms", median(ours_first)},
            {"median_wall_ms", median(ours_wall)},
            {"median_final_cost", median(ours_cost)}}},
          {"pagmo_sade",
           {{"feasible_runs", sade_feasible},
            {"median_first_feasible_ms", median(sade_first)},
            {"median_wall_ms", median(sade_wall)},
            {"median_final_cost", median(sade_cost)}}},
          {"pagmo_de",
           {{"feasible_runs", de_feasible},
            {"median_first_feasible_ms", median(de_first)},
            {"median_final_cost", median(de_cost)}}},
          {"ours_2_threads_without_cut_off", {{"median_wall_ms", median(full_wall)}}},
          {"wall_ratio_sade_over_ours", median(sade_wall) / median(ours_wall)},
          {"wall_ratio_sade_over_ours_without_cut_off", median(sade_wall) / median(full_wall)},
          {"runs", runs}};
    }
  }
  // 5. Backflip knee-torque sweep: the smallest knee peak torque at which the planner finds a
  // backflip (paper: 57 Nm in simulation; the robot: 42 Nm), from standing (the paper's) and
  // from rolling backward at 1 m/s (braking pitches the body nose-up). Cold solves with the
  // default settings (flip box and initial guess), every other actuator as in the file.
  if (part("backflip")) {
    json study = json::array();
    const int flip_seeds = quick ? 3 : 10;
    for (const double v0 : {0.0, -1.0})
      for (const double knee_nm : {42.0, 47.0, 52.0, 57.0}) {
        const JumpPlanner strong(planner.robot().withPeakTorque(wj::model::JointKind::KFE, knee_nm),
                                 planner.settings());
        const Scenario sc = makePreset(strong, "backflip", v0);
        std::vector<double> total;
        int feasible = 0;
        json seeds = json::array();
        for (int seed = 1; seed <= flip_seeds; ++seed) {
          PlanOptions o;
          o.seed = static_cast<std::uint64_t>(seed);
          o.threads = 2;
          const PlannerResult r = strong.plan(sc.task, sc.initial, o);
          total.push_back(r.total_ms);
          feasible += r.evaluation.feasible;
          json binding = json::array();
          for (const auto c : r.binding) binding.push_back(toString(c));
          seeds.push_back(
              {{"seed", seed},
               {"feasible", r.evaluation.feasible},
               {"solve_ms", r.total_ms},
               {"touchdown_pitch_rad", r.evaluation.predicted.touchdown.state.pitch},
               {"touchdown_dx_m", r.evaluation.predicted.touchdown.state.x},
               {"apex_base_z_m", r.evaluation.predicted.apex.base_z},
               {"takeoff_pitch_rad", r.evaluation.predicted.takeoff.state.pitch},
               {"takeoff_pitch_rate_rad_s", r.evaluation.predicted.takeoff.state.pitch_rate},
               {"max_abs_torque_nm",
                {{"hfe", r.evaluation.max_abs_torque_nm[1]},
                 {"kfe", r.evaluation.max_abs_torque_nm[2]}}},
               {"binding", binding}});
        }
        study.push_back({{"knee_peak_torque_nm", knee_nm},
                         {"v0_m_s", v0},
                         {"feasible", feasible},
                         {"runs", flip_seeds},
                         {"median_solve_ms_2_threads", median(total)},
                         {"seeds", seeds}});
      }
    out["backflip_knee_torque_sweep"] = study;
  }
  std::cout << out.dump(2) << std::endl;
  return 0;
}
