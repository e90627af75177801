// bench_verify: the verification of the service's candidates, timed and compared with the
// reference setting of the verifier (issue 21 item 3). For each case (the cold requests of
// bench_server: standing vertical jumps to apex heights 0.40 + 0.015 i; and the planner's
// presets) the planner runs once (seeded, one thread); its best `--candidates` distinct
// candidates become plans as the server builds them and each is verified `--runs` times with
// the verifier's default settings; with `--compare` also once with the reference settings
// (VerifierSettings::reference()), and the verdicts and measured quantities are compared; with
// `--compare-models` also once on the full 3-D model (VerificationModel::Full, same
// integrator) against the default (the sagittal model for these symmetric plans), timed too;
// with `--compare-simbody` also with IntegratorKind::SemiExplicitEulerSimbody (the same method
// stepped by Simbody's integrator instead of the project's EulerStepper), timed too, and the
// reports must agree bit for bit.
// Prints JSON.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <iostream>
#include <string>
#include <vector>

#include "planner/presets.h"
#include "sim/verifier.h"

namespace {

namespace pl = wj::planner;
namespace sm = wj::sim;
using Clock = std::chrono::steady_clock;

double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// bench_server's cold request i: standing still, legs at (0, 1, -2, 0), apex target height.
pl::Scenario standingCase(const wj::model::RobotModel& robot, int i) {
  pl::Scenario sc;
  sc.name = "standing_" + std::to_string(i);
  for (const wj::model::Leg leg : wj::model::kLegs) {
    sc.initial.q[wj::model::jointIndex(leg, wj::model::JointKind::HFE)] = 1.0;
    sc.initial.q[wj::model::jointIndex(leg, wj::model::JointKind::KFE)] = -2.0;
  }
  sc.initial.validate(robot);
  sc.task.target.height = 0.40 + 0.015 * i;
  sc.task.target.event = pl::TargetEvent::Apex;
  sc.task.mode = pl::TakeoffMode::Simultaneous;
  return sc;
}

nlohmann::json eventJson(const wj::planner::JumpEvent& e) {
  return {{"t", e.t},         {"x", e.state.x},  {"z", e.state.z}, {"pitch", e.state.pitch},
          {"vx", e.state.vx}, {"vz", e.state.vz}};
}

nlohmann::json reportJson(const sm::VerificationReport& r) {
  nlohmann::json failures = nlohmann::json::array();
  for (const sm::FailureReason f : r.failures.toVector()) failures.push_back(sm::toString(f));
  return {{"model", r.model == sm::SimModel::Sagittal ? "sagittal" : "full"},
          {"passed", r.passed},
          {"failures", failures},
          {"simulated_s", r.final_time_s},
          {"settled_early", r.settled_early},
          {"integrator_steps", r.integrator_steps},
          {"takeoff", eventJson(r.measured.takeoff)},
          {"apex", eventJson(r.measured.apex)},
          {"touchdown", eventJson(r.measured.touchdown)},
          {"max_envelope_ratio", r.max_envelope_ratio},
          {"max_speed_ratio", r.max_speed_ratio},
          {"final_roll_rad", r.final_roll_rad},
          {"final_angular_speed_rad_s", r.final_angular_speed_rad_s},
          {"min_obstacle_clearance", r.measured.min_obstacle_clearance},
          {"final_pitch_rad", r.final_pitch_rad},
          {"final_base_height_m", r.final_base_height_m}};
}

// Every measured quantity of the two reports is the same double (JSON prints the shortest
// representation that reads back to the same double), and so are the verdicts, reasons,
// per-joint peaks and work counts.
bool identicalReports(const sm::VerificationReport& a, const sm::VerificationReport& b) {
  const auto joints = [](const sm::VerificationReport& r) {
    nlohmann::json j = nlohmann::json::array();
    for (const sm::JointMetrics& m : r.joints)
      j.push_back({m.max_abs_torque_nm, m.max_abs_demand_nm, m.max_abs_speed_rad_s,
                   m.max_envelope_ratio, m.max_speed_ratio, m.min_q_rad, m.max_q_rad});
    return j;
  };
  const auto rest = [](const sm::VerificationReport& r) {  // NaN (not measured) prints null
    return nlohmann::json{r.final_rotation_rad,   r.apex_height_error_m, r.touchdown_dx_error_m,
                          r.max_base_z_m,         r.integrator_steps,    r.initial_ground_gap_m,
                          r.nominal_base_height_m};
  };
  // Compared as printed: a NaN (an event not measured) is unequal to itself as a number.
  return reportJson(a).dump() == reportJson(b).dump() && joints(a).dump() == joints(b).dump() &&
         rest(a).dump() == rest(b).dump() && a.reasons == b.reasons;
}

// The largest absolute differences of the measured quantities between two reports.
struct Differences {
  double event_pos_m = 0.0, event_vel_m_s = 0.0, event_pitch_rad = 0.0, event_t_s = 0.0;
  double envelope_ratio = 0.0, speed_ratio = 0.0, clearance_m = 0.0, final_pitch_rad = 0.0;
  double final_roll_rad = 0.0, final_height_m = 0.0, final_angular_speed_rad_s = 0.0;
  void add(const sm::VerificationReport& a, const sm::VerificationReport& b) {
    const auto event = [&](const pl::JumpEvent& x, const pl::JumpEvent& y) {
      event_t_s = std::max(event_t_s, std::abs(x.t - y.t));
      event_pos_m =
          std::max({event_pos_m, std::abs(x.state.x - y.state.x), std::abs(x.state.z - y.state.z)});
      event_vel_m_s = std::max(
          {event_vel_m_s, std::abs(x.state.vx - y.state.vx), std::abs(x.state.vz - y.state.vz)});
      event_pitch_rad = std::max(event_pitch_rad, std::abs(x.state.pitch - y.state.pitch));
    };
    event(a.measured.takeoff, b.measured.takeoff);
    event(a.measured.apex, b.measured.apex);
    event(a.measured.touchdown, b.measured.touchdown);
    envelope_ratio =
        std::max(envelope_ratio, std::abs(a.max_envelope_ratio - b.max_envelope_ratio));
    speed_ratio = std::max(speed_ratio, std::abs(a.max_speed_ratio - b.max_speed_ratio));
    const double ca = a.measured.min_obstacle_clearance, cb = b.measured.min_obstacle_clearance;
    if (ca != cb) clearance_m = std::max(clearance_m, std::abs(ca - cb));  // inf == inf: none
    final_roll_rad = std::max(final_roll_rad, std::abs(a.final_roll_rad - b.final_roll_rad));
    final_angular_speed_rad_s =
        std::max(final_angular_speed_rad_s,
                 std::abs(a.final_angular_speed_rad_s - b.final_angular_speed_rad_s));
    final_pitch_rad = std::max(final_pitch_rad, std::abs(a.final_pitch_rad - b.final_pitch_rad));
    final_height_m =
        std::max(final_height_m, std::abs(a.final_base_height_m - b.final_base_height_m));
  }
  nlohmann::json toJson() const {
    return {{"event_position_m", event_pos_m},
            {"event_velocity_m_s", event_vel_m_s},
            {"event_pitch_rad", event_pitch_rad},
            {"event_time_s", event_t_s},
            {"envelope_ratio", envelope_ratio},
            {"speed_ratio", speed_ratio},
            {"obstacle_clearance_m", clearance_m},
            {"final_pitch_rad", final_pitch_rad},
            {"final_roll_rad", final_roll_rad},
            {"final_base_height_m", final_height_m},
            {"final_angular_speed_rad_s", final_angular_speed_rad_s}};
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Times the verification of planned candidates; compares with the reference."};
  int standing = 10, candidates = 2, runs = 3;
  std::uint64_t seed = 7;
  std::vector<std::string> presets = pl::presetNames();
  bool compare = false, compare_models = false, full_only = false, compare_simbody = false;
  app.add_option("--standing", standing, "bench_server's cold requests (0..n-1)")
      ->capture_default_str();
  app.add_option("--presets", presets, "planner presets (none: --presets '')");
  app.add_option("--candidates", candidates, "candidates verified per plan")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--runs", runs, "timed verifications per candidate")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--seed", seed, "planner seed")->capture_default_str();
  app.add_flag("--compare", compare, "also verify with VerifierSettings::reference()");
  app.add_flag("--full-model", full_only,
               "verify on the full 3-D model only (VerificationModel::Full), e.g. for callgrind");
  app.add_flag("--compare-models", compare_models,
               "also verify on the full 3-D model (VerificationModel::Full)");
  app.add_flag("--compare-simbody", compare_simbody,
               "also verify with Simbody's SemiExplicitEulerIntegrator (identical reports)");
  CLI11_PARSE(app, argc, argv);
  presets.erase(std::remove(presets.begin(), presets.end(), std::string()), presets.end());

