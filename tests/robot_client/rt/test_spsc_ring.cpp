// SpscRing: order, wrap-around, full/drop counting, and a two-thread stress test.
#include <gtest/gtest.h>

#include <cstdint>
#include <thread>

#include "rt/spsc_ring.h"

namespace wj::rt {
namespace {

TEST(SpscRing, PopsInPushOrderAcrossWrapAround) {
  SpscRing<int, 4> ring;
  int out = -1;
  EXPECT_FALSE(ring.tryPop(out));
  EXPECT_EQ(out, -1);
  int next_push = 0, next_pop = 0;
  // 10 rounds of 3 pushes and 3 pops run the indices around the 4 slots several times.
  for (int round = 0; round < 10; ++round) {
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(ring.tryPush(next_push++));
    EXPECT_EQ(ring.size(), 3u);
    for (int i = 0; i < 3; ++i) {
      ASSERT_TRUE(ring.tryPop(out));
      EXPECT_EQ(out, next_pop++);
    }
    EXPECT_EQ(ring.size(), 0u);
  }
  EXPECT_EQ(ring.dropped(), 0u);
}

TEST(SpscRing, FullRingDropsAndCounts) {
  SpscRing<std::uint32_t, 8> ring;
  for (std::uint32_t i = 0; i < 8; ++i) EXPECT_TRUE(ring.tryPush(i));
  EXPECT_EQ(ring.size(), 8u);
  EXPECT_FALSE(ring.tryPush(100));
  EXPECT_FALSE(ring.tryPush(101));
  EXPECT_EQ(ring.dropped(), 2u);
  std::uint32_t out = 0;
  ASSERT_TRUE(ring.tryPop(out));
  EXPECT_EQ(out, 0u);
  EXPECT_TRUE(ring.tryPush(8));  // room again
  for (std::uint32_t expected = 1; expected <= 8; ++expected) {
    ASSERT_TRUE(ring.tryPop(out));
    EXPECT_EQ(out, expected);  // the dropped values never appear
  }
  EXPECT_FALSE(ring.tryPop(out));
  EXPECT_EQ(ring.dropped(), 2u);
}

struct Sample {
  std::uint64_t seq = 0;
  std::uint64_t check = 0;  // ~seq: a torn slot would break it
  double payload[6] = {};
};

TEST(SpscRing, TwoThreadStressKeepsSequence) {
  constexpr std::uint64_t kCount = 2'000'000;
  SpscRing<Sample, 64> ring;
  std::uint64_t pushed = 0;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kCount; ++i) {
      Sample s;
      s.seq = i;
      s.check = ~i;
      for (double& p : s.payload) p = static_cast<double>(i);
      if (ring.tryPush(s)) ++pushed;
    }
  });
  std::uint64_t popped = 0, last = 0, errors = 0;
  Sample s;
  // Every value is either popped or counted as dropped by the producer.
  while (popped + ring.dropped() < kCount) {
    if (!ring.tryPop(s)) {
      std::this_thread::yield();
      continue;
    }
    if (s.check != ~s.seq || s.payload[5] != static_cast<double>(s.seq)) ++errors;
    if (popped > 0 && s.seq <= last) ++errors;  // strictly increasing (drops leave gaps)
    last = s.seq;
    ++popped;
  }
  producer.join();
  EXPECT_FALSE(ring.tryPop(s));
  EXPECT_EQ(errors, 0u);
  EXPECT_EQ(popped, pushed);
  EXPECT_EQ(popped + ring.dropped(), kCount);
  EXPECT_GT(popped, 0u);
}

}  // namespace
}  // namespace wj::rt
