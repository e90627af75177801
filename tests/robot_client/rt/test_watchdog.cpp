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
  s.timeout = 20ms;
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
  for (int i = 0; i < 30; ++i) {
    dog.kick();
    std::this_thread::sleep_for(1ms);
  }
  EXPECT_FALSE(dog.tripped());
  // Kicks stop: the trip comes within a generous bound, and only once.
  const auto t0 = std::chrono::steady_clock::now();
  while (!dog.tripped() && std::chrono::steady_clock::now() - t0 < 2s)
    std::this_thread::sleep_for(1ms);
  const auto waited = std::chrono::steady_clock::now() - t0;
  EXPECT_TRUE(dog.tripped());
  EXPECT_GE(waited, 15ms);
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
