// planner_server: the jump planning service (wheeljump.planner.v1.JumpPlanner over gRPC).
// See docs/service.md for the configuration, the cache and what each status code means.
#include <absl/synchronization/mutex.h>
#include <malloc.h>
#include <pthread.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdlib>
#include <iostream>

#include "planner/planner_settings.h"
#include "robot_model/robot_model.h"
#include "server/config.h"
#include "server/plan_verifier.h"
#include "server/server_runner.h"

int main(int argc, char** argv) {
  // Every cache hit allocates and frees a few hundred KB (the plan's N x 16 matrices, the
  // response's arrays, the serialized message). With glibc's defaults these blocks go back to
  // the kernel when freed (mmap above 128 KB, heap trimming, the worker threads' arenas shrunk
  // with madvise) and the next hit faults them in again, zeroed: converting and serializing a
  // 1 kHz response took 0.48 ms of CPU that way and 0.12 ms without (bench_server's
  // breakdown). Blocks up to 4 MiB now come from the heap and up to 64 MiB of free heap is
  // kept: the process holds on to what its calls in flight needed at their peak.
  ::mallopt(M_MMAP_THRESHOLD, 4 * 1024 * 1024);
  ::mallopt(M_TRIM_THRESHOLD, 64 * 1024 * 1024);
  // Debian's Abseil is built without NDEBUG, so every absl::Mutex that gRPC locks (several per
  // call) also updated a global lock-order graph for deadlock detection: 4 us of a hot hit's
  // server CPU and 2 us of an empty RPC's in `perf record` (GraphCycles::GetId, InsertEdge,
  // RemoveNode; docs/service.md, "Where a hot hit's CPU goes"). The service takes no absl lock
  // of its own; gRPC's locks are tested upstream.
  absl::SetMutexDeadlockDetectionMode(absl::OnDeadlockCycle::kIgnore);
  CLI::App app{"Jump planning service of the wheeljump stack (gRPC, wheeljump.planner.v1)."};
  std::string config_path, listen;
  bool print_config = false;
  app.add_option("--config", config_path,
                 "YAML configuration; every key required, unknown keys refused "
                 "(sample: config/planner_server.yaml). Without it the built-in defaults apply.");
  app.add_option("--listen", listen,
                 "host:port to listen on, overriding the configuration (default 127.0.0.1:50051; "
                 "port 0 picks a free port)");
  app.add_flag("--print-config", print_config, "print the effective configuration and exit");
  std::string check_path;
  app.add_option("--check-config", check_path,
                 "read FILE with the strict reader, validate it, load the robot model, the "
                 "planner settings and the verifier's files it names, then exit: 0 valid, 2 not "
                 "(TLS files and the "
                 "cache folder are not checked: they belong to the machine)")
      ->excludes("--config");
  CLI11_PARSE(app, argc, argv);

  if (!check_path.empty()) {
    try {
      const auto config = wj::server::ServerConfig::fromYamlFile(check_path);
      if (!config.models_dir.empty()) ::setenv("WJ_MODELS_DIR", config.models_dir.c_str(), 1);
      const auto robot = wj::model::RobotModel::loadDefault(config.actuators_file);
      if (!config.planner.settings_file.empty())
        (void)wj::planner::PlannerSettings::fromYaml(config.planner.settings_file);
      // The verifier's files (sim settings, the robot client's jump executor) as it reads them.
      if (config.verification.enabled && wj::server::simVerifierAvailable())
        (void)wj::server::makeSimVerifier(robot, config.verification);
      std::cout << check_path << ": ok (listen " << config.listen << ", tls "
                << wj::server::toString(config.tls.mode) << ", cache "
                << (config.cache.backend == wj::server::CacheBackend::Redis
                        ? "redis " + config.cache.redis.host + ":" +
                              std::to_string(config.cache.redis.port)
                    : config.cache.path.empty() ? std::string("memory only")
                                                : config.cache.path)
                << ", model " << robot.name() << " from "
                << wj::model::RobotModel::defaultModelsDir().string() << ")" << std::endl;
      return 0;
    } catch (const std::exception& e) {
      std::cerr << "planner_server: " << e.what() << std::endl;
      return 2;
    }
  }

  // SIGTERM and SIGINT are taken synchronously by sigwait() below: blocked here, before any
  // thread starts, so that every thread inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  try {
    wj::server::ServerConfig config = config_path.empty()
                                          ? wj::server::ServerConfig{}
                                          : wj::server::ServerConfig::fromYamlFile(config_path);
    if (!listen.empty()) {
      config.listen = listen;
      config.validate();
    }
    std::cout << "# effective configuration\n" << config.toYaml() << std::flush;
    if (print_config) return 0;
    spdlog::set_default_logger(spdlog::stderr_color_mt("planner_server"));
    spdlog::set_level(spdlog::level::from_str(config.log_level));

    wj::server::PlannerServer server(config);
    spdlog::info("{}", server.describe());
    // Tests and scripts read this line to find an ephemeral port.
    std::cout << "planner_server listening on " << server.address() << std::endl;

    int received = 0;
    sigwait(&signals, &received);
    spdlog::info("signal {}: shutting down (grace {} s)", received, config.shutdown_grace_s);
    server.shutdown();
    const auto stats = server.core().stats();
    spdlog::info("stopped after {:.1f} s: {} requests, {} hits, {} misses, cache flushed",
                 stats.uptime_s, stats.requests, stats.cache_hits, stats.cache_misses);
    std::cout << "planner_server stopped" << std::endl;
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "planner_server: " << e.what() << std::endl;
    return 2;
  }
}
