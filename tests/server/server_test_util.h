#pragma once
// Helpers of the service tests: temporary folders, a fast test configuration, requests in the
// standing posture, and a real planner_server process on an ephemeral loopback port.

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "server/config.h"
#include "server/planning_core.h"
#include "wheeljump/planner/v1/jump_planner.pb.h"

namespace wj::server::test {

namespace v1 = wheeljump::planner::v1;

/// A fresh folder under the system temp dir, removed by the destructor.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix);
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

/// The test configuration: 127.0.0.1:0, the fast planner settings (tests/server/data), a cache
/// in `dir`, verification off (the tests that need it turn it on), short grace.
ServerConfig testConfig(const std::filesystem::path& dir);

/// testConfig without a cache file, with the planner's default settings (as tests/planner's
/// digests), the multibody verification on and calls up to 120 s: the configuration of the
/// tests that verify presets' plans.
ServerConfig verifyingDefaultsConfig();

/// The preset `name`'s task and initial state as a request, with `seed` and `request_id`.
PlanRequest presetRequest(const PlanningCore& core, const std::string& name, std::uint64_t seed,
                          const std::string& request_id);

/// `request` answered by `core` (a call with a 120 s deadline), waited for.
PlanOutcome ask(PlanningCore& core, PlanRequest request);

/// A PlanJump request of the robot standing level in the planner's take-off posture, rolling at
/// `v0`, asked for a vertical jump to a CoM apex of `height` (simultaneous take-off).
v1::PlanJumpRequest standingRequest(double v0, double height = 0.8);

/// A planner_server child process (the binary built next to the tests).
class ServerProcess {
 public:
  /// Writes `config` to `config_path` and starts the server with it; waits (up to 30 s) for its
  /// "listening on" line. Throws std::runtime_error if it exits or does not start.
  ServerProcess(const ServerConfig& config, const std::filesystem::path& config_path);
  /// Kills the process (SIGKILL) if it still runs.
  ~ServerProcess();
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  int port() const { return port_; }
  std::string target() const { return "127.0.0.1:" + std::to_string(port_); }
  pid_t pid() const { return pid_; }
  /// Sends `signal` (SIGTERM, SIGKILL).
  void signal(int signal);
  /// Waits up to `timeout` for the exit; the exit code, 128 + signal if killed, nullopt if it
  /// still runs.
  std::optional<int> waitExit(std::chrono::milliseconds timeout);
  /// Everything the server wrote to stdout and stderr so far.
  std::string output() const;

 private:
  pid_t pid_ = -1;
  int port_ = 0;
  std::filesystem::path log_path_;
  bool exited_ = false;
  int exit_code_ = 0;
};

/// Runs planner_server with `args`, waits up to 30 s, returns (exit code, output).
std::pair<int, std::string> runServerToExit(const std::vector<std::string>& args);

/// Path of the planner_server binary under test.
std::string serverBinary();

}  // namespace wj::server::test
