#pragma once
/// @file Fixed-period timer with absolute deadlines on CLOCK_MONOTONIC
/// (`clock_nanosleep(..., TIMER_ABSTIME, ...)`), so that the period does not drift with the
/// loop body's compute time: deadline k+1 = deadline k + period.

#include <chrono>
#include <cstdint>
#include <stdexcept>

namespace wj::rt {

/// Clock of the timer: std::chrono::steady_clock is CLOCK_MONOTONIC on Linux (libstdc++).
using MonotonicClock = std::chrono::steady_clock;

/// See the file comment. Not thread-safe: the loop thread owns its timer. waitNext() does not
/// allocate, lock or log.
class PeriodicTimer {
 public:
  /// A timer of `period` (> 0; throws std::invalid_argument otherwise). Call start() next.
  explicit PeriodicTimer(std::chrono::nanoseconds period);

  /// Sets the first deadline to now + period and clears the counters.
  void start();

  /// Sleeps until the next deadline. If that deadline has already passed (the body took longer
  /// than the rest of the period), counts an overrun, returns at once and re-phases the grid
  /// to now: the following deadline is now + period, so a late iteration is never followed by
  /// a burst of catch-up iterations.
  void waitNext();

  /// Busy-wait the last `spin` before each deadline instead of sleeping through it (0, the
  /// default: sleep to the deadline). Trades that much CPU per period for a wake-up that does
  /// not depend on the scheduler's latency. Must be shorter than the period.
  void setSpin(std::chrono::nanoseconds spin) {
    if (spin.count() < 0 || spin >= period_)
      throw std::invalid_argument("PeriodicTimer: spin must be in [0, period)");
    spin_ = spin;
  }
  /// Nominal period.
  std::chrono::nanoseconds period() const { return period_; }
  /// Deadline of the current period (the one waitNext() last waited for; after re-phasing, the
  /// time of the late wake-up).
  MonotonicClock::time_point deadline() const { return deadline_; }
  /// When waitNext() last returned (read after the sleep).
  MonotonicClock::time_point wakeTime() const { return wake_; }
  /// Wake-up lateness of the current period: wakeTime() - the deadline that was due (>= 0;
  /// for an overrun, how late the body finished).
  std::chrono::nanoseconds lateness() const { return lateness_; }
  /// Time between the last two wake-ups (the first: from start()).
  std::chrono::nanoseconds lastPeriod() const { return last_period_; }
  /// Periods whose deadline had passed when waitNext() was called, since start().
  std::uint64_t overruns() const { return overruns_; }
  /// Calls of waitNext() since start().
  std::uint64_t iterations() const { return iterations_; }

 private:
  std::chrono::nanoseconds period_;
  std::chrono::nanoseconds spin_{0};
  MonotonicClock::time_point deadline_{};
  MonotonicClock::time_point wake_{};
  std::chrono::nanoseconds lateness_{0};
  std::chrono::nanoseconds last_period_{0};
  std::uint64_t overruns_ = 0;
  std::uint64_t iterations_ = 0;
};

}  // namespace wj::rt
