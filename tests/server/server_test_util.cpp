#include "server_test_util.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <future>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "planner/presets.h"

namespace wj::server::test {

TempDir::TempDir(const std::string& prefix) {
  std::string pattern = (std::filesystem::temp_directory_path() / (prefix + "-XXXXXX")).string();
  if (!::mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed");
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

ServerConfig testConfig(const std::filesystem::path& dir) {
  ServerConfig c;
  c.listen = "127.0.0.1:0";
  c.log_level = "warn";
  c.shutdown_grace_s = 2.0;
  c.planner.settings_file = WJ_SERVER_TEST_DATA_DIR "/planner_fast.yaml";
  c.planner.polish_min_budget_s = 1e9;  // never polish in the tests (also off in the settings)
  c.deadlines.default_s = 20.0;
  c.verification.enabled = false;
  c.cache.path = (dir / "cache.sqlite").string();
  c.cache.synchronous_full = true;
  return c;
}

ServerConfig verifyingDefaultsConfig() {
  ServerConfig config = testConfig("/nonexistent");
  config.cache.path.clear();
  config.planner.settings_file.clear();
  config.verification.enabled = true;
  config.deadlines.max_s = 120.0;
  return config;
}

PlanRequest presetRequest(const PlanningCore& core, const std::string& name, std::uint64_t seed,
                          const std::string& request_id) {
  const planner::Scenario sc = planner::makePreset(core.planner(), name);
  PlanRequest r;
  r.task = sc.task;
  r.initial = sc.initial;
  r.seed = seed;
  r.request_id = request_id;
  return r;
}

PlanOutcome ask(PlanningCore& core, PlanRequest request) {
  std::promise<PlanOutcome> done;
  auto future = done.get_future();
  auto call =
      std::make_shared<PlanCall>(Clock::now() + std::chrono::seconds(120),
                                 [&done](PlanOutcome&& o) { done.set_value(std::move(o)); });
  core.plan(std::move(request), call);
  return future.get();
}

v1::PlanJumpRequest standingRequest(double v0, double height) {
  v1::PlanJumpRequest r;
  auto* s = r.mutable_state();
  s->mutable_base_position_w_m()->set_z(0.4);
  s->mutable_base_orientation_w()->set_w(1.0);
  s->mutable_base_linear_velocity_w_m_s()->set_x(v0);
  for (int leg = 0; leg < 4; ++leg) {
    // The planner's default take-off posture (PlannerSettings::stand_hfe_rad, stand_kfe_rad).
    for (const double q : {0.0, 1.0, -2.0, 0.0}) s->add_joint_positions_rad(q);
    for (int j = 0; j < 4; ++j) s->add_joint_velocities_rad_s(0.0);
  }
  auto* t = r.mutable_task();
  t->set_target_dx_m(0.0);
  t->set_target_height_m(height);
  t->set_event(v1::TARGET_EVENT_APEX);
  t->set_takeoff_mode(v1::TAKEOFF_MODE_SIMULTANEOUS);
  r.set_request_id("test");
  return r;
}

std::string serverBinary() {
  return WJ_PLANNER_SERVER_BIN;
}

ServerProcess::ServerProcess(const ServerConfig& config, const std::filesystem::path& config_path) {
  {
    std::ofstream out(config_path);
    out << config.toYaml();
  }
  log_path_ = config_path.string() + ".log";
  // A restart with the same configuration must not read the previous process's port.
  std::filesystem::remove(log_path_);
  pid_ = ::fork();
  if (pid_ < 0) throw std::runtime_error("fork failed");
  if (pid_ == 0) {
    const int fd = ::open(log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    const std::string bin = serverBinary();
    const std::string cfg = config_path.string();
    ::execl(bin.c_str(), bin.c_str(), "--config", cfg.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < until) {
    const std::string text = output();
    const auto at = text.find("listening on ");
    if (at != std::string::npos) {
      const auto eol = text.find('\n', at);
      if (eol != std::string::npos) {
        const std::string address = text.substr(at + 13, eol - at - 13);
        port_ = std::stoi(address.substr(address.rfind(':') + 1));
        return;
      }
    }
    if (waitExit(std::chrono::milliseconds(0)))
      throw std::runtime_error("planner_server exited at start:\n" + output());
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  signal(SIGKILL);
  throw std::runtime_error("planner_server did not start in 30 s:\n" + output());
}

ServerProcess::~ServerProcess() {
  if (!exited_) {
    signal(SIGKILL);
    waitExit(std::chrono::seconds(10));
  }
}

void ServerProcess::signal(int sig) {
  if (!exited_ && pid_ > 0) ::kill(pid_, sig);
}

std::optional<int> ServerProcess::waitExit(std::chrono::milliseconds timeout) {
  if (exited_) return exit_code_;
  const auto until = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == pid_) {
      exited_ = true;
      exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status)
                                     : (WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1);
      return exit_code_;
    }
    if (std::chrono::steady_clock::now() >= until) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

std::string ServerProcess::output() const {
  std::ifstream in(log_path_);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::pair<int, std::string> runServerToExit(const std::vector<std::string>& args) {
  TempDir dir("wj-server-run");
  const auto log = dir / "out.log";
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    const std::string bin = serverBinary();
    std::vector<char*> argv{const_cast<char*>(bin.c_str())};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(bin.c_str(), argv.data());
    ::_exit(127);
  }
  int status = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  int code = -1;
  for (;;) {
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      break;
    }
    if (std::chrono::steady_clock::now() >= until) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  return {code, ss.str()};
}

}  // namespace wj::server::test
