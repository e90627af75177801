// bench_sim: times one verification of a 1.5 s jump scenario (a closed-form vertical jump
// from rolling, then one second of landing) on one thread and prints JSON:
//   {"median_ms": ..., "runs": [...], "settings": {...}, "report": {...}}
// Options override the integrator and contact settings, to measure what they cost.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "sim/reference_plans.h"
#include "sim/verifier.h"

namespace {

template <class Enum, std::size_t N>
Enum parseEnum(const std::string& text, const std::array<Enum, N>& values) {
  for (const Enum v : values)
    if (text == wj::sim::toString(v)) return v;
  throw CLI::ValidationError("unknown value '" + text + "'");
}

// CPU time of the calling thread [ms]: robust against other processes on a shared machine.
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  using namespace wj;
  CLI::App app{"Times the verification of a 1.5 s jump scenario (single thread)."};
  int runs = 9;
  std::string settings_file;
  std::string integrator, wheel_shape, actuator_update;
  double accuracy = 0.0, max_step = 0.0, stiffness = 0.0, transition_velocity = 0.0;
  double v0 = 1.0;
  std::string csv;
  app.add_option("--runs", runs, "timed runs (after one warm-up)")->check(CLI::PositiveNumber);
  app.add_option("--settings", settings_file, "SimSettings YAML (default: built-in defaults)");
  app.add_option("--integrator", integrator,
                 "semi_explicit_euler | semi_explicit_euler2 | runge_kutta3 | runge_kutta_merson");
  app.add_option("--accuracy", accuracy, "integrator accuracy");
  app.add_option("--max-step", max_step, "largest integrator step [s]");
  app.add_option("--stiffness", stiffness, "contact material stiffness [Pa]");
  app.add_option("--transition-velocity", transition_velocity, "friction transition [m/s]");
  app.add_option("--wheel-shape", wheel_shape, "sphere | ellipsoid");
  app.add_option("--actuator-update", actuator_update, "continuous | zero_order_hold");
  double push_accel = 0.0;
  double duration = 1.5;
  app.add_option("--duration", duration, "simulated time: touchdown at t3, then landing [s]");
  app.add_option("--v0", v0, "run-up speed [m/s]");
  app.add_option("--push-accel", push_accel, "upward CoM acceleration of the push [m/s^2]");
  app.add_option("--csv", csv, "write the telemetry of the last run to this file");
  CLI11_PARSE(app, argc, argv);

  const std::filesystem::path models = WJ_MODELS_DIR;
  const model::RobotModel robot =
      model::RobotModel::load(models / "wheeljump.urdf", models / "actuators.yaml");
  sim::VerifierSettings settings;
  if (!settings_file.empty()) settings.sim = sim::loadSimSettings(settings_file);
  sim::SimSettings& s = settings.sim;
  if (!integrator.empty())
    s.integrator.kind = parseEnum(
        integrator,
        std::array{sim::IntegratorKind::SemiExplicitEuler, sim::IntegratorKind::SemiExplicitEuler2,
                   sim::IntegratorKind::RungeKutta3, sim::IntegratorKind::RungeKuttaMerson,
                   sim::IntegratorKind::SemiExplicitEulerSimbody});
  if (!wheel_shape.empty())
    s.contact.wheel_shape =
        parseEnum(wheel_shape, std::array{sim::WheelShape::Sphere, sim::WheelShape::Ellipsoid});
  if (!actuator_update.empty())
    s.actuator_update = parseEnum(actuator_update, std::array{sim::ActuatorUpdate::Continuous,
                                                              sim::ActuatorUpdate::ZeroOrderHold});
  if (accuracy > 0.0) s.integrator.accuracy = accuracy;
  if (max_step > 0.0) s.integrator.max_step_s = max_step;
  if (stiffness > 0.0) s.contact.stiffness_pa = stiffness;
  if (transition_velocity > 0.0) s.contact.transition_velocity_m_s = transition_velocity;

  sim::VerticalJumpSpec spec;
  spec.v0_m_s = v0;
  if (push_accel > 0.0) spec.push_accel_m_s2 = push_accel;
  const planner::JumpPlan plan = sim::makeVerticalJumpPlan(robot, spec, s.contact, s.gravity_m_s2);
  // Landing lasts until `duration` (touchdown is close to the planned t3).
  settings.executor.landing_duration_s = std::max(0.1, duration - plan.t3);
  const sim::Verifier verifier(robot, settings);
  const sim::Scenario scenario;

  std::vector<double> ms, cpu_ms;
  sim::VerificationReport report;
  for (int i = 0; i <= runs; ++i) {
    sim::TelemetryRecorder recorder;
    const bool record = i == runs && !csv.empty();
    const double c0 = threadCpuMs();
    const auto t0 = std::chrono::steady_clock::now();
    report =
        verifier.verify(plan, scenario, record ? recorder.callback() : sim::TelemetryCallback{});
    const auto t1 = std::chrono::steady_clock::now();
    const double c1 = threadCpuMs();
    if (i > 0) {
      ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      cpu_ms.push_back(c1 - c0);
    }
    if (record) {
      std::ofstream out(csv);
      recorder.writeCsv(out);
    }
  }
  const auto [min_it, max_it] = std::minmax_element(ms.begin(), ms.end());

  nlohmann::json j;
  j["benchmark"] = "verify_vertical_jump";
  j["median_ms"] = median(ms);
  j["min_ms"] = *min_it;
  j["max_ms"] = *max_it;
  j["median_cpu_ms"] = median(cpu_ms);
  j["runs_ms"] = ms;
  j["simulated_s"] = report.final_time_s;
  j["settings"] = {{"integrator", sim::toString(s.integrator.kind)},
                   {"accuracy", s.integrator.accuracy},
                   {"max_step_s", s.integrator.max_step_s},
                   {"stiffness_pa", s.contact.stiffness_pa},
                   {"transition_velocity_m_s", s.contact.transition_velocity_m_s},
                   {"wheel_shape", sim::toString(s.contact.wheel_shape)},
                   {"actuator_update", sim::toString(s.actuator_update)},
                   {"v0_m_s", v0}};
  nlohmann::json reasons = nlohmann::json::array();
  for (const auto& r : report.reasons) reasons.push_back(r);
  j["report"] = {{"passed", report.passed},
                 {"reasons", reasons},
                 {"integrator_steps", report.integrator_steps},
                 {"integrator_realizations", report.integrator_realizations},
                 {"takeoff_t_s", report.measured.takeoff.t},
                 {"apex_com_z_m", report.measured.apex.state.z},
                 {"apex_height_error_m", report.apex_height_error_m},
                 {"touchdown_t_s", report.measured.touchdown.t},
                 {"touchdown_dx_m", report.measured.touchdown.state.x},
                 {"max_envelope_ratio", report.max_envelope_ratio},
                 {"final_base_height_m", report.final_base_height_m},
                 {"final_pitch_rad", report.final_pitch_rad}};
  std::cout << j.dump(2) << std::endl;
  return 0;
}
