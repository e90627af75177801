// bench_server's shared parts: the planner_server child process, the requests, the base
// configuration (bench_server_common.h).
#include "bench_server_common.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "planner_client/compact_knots.h"

namespace wj::server_bench {

using namespace std::chrono_literals;

Server::Server(const wj::server::ServerConfig& config, const std::filesystem::path& dir,
               const std::string& name) {
  const auto config_path = dir / (name + ".yaml");
  std::ofstream(config_path) << config.toYaml();
  log_ = dir / (name + ".log");
  std::filesystem::remove(log_);
  pid_ = ::fork();
  if (pid_ == 0) {
    const int fd = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    // As deployed (docs/planner.md, "Threads"): DE threads sleep at their barriers.
    ::setenv("OMP_WAIT_POLICY", "passive", 0);
    ::execl(WJ_PLANNER_SERVER_BIN, WJ_PLANNER_SERVER_BIN, "--config", config_path.c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  const auto until = Clock::now() + 120s;
  while (Clock::now() < until) {
    std::ifstream in(log_);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string text = ss.str();
    const auto at = text.find("listening on ");
    const auto eol = at == std::string::npos ? at : text.find('\n', at);
    if (eol != std::string::npos) {
      const std::string address = text.substr(at + 13, eol - at - 13);
      target_ = address;
      return;
    }
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      throw std::runtime_error("planner_server exited at start:\n" + text);
    }
    std::this_thread::sleep_for(20ms);
  }
  kill(SIGKILL);
  throw std::runtime_error("planner_server did not start");
}

int Server::kill(int signal) {
  if (pid_ <= 0) return -1;
  ::kill(pid_, signal);
  int status = 0;
  ::waitpid(pid_, &status, 0);
  pid_ = -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

double Server::cpuMs() const {
  std::ifstream in("/proc/" + std::to_string(pid_) + "/stat");
  std::string text;
  std::getline(in, text);
  // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
  std::istringstream fields(text.substr(text.rfind(')') + 2));
  std::string field;
  double ticks = 0.0;
  for (int i = 3; i <= 15 && fields >> field; ++i)
    if (i >= 14) ticks += std::stod(field);
  return ticks * 1000.0 / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

double Server::rssMb() const {
  std::ifstream in("/proc/" + std::to_string(pid_) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return -1.0;
}

v1::TrajectoryFormat g_format = v1::TRAJECTORY_FORMAT_COMPACT_KNOTS;

bool useResponse(const v1::PlanJumpResponse& response) {
  if (!response.plan().has_compact_knots()) return true;
  thread_local v1::TrajectoryKnots knots;
  return wj::client::expandKnots(response.plan().compact_knots(), &knots).empty();
}

v1::PlanJumpRequest standing(double v0, double height) {
  v1::PlanJumpRequest r;
  auto* s = r.mutable_state();
  s->mutable_base_orientation_w()->set_w(1.0);
  s->mutable_base_linear_velocity_w_m_s()->set_x(v0);
  for (int leg = 0; leg < 4; ++leg) {
    for (const double q : {0.0, 1.0, -2.0, 0.0}) s->add_joint_positions_rad(q);
    for (int j = 0; j < 4; ++j) s->add_joint_velocities_rad_s(0.0);
  }
  auto* t = r.mutable_task();
  t->set_target_height_m(height);
  t->set_event(v1::TARGET_EVENT_APEX);
  t->set_takeoff_mode(v1::TAKEOFF_MODE_SIMULTANEOUS);
  r.set_request_id("bench");
  r.set_trajectory_format(g_format);
  return r;
}

double g_output_dt_s = 0.002;
double g_hot_responses_mb = wj::server::CacheConfig{}.hot_responses_mb;
bool g_both_hit_paths = true;
int g_hit_rounds = 30;

wj::server::ServerConfig baseConfig(const std::filesystem::path& dir) {
  wj::server::ServerConfig c;
  c.planner.output_dt_s = g_output_dt_s;
  c.listen = "127.0.0.1:0";
  c.log_level = "warn";
  c.cache.path = (dir / "cache.sqlite").string();
  return c;
}

std::filesystem::path writeFastPlannerSettings(const std::filesystem::path& dir) {
  const auto p = dir / "planner_fast.yaml";
  std::ofstream(p) << "de:\n  population_size: 16\n  max_generations: 40\n"
                      "  max_evaluations: 640\n  stagnation_generations: 15\n"
                      "polish:\n  enabled: false\n";
  return p;
}

}  // namespace wj::server_bench
