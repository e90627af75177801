// bench_mpc: cost of the NMPC on one core, as JSON on stdout:
//   sqp_iteration   median / p90 / max CPU time of one SQP iteration (real-time iteration, one
//                   per MPC cycle) over closed-loop runs (rolling to 3 m/s; trotting), and the
//                   median of each part (linearization, projection, Riccati, rollout, line
//                   search);
//   closed_loop     the MPC in its own thread next to the 1 kHz loop paced in real time on the
//                   Simbody robot: achieved MPC rate (wall and simulated time), loop overruns;
//   ipopt           the full-horizon NLP of one MPC cycle (states met in closed loop: rolling,
//                   steady trot, trot onset) solved by Ipopt (exact cost Hessian, FD constraint
//                   curvature) against the SQP iterated to convergence on it.
// CPU times are of the calling thread (robust against other processes on a shared machine);
// rates are wall-clock.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <thread>
#include <vector>

#include "nmpc/ipopt_reference.h"
#include "nmpc_sim/closed_loop.h"

namespace {

using namespace wj;
using namespace wj::nmpc;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5)];
}

json summary(const std::vector<double>& v) {
  return {{"median", quantile(v, 0.5)},
          {"p90", quantile(v, 0.9)},
          {"max", v.empty() ? 0.0 : *std::max_element(v.begin(), v.end())},
          {"samples", v.size()}};
}

// SQP iteration times over the synchronous closed loop of one scenario.
void collectIterations(const model::RobotModel& robot, const LocomotionSettings& settings,
                       bool trot, double seconds, std::vector<SqpTimings>& out) {
  LocomotionController c(robot, settings);
  SpeedCommand command;
  command.t_start_s = 0.3;
  command.v_target_m_s = trot ? 0.5 : 3.0;
  command.acceleration_m_s2 = 1.5;
  c.setSpeedCommand(command);
  if (trot) c.setGait(0.5, Gait::Trot);
  const sim::SimSettings sim;
  const sim_loop::LoopResult r = sim_loop::runClosedLoop(robot, c, sim, seconds, 0.01, 0.0,
                                                         [](double, LocomotionController&) {});
  for (const SqpStats& s : r.mpc_stats)
    if (s.iterations == 1) out.push_back(s.timings);
}

// The MPC in its own thread, the control loop paced at 1 kHz in real time.
json runThreaded(const model::RobotModel& robot, const LocomotionSettings& settings,
                 double seconds) {
  LocomotionController c(robot, settings);
  SpeedCommand command;
  command.t_start_s = 0.3;
  command.v_target_m_s = 2.0;
  command.acceleration_m_s2 = 1.5;
  c.setSpeedCommand(command);
  const sim::SimSettings sim_settings;
  sim::SimRobot robot_sim(robot, sim_settings);
  robot_sim.reset(sim_loop::standingPlacement(robot, c, sim_settings.terrain));

  std::mutex state_mutex;
  double shared_t = 0.0;
  State shared_x = State::Zero();
  std::atomic<bool> have_state{false}, stop{false};
  std::atomic<long> mpc_cycles{0};
  std::vector<double> mpc_wall_ms;
  mpc_wall_ms.reserve(100000);

  // First solve before the loop starts (the loop needs a policy).
  sim::GroundTruth gt;
  robot_sim.calcGroundTruth(gt, false);
  State x0 = c.model().calcStateFromBase(gt.X_WB, gt.v_WB, gt.w_WB, gt.q);
  for (int i = 0; i < 5; ++i) c.updateMpc(0.0, x0);

  std::thread mpc([&] {
    while (!stop) {
      if (!have_state) {
        std::this_thread::yield();
        continue;
      }
      double t = 0.0;
      State x;
      {
        std::lock_guard<std::mutex> lock(state_mutex);
        t = shared_t;
        x = shared_x;
      }
      const auto start = Clock::now();
      c.updateMpc(t, x);
      mpc_wall_ms.push_back(
          std::chrono::duration<double, std::milli>(Clock::now() - start).count());
      ++mpc_cycles;
    }
  });

  model::SensorData sensors;
  model::JointCommands commands{};
  const auto period = std::chrono::microseconds(1000);
  const int steps = static_cast<int>(seconds * 1000.0);
  int overruns = 0;
  bool fell = false;
  const auto start = Clock::now();
  auto next = start;
  for (int k = 0; k < steps; ++k) {
    robot_sim.calcGroundTruth(gt, false);
    robot_sim.read(sensors);
    const State x = c.model().calcStateFromBase(gt.X_WB, gt.v_WB, gt.w_WB, gt.q);
    {
      std::lock_guard<std::mutex> lock(state_mutex);
      shared_t = gt.t;
      shared_x = x;
    }
    have_state = true;
    c.calcCommands(gt.t, x, sensors, commands);
    robot_sim.write(commands);
    robot_sim.advance();
    if (gt.base_in_contact) fell = true;
    next += period;
    if (Clock::now() > next) {
      ++overruns;
    } else {
      std::this_thread::sleep_until(next);
    }
  }
  const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  stop = true;
  mpc.join();
  robot_sim.calcGroundTruth(gt, false);
  return {{"wall_s", wall_s},
          {"simulated_s", gt.t},
          {"mpc_cycles", mpc_cycles.load()},
          {"mpc_rate_hz_wall", static_cast<double>(mpc_cycles.load()) / wall_s},
          {"mpc_rate_hz_simulated", static_cast<double>(mpc_cycles.load()) / gt.t},
          {"mpc_cycle_wall_ms", summary(mpc_wall_ms)},
          {"loop_overruns", overruns},
          {"final_speed_m_s", gt.v_WB.x()},
          {"fell", fell}};
}