  const auto robot = wj::model::RobotModel::loadDefault();
  const pl::JumpPlanner planner(robot, pl::PlannerSettings{});
  std::vector<pl::Scenario> cases;
  for (int i = 0; i < standing; ++i) cases.push_back(standingCase(robot, i));
  for (const auto& name : presets) cases.push_back(pl::makePreset(planner, name));

  sm::VerifierSettings settings;
  if (full_only) settings.model = sm::VerificationModel::Full;
  const sm::Verifier verifier(robot, settings);
  const sm::Verifier reference(robot, sm::VerifierSettings::reference());
  sm::VerifierSettings full_settings;
  full_settings.model = sm::VerificationModel::Full;
  const sm::Verifier full(robot, full_settings);
  sm::VerifierSettings simbody_settings = settings;
  simbody_settings.sim.integrator.kind = sm::IntegratorKind::SemiExplicitEulerSimbody;
  const sm::Verifier simbody(robot, simbody_settings);
  std::vector<double> simbody_cpu_all;
  int simbody_identical = 0, simbody_compared = 0;
  nlohmann::json out, rows = nlohmann::json::array();
  std::vector<double> wall_all, cpu_all, ref_cpu_all, full_cpu_all, simulated_all;
  int verdicts_same = 0, compared = 0, models_same = 0, models_compared = 0, sagittal_runs = 0;
  Differences diff, model_diff;
  for (const pl::Scenario& sc : cases) {
    pl::PlanOptions o;
    o.seed = seed;
    o.threads = 1;
    o.num_candidates = candidates;
    const pl::PlannerResult r = planner.plan(sc.task, sc.initial, o);
    if (!r.evaluation.valid) continue;
    const pl::JumpModel model(robot, planner.settings(), sc.task, sc.initial);
    const sm::Scenario scenario = sm::scenarioForTask(sc.task);
    for (std::size_t k = 0; k < r.candidates.size(); ++k) {
      const pl::JumpPlan plan =
          k == 0 ? r.plan : model.buildPlan(r.candidates[k].u, &r.candidates[k].evaluation);
      std::vector<double> wall, cpu;
      sm::VerificationReport report;
      for (int i = 0; i < runs; ++i) {
        const double c0 = threadCpuMs();
        const auto t0 = Clock::now();
        report = verifier.verify(plan, scenario);
        wall.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        cpu.push_back(threadCpuMs() - c0);
      }
      nlohmann::json row = {{"case", sc.name},
                            {"candidate", k},
                            {"wall_ms", median(wall)},
                            {"cpu_ms", median(cpu)},
                            {"report", reportJson(report)}};
      wall_all.push_back(median(wall));
      cpu_all.push_back(median(cpu));
      simulated_all.push_back(report.final_time_s);
      if (compare) {
        const double c0 = threadCpuMs();
        const sm::VerificationReport ref = reference.verify(plan, scenario);
        const double ref_cpu = threadCpuMs() - c0;
        ref_cpu_all.push_back(ref_cpu);
        ++compared;
        const bool same =
            ref.passed == report.passed && ref.failures.toVector() == report.failures.toVector();
        verdicts_same += same ? 1 : 0;
        diff.add(report, ref);
        Differences one;
        one.add(report, ref);
        row["reference"] = {{"cpu_ms", ref_cpu},
                            {"same_verdict", same},
                            {"differences", one.toJson()},
                            {"report", reportJson(ref)}};
      }
      sagittal_runs += report.model == sm::SimModel::Sagittal ? 1 : 0;
      if (compare_models) {
        std::vector<double> full_cpu;
        sm::VerificationReport f;
        for (int i = 0; i < runs; ++i) {
          const double c0 = threadCpuMs();
          f = full.verify(plan, scenario);
          full_cpu.push_back(threadCpuMs() - c0);
        }
        full_cpu_all.push_back(median(full_cpu));
        ++models_compared;
        const bool same = f.passed == report.passed &&
                          f.failures.toVector() == report.failures.toVector() &&
                          f.reasons.size() == report.reasons.size();
        models_same += same ? 1 : 0;
        model_diff.add(report, f);
        Differences one;
        one.add(report, f);
        row["full_model"] = {{"cpu_ms", median(full_cpu)},
                             {"same_verdict", same},
                             {"differences", one.toJson()},
                             {"report", reportJson(f)}};
      }
      if (compare_simbody) {
        std::vector<double> simbody_cpu;
        sm::VerificationReport b;
        for (int i = 0; i < runs; ++i) {
          const double c0 = threadCpuMs();
          b = simbody.verify(plan, scenario);
          simbody_cpu.push_back(threadCpuMs() - c0);
        }
        simbody_cpu_all.push_back(median(simbody_cpu));
        ++simbody_compared;
        const bool identical = identicalReports(report, b);
        simbody_identical += identical ? 1 : 0;
        row["simbody_integrator"] = {{"cpu_ms", median(simbody_cpu)}, {"identical", identical}};
        if (!identical) row["simbody_integrator"]["report"] = reportJson(b);
      }
      rows.push_back(row);
    }
  }
  out["verifications"] = rows;
  out["median_wall_ms"] = median(wall_all);
  out["median_cpu_ms"] = median(cpu_all);
  out["median_simulated_s"] = median(simulated_all);
  out["sagittal_runs"] = sagittal_runs;
  if (compare_models) {
    out["full_model_median_cpu_ms"] = median(full_cpu_all);
    out["models_compared"] = models_compared;
    out["models_same_verdicts"] = models_same;
    out["models_largest_differences"] = model_diff.toJson();
  }
  if (compare_simbody) {
    out["simbody_integrator_median_cpu_ms"] = median(simbody_cpu_all);
    out["simbody_integrator_compared"] = simbody_compared;
    out["simbody_integrator_identical"] = simbody_identical;
  }
  if (compare) {
    out["reference_median_cpu_ms"] = median(ref_cpu_all);
    out["compared"] = compared;
    out["same_verdicts"] = verdicts_same;
    out["largest_differences"] = diff.toJson();
  }
  std::cout << out.dump(2) << std::endl;
  return 0;
}
