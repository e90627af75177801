#pragma once
// A real redis-server for the shared-cache tests: a child process on a free loopback port, in a
// temporary folder, without persistence. Tests skip (GTEST_SKIP) only when the binary is absent;
// CI installs it with deploy/install-deps.sh.

#include <sys/types.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace wj::server::test {

/// Path of redis-server (WJ_REDIS_SERVER, else the first on PATH); nullopt if there is none.
std::optional<std::string> findRedisServer();

/// A port that was free on 127.0.0.1 a moment ago (bound to port 0, then closed).
int freeLoopbackPort();

/// A redis-server child process on 127.0.0.1:port, data in `dir`, no RDB or AOF.
class RedisProcess {
 public:
  /// Starts it and waits (up to 10 s) until it answers PING. Throws std::runtime_error if not.
  RedisProcess(const std::string& binary, const std::filesystem::path& dir, int port);
  /// Kills it (SIGKILL) if it runs.
  ~RedisProcess();
  RedisProcess(const RedisProcess&) = delete;
  RedisProcess& operator=(const RedisProcess&) = delete;

  /// SIGKILL and wait: an outage as abrupt as a crashed pod.
  void kill();
  /// Starts it again on the same port (empty: nothing was persisted).
  void restart();
  int port() const { return port_; }
  bool running() const { return pid_ > 0; }

  /// One command over a fresh connection; the reply as text ("(nil)" for nil, "ERR ..." for
  /// errors). Arguments are binary-safe.
  std::string command(const std::vector<std::string>& args) const;

 private:
  void start();

  std::string binary_;
  std::filesystem::path dir_;
  int port_;
  pid_t pid_ = -1;
};

}  // namespace wj::server::test
