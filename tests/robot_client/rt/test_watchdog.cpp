// Watchdog: trips once when kicks stop, not while kicked.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>

#include "rt/watchdog.h"

namespace wj::rt {
namespace {

using namespace std::chrono_literals;

WatchdogSettings shortTimeout() {
  WatchdogSettings s;
  s.timeout = 100ms;  // long against the 1 ms kicks, so a stalled test thread cannot trip it
  s.check_period = 1ms;
  return s;
}

TEST(Watchdog, DoesNotTripWhileKicked) {
  std::atomic<int> trips{0};
  Watchdog dog(shortTimeout(), [&] { trips.fetch_add(1); });
  dog.start();
  for (int i = 0; i < 200; ++i) {  // 200 ms of kicks every 1 ms
    dog.kick();
    std::this_thread::sleep_for(1ms);
  }
  dog.stop();
  EXPECT_FALSE(dog.tripped());
  EXPECT_EQ(trips.load(), 0);
  EXPECT_EQ(dog.kicks(), 200u);
}

TEST(Watchdog, TripsOnceWhenKicksStop) {
  std::atomic<int> trips{0};
  Watchdog dog(shortTimeout(), [&] { trips.fetch_add(1); });
  dog.start();
  for (int i = 0; i < 29; ++i) {
    dog.kick();
    std::this_thread::sleep_for(1ms);
  }
  // Kicks stop: the trip comes within a generous bound, never before the timeout after the last
  // kick (measured from just before it, so a stalled test thread cannot make it look early),
  // and only once.
  const auto last_kick = std::chrono::steady_clock::now();
  dog.kick();
  while (!dog.tripped() && std::chrono::steady_clock::now() - last_kick < 5s)
    std::this_thread::sleep_for(1ms);
  const auto waited = std::chrono::steady_clock::now() - last_kick;
  EXPECT_TRUE(dog.tripped());
  EXPECT_GE(waited, shortTimeout().timeout);
  std::this_thread::sleep_for(100ms);
  dog.stop();
  EXPECT_EQ(trips.load(), 1);
  // start() re-arms.
  dog.start();
  EXPECT_FALSE(dog.tripped());
  dog.stop();
}

TEST(Watchdog, ValidatesSettings) {
  WatchdogSettings s;
  s.timeout = 0ms;
  EXPECT_THROW(s.validate(), std::invalid_argument);
  s.timeout = 5ms;
  s.check_period = 10ms;
  EXPECT_THROW(Watchdog(s, {}), std::invalid_argument);
}

}  // namespace
}  // namespace wj::rt
