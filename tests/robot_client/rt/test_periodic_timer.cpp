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

TEST(PeriodicTimer, DeadlinesStayOnTheGridExceptWhereAnOverrunRephases) {
  // Checked on the timer's own deadline arithmetic, not on wall-clock statistics, so that a
  // loaded machine (ctest in parallel, CI) cannot make it fail: without overruns every
  // deadline is exactly the previous one plus the period (no drift with the loop body), and
  // every overrun shifts the grid by exactly its lateness.
  PeriodicTimer timer(2ms);
  timer.start();
  const auto start = timer.deadline();
  EXPECT_EQ(start, timer.wakeTime());
  constexpr int kPeriods = 200;
  std::chrono::nanoseconds shift{0};
  auto previous = start;
  auto previous_wake = timer.wakeTime();
  for (int k = 0; k < kPeriods; ++k) {
    const std::uint64_t overruns_before = timer.overruns();
    timer.waitNext();
    EXPECT_GE(timer.lateness().count(), 0);
    EXPECT_GE(timer.wakeTime(), timer.deadline());
    if (timer.overruns() == overruns_before) {
      ASSERT_EQ(timer.deadline() - previous, timer.period()) << "period " << k;
    } else {
      ASSERT_EQ(timer.overruns(), overruns_before + 1);
      // Re-phased to the late wake-up, which was at least a period after the last deadline.
      EXPECT_EQ(timer.deadline(), timer.wakeTime());
      EXPECT_EQ(timer.deadline() - previous, timer.period() + timer.lateness()) << "period " << k;
      shift += timer.lateness();
    }
    EXPECT_EQ(timer.lastPeriod(), timer.wakeTime() - previous_wake);
    previous = timer.deadline();
    previous_wake = timer.wakeTime();
  }
  EXPECT_EQ(timer.iterations(), static_cast<std::uint64_t>(kPeriods));
  EXPECT_EQ(timer.deadline() - start, kPeriods * timer.period() + shift);
}

TEST(PeriodicTimer, BodyLongerThanPeriodCountsOverrunWithoutBurst) {
  PeriodicTimer timer(2ms);
  timer.start();
  timer.waitNext();
  timer.waitNext();
  const std::uint64_t before = timer.overruns();
  const auto on_grid = timer.deadline();
  std::this_thread::sleep_for(7ms);  // misses three deadlines
  timer.waitNext();                  // returns at once, late
  EXPECT_EQ(timer.overruns(), before + 1);
  EXPECT_GE(timer.lateness(), 5ms);  // woke >= 7 ms after a wake-up >= the last deadline
  const auto late = timer.wakeTime();
  EXPECT_EQ(timer.deadline(), late);
  // Re-phased: the next deadline is a full period after the late iteration, not the old grid's
  // next point (which has passed, and would return at once: a catch-up burst). Checked on the
  // deadlines, so a loaded machine cannot fail it.
  timer.waitNext();
  EXPECT_GE(timer.deadline(), late + timer.period());
  EXPECT_GE(timer.wakeTime() - late, timer.period());
  EXPECT_GT(timer.deadline(), on_grid + 3 * timer.period());
}

}  // namespace
}  // namespace wj::rt
