#include "rt/watchdog.h"

#include <stdexcept>
#include <string>
#include <utility>

namespace wj::rt {

void WatchdogSettings::validate() const {
  if (timeout.count() <= 0)
    throw std::invalid_argument("WatchdogSettings.timeout must be > 0 ns, got " +
                                std::to_string(timeout.count()));
  if (check_period.count() <= 0 || check_period > timeout)
    throw std::invalid_argument("WatchdogSettings.check_period must be in (0, timeout = " +
                                std::to_string(timeout.count()) + "] ns, got " +
                                std::to_string(check_period.count()));
}

Watchdog::Watchdog(const WatchdogSettings& settings, std::function<void()> on_trip)
    : settings_(settings), on_trip_(std::move(on_trip)) {
  settings_.validate();
}

Watchdog::~Watchdog() {
  stop();
}

void Watchdog::start() {
  stop();
  tripped_.store(false, std::memory_order_release);
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = false;
  }
  thread_ = std::thread([this] { monitor(); });
}

void Watchdog::stop() {
  if (!thread_.joinable()) return;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void Watchdog::monitor() {
  using Clock = std::chrono::steady_clock;
  std::uint64_t last_seen = kicks_.load(std::memory_order_relaxed);
  Clock::time_point last_change = Clock::now();
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stop_) {
    wake_.wait_for(lock, settings_.check_period, [this] { return stop_; });
    if (stop_) break;
    const Clock::time_point now = Clock::now();
    const std::uint64_t k = kicks_.load(std::memory_order_relaxed);
    if (k != last_seen) {
      last_seen = k;
      last_change = now;
    } else if (!tripped_.load(std::memory_order_relaxed) && now - last_change > settings_.timeout) {
      tripped_.store(true, std::memory_order_release);
      if (on_trip_) on_trip_();
    }
  }
}

}  // namespace wj::rt
