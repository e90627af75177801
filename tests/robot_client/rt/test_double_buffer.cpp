// DoubleBuffer: latest-value semantics and no torn values under a two-thread stress test.
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>

#include "rt/double_buffer.h"

namespace wj::rt {
namespace {

TEST(DoubleBuffer, FetchReturnsLatestOnlyOnce) {
  DoubleBuffer<int> buffer(0);
  int out = -1;
  EXPECT_FALSE(buffer.fetch(out));
  EXPECT_EQ(out, -1);
  buffer.publish(1);
  buffer.publish(2);
  EXPECT_TRUE(buffer.hasNew());
  EXPECT_TRUE(buffer.fetch(out));
  EXPECT_EQ(out, 2);  // the latest, not the first
  EXPECT_FALSE(buffer.fetch(out));
  buffer.publish(3);
  EXPECT_TRUE(buffer.fetch(out));
  EXPECT_EQ(out, 3);
}

TEST(DoubleBuffer, CustomCopyIsUsed) {
  struct Doubling {
    void operator()(int& dst, const int& src) const { dst = 2 * src; }
  };
  DoubleBuffer<int, Doubling> buffer(0);
  buffer.publish(21);  // stored as 42, fetched as 84
  int out = 0;
  ASSERT_TRUE(buffer.fetch(out));
  EXPECT_EQ(out, 84);
}

// A value whose fields must agree: a reader that saw half of one publish and half of another
// would find them inconsistent.
struct Consistent {
  std::uint64_t seq = 0;
  std::array<std::uint64_t, 31> copies{};
};

TEST(DoubleBuffer, ReaderNeverSeesATornValue) {
  constexpr std::uint64_t kPublishes = 300'000;
  DoubleBuffer<Consistent> buffer;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    Consistent v;
    for (std::uint64_t i = 1; i <= kPublishes; ++i) {
      v.seq = i;
      v.copies.fill(i * 0x9E3779B97F4A7C15ull);
      buffer.publish(v);
    }
    done.store(true, std::memory_order_release);
  });
  Consistent v;
  std::uint64_t fetched = 0, torn = 0, backwards = 0, last = 0;
  for (;;) {
    const bool finished = done.load(std::memory_order_acquire);
    if (buffer.fetch(v)) {
      ++fetched;
      for (std::uint64_t c : v.copies)
        if (c != v.seq * 0x9E3779B97F4A7C15ull) ++torn;
      if (v.seq <= last) ++backwards;
      last = v.seq;
    }
    if (finished && !buffer.hasNew()) break;
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);
  EXPECT_GT(fetched, 0u);
  EXPECT_EQ(last, kPublishes);  // the final value always arrives
}

}  // namespace
}  // namespace wj::rt
