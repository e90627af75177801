#include "rt/periodic_timer.h"

#include <time.h>

#include <cerrno>
#include <stdexcept>
#include <string>

namespace wj::rt {
namespace {

MonotonicClock::time_point now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return MonotonicClock::time_point(std::chrono::seconds(ts.tv_sec) +
                                    std::chrono::nanoseconds(ts.tv_nsec));
}

timespec toTimespec(MonotonicClock::time_point t) {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch());
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(ns.count() / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(ns.count() % 1'000'000'000);
  return ts;
}

}  // namespace

PeriodicTimer::PeriodicTimer(std::chrono::nanoseconds period) : period_(period) {
  if (period.count() <= 0)
    throw std::invalid_argument("PeriodicTimer: period must be > 0 ns, got " +
                                std::to_string(period.count()));
}

void PeriodicTimer::start() {
  wake_ = now();
  deadline_ = wake_;  // waitNext() moves on to wake_ + period
  lateness_ = std::chrono::nanoseconds(0);
  last_period_ = std::chrono::nanoseconds(0);
  overruns_ = 0;
  iterations_ = 0;
}

void PeriodicTimer::waitNext() {
  const MonotonicClock::time_point previous_wake = wake_;
  const MonotonicClock::time_point due = deadline_ + period_;
  MonotonicClock::time_point t = now();
  if (t >= due) {
    // Overrun: run this period at once and re-phase the grid to now (no catch-up burst).
    ++overruns_;
    deadline_ = t;
  } else {
    // Sleep to `spin_` before the deadline, then poll the clock: the wake-up latency of the
    // sleep (scheduler, hypervisor) is paid before the deadline instead of after it.
    const MonotonicClock::time_point sleep_until = due - spin_;
    if (sleep_until > t) {
      const timespec ts = toTimespec(sleep_until);
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
      }
    }
    t = now();
    while (t < due) t = now();
    deadline_ = due;
  }
  wake_ = t;
  lateness_ = t - due;
  last_period_ = t - previous_wake;
  ++iterations_;
}

}  // namespace wj::rt
