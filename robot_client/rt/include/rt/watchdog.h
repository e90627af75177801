#pragma once
/// @file Watchdog of the control loop: the loop kicks it every period (one relaxed atomic
/// increment, no clock read); a monitor thread owned by the watchdog checks every few ms and,
/// when no kick arrived for longer than the timeout, latches tripped() and calls the trip
/// callback once (e.g. to command damping mode through the backend).

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>

namespace wj::rt {

/// Settings of a Watchdog.
struct WatchdogSettings {
  std::chrono::nanoseconds timeout{std::chrono::milliseconds(10)};  ///< longest gap between kicks
  std::chrono::nanoseconds check_period{std::chrono::milliseconds(1)};  ///< monitor's poll period

  /// Throws std::invalid_argument naming the field unless 0 < check_period <= timeout.
  void validate() const;
};

/// See the file comment. kick() and tripped() are safe from any thread; start() and stop()
/// belong to the owner thread.
class Watchdog {
 public:
  /// `on_trip` runs once on the monitor thread when the watchdog trips (must not throw).
  Watchdog(const WatchdogSettings& settings, std::function<void()> on_trip);
  ~Watchdog();
  Watchdog(const Watchdog&) = delete;
  Watchdog& operator=(const Watchdog&) = delete;

  /// Starts the monitor thread; the timeout counts from now. Clears a previous trip.
  void start();
  /// Stops and joins the monitor thread (idempotent; also done by the destructor).
  void stop();
  /// Signals that the loop is alive. Real-time safe: one relaxed atomic increment.
  void kick() { kicks_.fetch_add(1, std::memory_order_relaxed); }
  /// True once no kick arrived within the timeout (latched until start()).
  bool tripped() const { return tripped_.load(std::memory_order_acquire); }
  /// Kicks received since construction.
  std::uint64_t kicks() const { return kicks_.load(std::memory_order_relaxed); }
  /// True while the monitor thread runs.
  bool running() const { return thread_.joinable(); }

 private:
  void monitor();

  WatchdogSettings settings_;
  std::function<void()> on_trip_;
  std::atomic<std::uint64_t> kicks_{0};
  std::atomic<bool> tripped_{false};
  std::mutex mutex_;  // guards stop_ (monitor thread only; never taken by kick())
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace wj::rt
