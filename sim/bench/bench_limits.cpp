// bench_limits: what limits the robot's jumps, planned and executed in Simbody (docs/limits.md).
//  - paper_gap: the paper (Zeng et al., Sec. V-B) planned a 0.7 m vertical jump with drives
//    modelled as a constant 42 Nm up to 40 rad/s, and its hardware reached 0.5 m; it blamed the
//    motors' torque-speed trade-off. The vertical preset is planned the paper's way
//    (physics.actuator_model: constant_torque) and this project's way (the envelope), and each
//    plan is executed in Simbody (sim::Verifier), whose drives always saturate on the envelope:
//    the apex each plan promises against the apex the simulation reaches.
//  - relax: the vertical preset's highest apex (the planner's closest approach to 0.7 m) with
//    each limit relaxed in turn (knee range, envelope, peak torque, friction, crouch depth),
//    and the classes that bind.
//  - platform: the highest platform the robot lands on from a 3 m/s run-up and from standing:
//    the platform preset at increasing heights, planned and executed in Simbody.
// Prints one JSON document on stdout and a Markdown table per part on stderr.
// Usage: bench_limits [--only paper_gap|relax|platform] [--seeds N] [--threads N]
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "sim/verifier.h"

namespace {

namespace pl = wj::planner;
namespace sm = wj::sim;
using nlohmann::json;

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

json names(const std::vector<pl::ConstraintClass>& classes) {
  json out = json::array();
  for (const pl::ConstraintClass c : classes) out.push_back(pl::toString(c));
  return out;
}

// One plan of `sc` and, if it has a trajectory, its execution in Simbody.
struct Run {
  pl::PlannerResult plan;
  sm::VerificationReport sim;
  bool valid = false;
};

Run planAndVerify(const pl::JumpPlanner& planner, const sm::Verifier& verifier,
                  const pl::Scenario& sc, int seed, int threads) {
  Run run;
  pl::PlanOptions o;
  o.seed = static_cast<std::uint64_t>(seed);
  o.threads = threads;
  run.plan = planner.plan(sc.task, sc.initial, o);
  run.valid = run.plan.evaluation.valid;
  if (run.valid) run.sim = verifier.verify(run.plan.plan, sm::scenarioForTask(sc.task));
  return run;
}

json runJson(const Run& r, int seed) {
  if (!r.valid) return {{"seed", seed}, {"valid", false}};
  json failures = json::array();
  for (const sm::FailureReason f : r.sim.failures.toVector()) failures.push_back(sm::toString(f));
  const pl::Evaluation& ev = r.plan.evaluation;
  return {{"seed", seed},
          {"valid", true},
          {"feasible", ev.feasible},
          {"constraints_ok", ev.constraints_ok},
          {"binding", names(r.plan.binding)},
          {"planned_base_apex_m", ev.predicted.apex.base_z},
          {"planned_com_apex_m", ev.predicted.apex.state.z},
          {"planned_touchdown_dx_m", ev.predicted.touchdown.state.x},
          {"planned_max_kfe_torque_nm", ev.max_abs_torque_nm[2]},
          {"planned_max_kfe_speed_rad_s", ev.max_abs_speed_rad_s[2]},
          {"simulated_base_apex_m", r.sim.max_base_z_m},
          {"simulated_com_apex_m", r.sim.measured.apex.state.z},
          {"simulated_touchdown_dx_m", r.sim.measured.touchdown.state.x},
          {"simulated_max_envelope_ratio", r.sim.max_envelope_ratio},
          {"landed_upright", r.sim.landed_upright},
          {"final_base_height_m", r.sim.final_base_height_m},
          {"passed", r.sim.passed},
          {"failures", failures}};
}

// The paper's gap: the same task planned with and without the envelope, both executed on it.
json paperGap(const wj::model::RobotModel& robot, const sm::Verifier& verifier, int seeds,
              int threads) {
  json out;
  const pl::ActuatorModel models[2] = {pl::ActuatorModel::ConstantTorque,
                                       pl::ActuatorModel::Envelope};
  const char* labels[2] = {"paper", "envelope"};
  std::fprintf(stderr,
               "\npaper_gap (vertical preset, target base apex 0.7 m, medians of %d seeds)\n\n"
               "| plan | planned base apex | simulated base apex | shortfall | simulated demand / "
               "envelope | verified |\n| --- | --- | --- | --- | --- | --- |\n",
               seeds);
  for (int k = 0; k < 2; ++k) {
    pl::PlannerSettings s;
    s.actuator_model = models[k];
    const pl::JumpPlanner planner(robot, s);
    const pl::Scenario sc = pl::makePreset(planner, "vertical");
    std::vector<double> planned, simulated, ratio;
    int passed = 0;
    json runs = json::array();
    for (int seed = 1; seed <= seeds; ++seed) {
      const Run r = planAndVerify(planner, verifier, sc, seed, threads);
      runs.push_back(runJson(r, seed));
      if (!r.valid) continue;
      planned.push_back(r.plan.evaluation.predicted.apex.base_z);
      simulated.push_back(r.sim.max_base_z_m);
      ratio.push_back(r.sim.max_envelope_ratio);
      passed += r.sim.passed;
    }
    out[labels[k]] = {{"actuator_model", pl::toString(models[k])},
                      {"runs", runs},
                      {"median_planned_base_apex_m", median(planned)},
                      {"median_simulated_base_apex_m", median(simulated)},
                      {"median_shortfall_m", median(planned) - median(simulated)},
                      {"median_simulated_envelope_ratio", median(ratio)},
                      {"verification_passed", passed}};
    std::fprintf(stderr, "| %s | %.3f m | %.3f m | %.3f m | %.2f | %d/%d |\n",
                 k == 0 ? "paper: 42 Nm at any speed up to 40 rad/s" : "this project: envelope",
                 median(planned), median(simulated), median(planned) - median(simulated),
                 median(ratio), passed, static_cast<int>(planned.size()));
  }
  return out;
}

// The robot model with the knee's range moved to [kfe_lower_rad, kfe_upper_rad]: the URDF text
// with that one limit changed, loaded from a temporary copy.
wj::model::RobotModel withKneeRange(double kfe_lower_rad, double kfe_upper_rad) {
  const std::filesystem::path dir = wj::model::RobotModel::defaultModelsDir();
  std::ifstream in(dir / "wheeljump.urdf");
  std::stringstream text;
  text << in.rdbuf();
  std::string urdf = text.str();
  const std::string from = "lower=\"-2.7\" upper=\"-0.5\"";
  std::ostringstream to;
  to << "lower=\"" << kfe_lower_rad << "\" upper=\"" << kfe_upper_rad << "\"";
  int replaced = 0;
  for (std::size_t pos = urdf.find(from); pos != std::string::npos; pos = urdf.find(from, pos)) {
    urdf.replace(pos, from.size(), to.str());
    ++replaced;
  }
  if (replaced != 4) throw std::runtime_error("the URDF's knee limits are not the expected ones");
  const std::filesystem::path tmp =
      std::filesystem::temp_directory_path() / "bench_limits_knee.urdf";
  std::ofstream(tmp) << urdf;
  auto model = wj::model::RobotModel::load(tmp, dir / "actuators.yaml");
  std::filesystem::remove(tmp);
  return model;
}

// Where a class's worst margin is: a joint's name, or the model's location code.
std::string whereOf(const wj::model::RobotModel& robot, const pl::Evaluation& ev,
                    pl::ConstraintClass c) {
  const int loc = ev.margins[static_cast<int>(c)].location;
  if (loc >= 0 && loc < wj::model::kNumJoints) return robot.joints()[loc].name;
  return std::to_string(loc);
}

// The vertical preset's highest apex with each limit relaxed in turn (planner only).
json relax(const wj::model::RobotModel& robot, int seeds, int threads) {
  struct Case {
    std::string name;
    std::string change;
    pl::PlannerSettings settings;
    const wj::model::RobotModel* robot;
  };
  const wj::model::RobotModel knee_flexed = withKneeRange(-2.9, -0.5);
  const wj::model::RobotModel knee_straight = withKneeRange(-2.7, -0.3);
  std::vector<Case> cases;
  cases.push_back({"baseline", "as shipped", {}, &robot});
  cases.push_back(
      {"knee_range_flexed", "knee lower limit -2.7 -> -2.9 rad (deeper)", {}, &knee_flexed});
  cases.push_back({"knee_range_straight",
                   "knee upper limit -0.5 -> -0.3 rad (straighter)",
                   {},
                   &knee_straight});
  {
    Case c{"envelope", "no torque-speed envelope (42 Nm up to 40 rad/s)", {}, &robot};
    c.settings.actuator_model = pl::ActuatorModel::ConstantTorque;
    cases.push_back(c);
  }
  {
    Case c{"peak_torque", "peak torque x1.1 (46.2 Nm), envelope kept", {}, &robot};
    c.settings.actuator_torque_scale = 1.1;
    cases.push_back(c);
  }
  {
    Case c{"friction", "friction mu 0.7 -> 1.0", {}, &robot};
    c.settings.friction_mu = 1.0;
    cases.push_back(c);
  }
  {
    Case c{"crouch", "deeper take-off crouch HFE 1.0/KFE -2.0 -> 1.2/-2.4 rad", {}, &robot};
    c.settings.stand_hfe_rad = 1.2;
    c.settings.stand_kfe_rad = -2.4;
    cases.push_back(c);
  }
  json out = json::array();
  std::fprintf(stderr,
               "\nrelax (vertical preset's highest base apex, planner's closest approach to 0.7 m, "
               "median of %d seeds)\n\n| limit relaxed | change | planned base apex | gain | "
               "binding (seed 1) |\n| --- | --- | --- | --- | --- |\n",
               seeds);
  double base = 0.0;
  for (const Case& c : cases) {
    const pl::JumpPlanner planner(*c.robot, c.settings);
    const pl::Scenario sc = pl::makePreset(planner, "vertical");
    std::vector<double> apex;
    json binding, runs = json::array();
    for (int seed = 1; seed <= seeds; ++seed) {
      pl::PlanOptions o;
      o.seed = static_cast<std::uint64_t>(seed);
      o.threads = threads;
      const pl::PlannerResult r = planner.plan(sc.task, sc.initial, o);
      if (seed == 1) binding = names(r.binding);
      const bool ok = r.evaluation.valid && r.evaluation.constraints_ok;
      if (ok) apex.push_back(r.evaluation.predicted.apex.base_z);
      const pl::ClassMargin& jp =
          r.evaluation.margins[static_cast<int>(pl::ConstraintClass::JointPosition)];
      runs.push_back({{"seed", seed},
                      {"constraints_ok", ok},
                      {"planned_base_apex_m", r.evaluation.predicted.apex.base_z},
                      {"binding", names(r.binding)},
                      {"joint_position_margin_rad", jp.worst},
                      {"joint_position_at_s", jp.t},
                      {"joint_position_where",
                       whereOf(*c.robot, r.evaluation, pl::ConstraintClass::JointPosition)},
                      {"takeoff_s", r.evaluation.predicted.takeoff.t}});
    }
    const double m = median(apex);
    if (c.name == "baseline") base = m;
    out.push_back({{"limit", c.name},
                   {"change", c.change},
                   {"median_planned_base_apex_m", m},
                   {"gain_m", m - base},
                   {"runs", runs}});
    std::string b;
    for (const auto& n : binding) b += (b.empty() ? "" : ", ") + n.get<std::string>();
    std::fprintf(stderr, "| %s | %s | %.3f m | %+.3f m | %s |\n", c.name.c_str(), c.change.c_str(),
                 m, m - base, b.c_str());
  }
  return out;
}

// The platform preset at increasing heights, from the 3 m/s run-up and from standing.
json platform(const wj::model::RobotModel& robot, const sm::Verifier& verifier, int seeds,
              int threads) {
  const pl::JumpPlanner planner(robot, pl::PlannerSettings{});
  json out;
  std::fprintf(stderr,
               "\nplatform (highest platform landed on; a height counts when a seed's plan is "
               "feasible and Simbody passes it)\n\n| start | height | feasible plans | passed in "
               "Simbody | planned / simulated touchdown dx (seed 1) |\n| --- | --- | --- | --- | "
               "--- |\n");
  struct Start {
    const char* name;
    double v0, x_min, dx;
  };
  // From the run-up the platform preset's geometry; from standing, the near face 0.7 m ahead
  // (0.5 and 0.6 m: no plan onto 0.1 m), the CoM landing 1.1 m ahead.
  for (const Start st : {Start{"run_up_3m_s", 3.0, 1.6, 2.0}, Start{"standing", 0.0, 0.7, 1.1}}) {
    double highest = 0.0;
    json rows = json::array();
    for (int k = 1; k <= 12; ++k) {
      const double h = 0.05 * k;
      pl::Scenario sc = pl::makePreset(planner, "platform", st.v0);
      // The preset's touchdown height above the top (standing + the hind wheels' drop).
      const double above_top = sc.task.target.height - pl::kPlatformHeight;
      sc.task.obstacle = pl::BoxObstacle{st.x_min, st.x_min + pl::kPlatformLength, h};
      sc.task.target.height = above_top + h;
      sc.task.target.dx = st.dx;
      int feasible = 0, passed = 0;
      json runs = json::array();
      double planned_dx = 0.0, simulated_dx = 0.0;
      for (int seed = 1; seed <= seeds; ++seed) {
        const Run r = planAndVerify(planner, verifier, sc, seed, threads);
        runs.push_back(runJson(r, seed));
        if (!r.valid) continue;
        if (seed == 1) {
          planned_dx = r.plan.evaluation.predicted.touchdown.state.x;
          simulated_dx = r.sim.measured.touchdown.state.x;
        }
        feasible += r.plan.evaluation.feasible;
        passed += r.plan.evaluation.feasible && r.sim.passed;
      }
      if (passed > 0) highest = h;
      rows.push_back({{"height_m", h}, {"feasible", feasible}, {"passed", passed}, {"runs", runs}});
      std::fprintf(stderr, "| %s | %.2f m | %d/%d | %d/%d | %.2f / %.2f m |\n", st.name, h,
                   feasible, seeds, passed, seeds, planned_dx, simulated_dx);
      if (feasible == 0 && h > highest + 0.101) break;  // two heights in a row out of reach
    }
    out[st.name] = {{"v0_m_s", st.v0},
                    {"near_face_x_m", st.x_min},
                    {"target_dx_m", st.dx},
                    {"highest_platform_m", highest},
                    {"heights", rows}};
    std::fprintf(stderr, "| %s | highest: %.2f m | | | |\n", st.name, highest);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"What limits the jumps: the paper's gap, relaxed limits, the highest platform."};
  int seeds = 3;
  int threads = 2;
  std::string only;
  app.add_option("--only", only, "paper_gap | relax | platform (default: all)")
      ->check(CLI::IsMember({"paper_gap", "relax", "platform"}));
  app.add_option("--seeds", seeds, "planner seeds 1..N")->check(CLI::Range(1, 100));
  app.add_option("--threads", threads, "planner threads")->check(CLI::Range(1, 64));
  CLI11_PARSE(app, argc, argv);
  try {
    const auto robot = wj::model::RobotModel::loadDefault();
    const sm::Verifier verifier(robot, sm::VerifierSettings{});
    json out;
    out["seeds"] = seeds;
    if (only.empty() || only == "paper_gap")
      out["paper_gap"] = paperGap(robot, verifier, seeds, threads);
    if (only.empty() || only == "relax") out["relax"] = relax(robot, seeds, threads);
    if (only.empty() || only == "platform")
      out["platform"] = platform(robot, verifier, seeds, threads);
    std::cout << out.dump(2) << std::endl;
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "bench_limits: " << e.what() << "\n";
    return 2;
  }
}
