// PeriodicTimer: correctness with generous bounds (a shared machine), not a timing target;
// the jitter figures come from bench_timer.
#include <gtest/gtest.h>

#include <chrono>
#include <stdexcept>
#include <thread>

#include "rt/periodic_timer.h"

namespace wj::rt {
namespace {

using namespace std::chrono_literals;

TEST(PeriodicTimer, RejectsNonPositivePeriod) {
  EXPECT_THROW(PeriodicTimer(0ns), std::invalid_argument);
  EXPECT_THROW(PeriodicTimer(-1ms), std::invalid_argument);
}

TEST(PeriodicTimer, PeriodsAverageToNominal) {
  PeriodicTimer timer(2ms);
  timer.start();
  const auto t0 = MonotonicClock::now();
  constexpr int kPeriods = 200;
  for (int k = 0; k < kPeriods; ++k) {
    timer.waitNext();
    EXPECT_GE(timer.lateness().count(), 0);
    EXPECT_GE(timer.wakeTime(), timer.deadline());
  }
  const double mean_ms =
      std::chrono::duration<double, std::milli>(MonotonicClock::now() - t0).count() / kPeriods;
  // Absolute deadlines: the mean period is nominal unless periods were skipped by overruns.
  EXPECT_NEAR(mean_ms, 2.0, 0.1) << "overruns: " << timer.overruns();
  EXPECT_EQ(timer.iterations(), static_cast<std::uint64_t>(kPeriods));
  EXPECT_LT(timer.overruns(), 10u);
}

TEST(PeriodicTimer, BodyLongerThanPeriodCountsOverrunWithoutBurst) {
  PeriodicTimer timer(2ms);
  timer.start();
  timer.waitNext();
  timer.waitNext();
  const std::uint64_t before = timer.overruns();
  std::this_thread::sleep_for(7ms);  // misses three deadlines
  timer.waitNext();                  // returns at once, late
  EXPECT_EQ(timer.overruns(), before + 1);
  EXPECT_GE(timer.lateness(), 3ms);
  // Re-phased: the next period is a full one again, not an immediate catch-up.
  const auto t = MonotonicClock::now();
  timer.waitNext();
  EXPECT_GE(MonotonicClock::now() - t, 1500us);
  EXPECT_EQ(timer.overruns(), before + 1);
}

}  // namespace
}  // namespace wj::rt