// One MPC cycle's NLP (full horizon) from a state met in the closed loop: SQP to convergence
// and Ipopt, times and agreement.
json compareIpopt(const model::RobotModel& robot, const LocomotionSettings& settings, bool trot,
                  double at_s, const char* label) {
  LocomotionController c(robot, settings);
  SpeedCommand command;
  command.t_start_s = 0.3;
  command.v_target_m_s = trot ? 0.5 : 3.0;
  command.acceleration_m_s2 = 1.5;
  c.setSpeedCommand(command);
  if (trot) c.setGait(0.5, Gait::Trot);
  const sim::SimSettings sim;
  State x;
  double t = 0.0;
  sim_loop::runClosedLoop(robot, c, sim, at_s, 0.01, 0.0, [&](double, LocomotionController&) {});
  t = c.solver().times()[0];
  x = c.solver().states()[0];
  const Targets targets = c.targets();

  SqpSettings sqp = settings.sqp;
  sqp.max_iterations = 200;
  sqp.step_tolerance = 1e-8;
  sqp.constraint_tolerance = 1e-9;
  SqpSolver solver(sqp, c.solver().problem());
  const double cpu0 = threadCpuMs();
  const SqpStatus status = solver.solve(t, x, targets);
  const double sqp_ms = threadCpuMs() - cpu0;

  IpoptReferenceSettings ipopt_settings;
  ipopt_settings.max_iterations = 500;
  const double cpu1 = threadCpuMs();
  const IpoptReferenceResult ip =
      solveWithIpopt(sqp, c.solver().problem(), t, x, targets, ipopt_settings);
  const double ipopt_cpu_ms = threadCpuMs() - cpu1;
  double dx = 0.0, du = 0.0;
  if (ip.x.size() == solver.states().size()) {
    for (std::size_t k = 0; k < ip.x.size(); ++k)
      dx = std::max(dx, (ip.x[k] - solver.states()[k]).cwiseAbs().maxCoeff());
    for (std::size_t k = 0; k < ip.u.size(); ++k)
      du = std::max(du, (ip.u[k] - solver.inputs()[k]).cwiseAbs().maxCoeff());
  }
  return {{"scenario", label},
          {"state_at_s", at_s},
          {"intervals", solver.numIntervals()},
          {"sqp",
           {{"status", toString(status)},
            {"iterations", solver.stats().iterations},
            {"cpu_ms", sqp_ms},
            {"cost", solver.stats().cost},
            {"violation", solver.stats().violation}}},
          {"ipopt",
           {{"status", ip.status},
            {"iterations", ip.iterations},
            {"cpu_ms", ipopt_cpu_ms},
            {"wall_ms", ip.solve_ms},
            {"cost", ip.cost},
            {"violation", ip.violation}}},
          {"max_abs_state_difference", dx},
          {"max_abs_input_difference", du}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Times the NMPC: SQP iteration and its parts, MPC rate in closed loop, Ipopt."};
  double roll_s = 4.0, trot_s = 3.0, threaded_s = 3.0;
  bool skip_ipopt = false;
  app.add_option("--roll-seconds", roll_s, "simulated seconds of the rolling run")
      ->check(CLI::PositiveNumber);
  app.add_option("--trot-seconds", trot_s, "simulated seconds of the trotting run")
      ->check(CLI::PositiveNumber);
  app.add_option("--threaded-seconds", threaded_s, "real-time seconds of the threaded run")
      ->check(CLI::PositiveNumber);
  app.add_flag("--skip-ipopt", skip_ipopt, "leave out the Ipopt comparison");
  CLI11_PARSE(app, argc, argv);

  const model::RobotModel robot = model::RobotModel::loadDefault();
  const LocomotionSettings settings;
  json out;
  out["settings"] = {{"horizon_s", settings.sqp.horizon_s},
                     {"dt_s", settings.sqp.dt_s},
                     {"integrator", toString(settings.sqp.integrator)},
                     {"iterations_per_cycle", settings.sqp.max_iterations},
                     {"threads", 1}};

  std::vector<SqpTimings> timings;
  collectIterations(robot, settings, false, roll_s, timings);
  collectIterations(robot, settings, true, trot_s, timings);
  std::vector<double> total, lin, proj, ric, roll, ls;
  for (const SqpTimings& t : timings) {
    total.push_back(t.total_ms);
    lin.push_back(t.linearization_ms);
    proj.push_back(t.projection_ms);
    ric.push_back(t.riccati_ms);
    roll.push_back(t.rollout_ms);
    ls.push_back(t.line_search_ms);
  }
  out["sqp_iteration_cpu_ms"] = summary(total);
  out["sqp_iteration_target_ms"] = 5.0;
  out["parts_median_cpu_ms"] = {{"linearization", quantile(lin, 0.5)},
                                {"projection", quantile(proj, 0.5)},
                                {"riccati", quantile(ric, 0.5)},
                                {"rollout", quantile(roll, 0.5)},
                                {"line_search", quantile(ls, 0.5)}};
  out["closed_loop_threaded"] = runThreaded(robot, settings, threaded_s);
  if (!skip_ipopt) {
    out["ipopt_comparison"] = json::array(
        {compareIpopt(robot, settings, false, 1.5, "rolling, accelerating to 3 m/s"),
         compareIpopt(robot, settings, true, 2.3, "trot at 0.5 m/s, steady"),
         compareIpopt(robot, settings, true, 1.6, "trot at 0.5 m/s, 1.1 s after its onset")});
  }
  std::cout << out.dump(2) << std::endl;
  return 0;
}
