// robot_client: the on-robot program. Runs the 1 kHz control loop (estimator, NMPC policy or
// jump plan, PD and wheel law, safety), the NMPC thread, the asynchronous planner client, and
// the jump state machine, on the Simbody robot (--backend sim, optionally through emulated CAN
// frames with --via-can) or on MIT-mode motors over SocketCAN (--backend can).
//
// Exit status: 0 the scenario did what it should (jumped, cleared, landed and stopped), 3 it did
// not (aborted, fell, or hit the wall; the summary says why), 2 an error.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "robot_client/backends.h"
#include "robot_client/client_settings.h"
#include "robot_client/control_loop.h"
#include "robot_client/mpc_worker.h"
#include "robot_client/plan_requester.h"
#include "robot_client/run_report.h"
#include "rt/loop_stats.h"
#include "rt/periodic_timer.h"
#include "rt/realtime.h"
#include "rt/watchdog.h"
#include "viz/replay_page.h"
#include "viz/side_view.h"

namespace {

namespace rc = wj::robot_client;
using nlohmann::json;

struct Options {
  std::string backend = "sim";
  std::string config;
  std::string planner;
  std::string scenario = "forward";
  bool via_can = false;
  std::uint64_t seed = 1;
  bool noise = true;
  std::string csv;
  std::string plot;
  std::string snapshots, gif, html;  ///< pictures of the run (viz/), "" = none
  bool json_out = false;
  bool fast = false;
  std::vector<std::string> can_interfaces = {"can0", "can1", "can2", "can3"};
  std::string plant;        // sim backend: plant file (sim/plant.h); "" = the nominal robot
  std::string request_log;  // every PlanJumpRequest as a line of JSON; "" = none
};

// The snapshot strip, the animation and the 3D replay page asked for on the command line.
void writePictures(const Options& opt, const wj::model::RobotModel& robot,
                   const wj::viz::Recording& rec) {
  if (opt.snapshots.empty() && opt.gif.empty() && opt.html.empty()) return;
  if (rec.frames.empty()) throw std::runtime_error("no frames recorded for the pictures");
  if (!opt.snapshots.empty()) wj::viz::writeSnapshotStrip(robot, rec, opt.snapshots);
  if (!opt.gif.empty()) wj::viz::writeAnimationGif(robot, rec, opt.gif);
  if (!opt.html.empty()) wj::viz::writeReplayPage(robot, rec, opt.html);
  for (const std::string* path : {&opt.snapshots, &opt.gif, &opt.html})
    if (!path->empty()) spdlog::info("wrote {}", *path);
}

// The knee figure's file beside --plot's: out/e2e_backflip.png -> out/e2e_backflip_knees.png.
std::string kneeFigurePath(const std::string& plot) {
  std::filesystem::path p(plot);
  const std::string ext = p.has_extension() ? p.extension().string() : ".png";
  return (p.parent_path() / (p.stem().string() + "_knees" + ext)).string();
}

int run(const Options& opt) {
  const rc::ClientSettings settings = rc::loadClientSettings(opt.config);
  const rc::ScenarioSettings& scenario = settings.scenario(opt.scenario);
  const wj::model::RobotModel robot = wj::model::RobotModel::loadDefault(scenario.actuators_file);

  wj::nmpc::LocomotionSettings loco;
  loco.model.nominal_base_height_m = scenario.nmpc_base_height_m;
  loco.reference.base_height_m = scenario.nmpc_base_height_m;
  loco.posture_integral = settings.posture_integral;
  wj::nmpc::LocomotionController controller(robot, loco);

  std::unique_ptr<rc::Backend> backend;
  if (opt.backend == "sim") {
    const wj::sim::PlantSettings plant =
        opt.plant.empty() ? wj::sim::PlantSettings{} : wj::sim::loadPlantSettings(opt.plant);
    backend =
        rc::makeSimBackend(robot, controller, scenario, opt.seed, opt.noise, opt.via_can, plant);
  } else if (opt.backend == "can") {
    backend = rc::makeCanBackend(robot, opt.can_interfaces);
  } else {
    throw std::invalid_argument("--backend must be sim or can, got '" + opt.backend + "'");
  }
  const bool simulated = opt.backend == "sim";

  std::unique_ptr<rc::PlanRequester> requester;
  if (!opt.planner.empty()) {
    rc::PlannerConnection connection = settings.planner;
    connection.request_log_file = opt.request_log;
    requester = std::make_unique<rc::PlanRequester>(opt.planner, connection, robot,
                                                    settings.executor, 9.81);
  } else {
    spdlog::warn("no --planner given: the jump will be aborted at the decision point");
  }

  rc::MpcWorker mpc(controller, settings.loop.mpc_period_s, /*lockstep=*/simulated);
  rc::ControlLoop loop(robot, settings, scenario, backend->robot(), controller, mpc,
                       requester.get(), backend->faults(), backend->rangeSensor());
  rc::RunRecorder recorder(robot, settings, scenario, opt.csv);
  // A two-step take-off (the backflip) also gets the knee figure beside --plot's.
  const bool knee_figure = !opt.plot.empty() && scenario.mode == wj::planner::TakeoffMode::TwoStep;
  if (!opt.snapshots.empty() || !opt.gif.empty() || !opt.html.empty() || knee_figure)
    recorder.keepFrames();

  loop.initialise(backend->startPosition());
  mpc.start();
  wj::rt::WatchdogSettings wd;
  wd.timeout = std::chrono::nanoseconds(static_cast<long>(settings.loop.watchdog_timeout_s * 1e9));
  wj::rt::Watchdog watchdog(wd, [&loop] { loop.tripWatchdog(); });
  wj::rt::LoopStats stats(
      std::chrono::nanoseconds(static_cast<long>(settings.loop.period_s * 1e9)));

  // The loop runs in this thread; telemetry and transitions are drained between periods in
  // simulation (simulated time) and by a separate thread on hardware.
  std::atomic<bool> done{false};
  std::thread drain;
  if (!simulated) {
    drain = std::thread([&] {
      while (!done.load()) {
        recorder.drain(loop);
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    });
    wj::rt::RtSettings rts;
    rts.priority = settings.loop.rt_priority;
    rts.lock_memory = settings.loop.lock_memory;
    rts.cpu = settings.loop.cpu;
    const wj::rt::RtSetupReport rep = wj::rt::setupRealtime(rts);
    for (const std::string& w : rep.warnings) spdlog::warn("real-time setup: {}", w);
    watchdog.start();
  }

  const auto wall_start = std::chrono::steady_clock::now();
  wj::rt::PeriodicTimer timer(
      std::chrono::nanoseconds(static_cast<long>(settings.loop.period_s * 1e9)));
  timer.setSpin(std::chrono::nanoseconds(static_cast<long>(settings.loop.spin_us * 1e3)));
  timer.start();
  double stop_at = scenario.duration_s;
  while (loop.time() < stop_at) {
    const auto t0 = std::chrono::steady_clock::now();
    loop.step();
    watchdog.kick();
    const auto compute = std::chrono::steady_clock::now() - t0;
    loop.setLastCompute(std::chrono::duration<double, std::micro>(compute).count());
    if (simulated) {
      backend->observe(loop, recorder);
      recorder.drain(loop);
      recorder.notePlan(requester.get());
      // Paced to the wall clock, so that the planning service's latency counts as on the
      // robot (--fast: as fast as the machine goes; a cold plan then seems slower).
      if (!opt.fast) timer.waitNext();
    } else {
      timer.waitNext();
      stats.record(timer.lateness(), std::chrono::duration_cast<std::chrono::nanoseconds>(compute),
                   timer.lateness() > timer.period());
    }
    // Once the robot stands (after a jump or an abort) or damps, half a second more and stop.
    const rc::Mode m = loop.mode();
    const bool settled =
        (m == rc::Mode::Stand && (loop.stateMachine().jumped() ||
                                  loop.stateMachine().abortReason() != rc::Reason::Start)) ||
        m == rc::Mode::Damping;
    if (settled && stop_at > loop.time() + 0.5) stop_at = loop.time() + 0.5;
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  done.store(true);
  if (drain.joinable()) drain.join();
  watchdog.stop();
  mpc.stop();
  recorder.drain(loop);

  rc::RunSummary summary = recorder.summarise(loop, requester.get(), *backend, mpc.counters());
  summary.wall_s = wall_s;
  if (!simulated) summary.loop_stats = stats.toJson();
  if (opt.json_out)
    std::cout << summary.toJson().dump(2) << "\n";
  else
    summary.printTable(std::cout);
  if (!opt.plot.empty()) recorder.plot(opt.plot, loop);
  if (knee_figure) recorder.plotKnees(kneeFigurePath(opt.plot), loop, requester.get());
  writePictures(opt, robot, recorder.recording(loop, requester.get()));
  return summary.success ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"robot_client: the wheeled-legged robot's on-board control program"};
  Options opt;
  app.add_option("--backend", opt.backend, "sim | can")->check(CLI::IsMember({"sim", "can"}));
  app.add_option("--config", opt.config, "robot client YAML (config/robot_client.yaml)");
  std::string check_path;
  app.add_option(
      "--check-config", check_path,
      "validate a robot client YAML (strict reader and ranges) and exit: 0 valid, 2 not");
  app.add_option("--planner", opt.planner, "planning service HOST:PORT (none: no jumps)");
  app.add_option("--scenario", opt.scenario,
                 "a scenario of the config's scenarios: (forward, vertical, ...)");
  app.add_flag("--via-can", opt.via_can,
               "sim backend: drive the simulated motors through emulated MIT-mode CAN frames");
  app.add_option("--seed", opt.seed, "sim backend: sensor-noise seed");
  app.add_flag("!--no-noise", opt.noise, "sim backend: exact sensors");
  app.add_option("--plant", opt.plant,
                 "sim backend: plant file (YAML, every key optional): how the simulated robot "
                 "differs from the model the controllers use (docs/sim.md, 'Plant')");
  app.add_option("--csv", opt.csv, "telemetry CSV file");
  app.add_option("--plot", opt.plot,
                 "figure (PNG, gnuplot); a two-step take-off (backflip) also writes the knees "
                 "over the take-off to <name>_knees.png");
  app.add_option("--snapshots", opt.snapshots,
                 "snapshot strip of the jump (PNG: the robot from take-off to landing)");
  app.add_option("--gif", opt.gif, "side-view animation of the run (GIF)");
  app.add_option("--html", opt.html, "3D replay page of the run (HTML, three.js inlined)");
  app.add_flag("--json", opt.json_out, "print the summary as JSON");
  app.add_option("--request-log", opt.request_log,
                 "append every plan request sent, one line of JSON each (replay: planner_cli "
                 "plan --request)");
  app.add_flag("--fast", opt.fast,
               "sim backend: do not pace simulated time to the wall clock (plan latency then "
               "weighs more)");
  app.add_option("--can-interfaces", opt.can_interfaces,
                 "can backend: one interface per leg, LF RF LH RH")
      ->expected(4);
  CLI11_PARSE(app, argc, argv);
  // Logs (transitions, warnings) go to stderr; stdout carries the summary (--json: only it).
  spdlog::set_default_logger(spdlog::stderr_color_mt("robot_client"));
  if (!check_path.empty()) {
    try {
      (void)rc::loadClientSettings(check_path);
      std::printf("%s: valid\n", check_path.c_str());
      return 0;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "robot_client: %s\n", e.what());
      return 2;
    }
  }
  if (opt.config.empty()) {
    std::fprintf(stderr, "robot_client: --config is required\n");
    return 2;
  }
  try {
    return run(opt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "robot_client: %s\n", e.what());
    return 2;
  }
}
