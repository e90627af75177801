#pragma once
/// @file Lock-free single-producer single-consumer ring buffer, e.g. to carry telemetry out of
/// the 1 kHz control loop: the loop pushes without blocking or allocating, a logger thread pops.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <new>
#include <type_traits>

namespace wj::rt {

/// Size of the cache line the indices are kept apart by [bytes] (no false sharing between the
/// producer's and the consumer's index).
inline constexpr std::size_t kCacheLineBytes = 64;

/// Lock-free ring of capacity N (a power of two) for one producer thread and one consumer
/// thread. tryPush() only from the producer, tryPop() only from the consumer; size() and
/// dropped() from anywhere (approximate while the other side runs). Wait-free, allocation-free.
template <class T, std::size_t N>
class SpscRing {
  static_assert(N >= 2 && (N & (N - 1)) == 0, "SpscRing: capacity N must be a power of two");
  static_assert(std::is_trivially_copyable_v<T>, "SpscRing: T must be trivially copyable");

 public:
  /// Number of slots.
  static constexpr std::size_t capacity() { return N; }

  /// Appends `value`; when the ring is full, drops it, counts the drop and returns false.
  bool tryPush(const T& value) {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_cache_ >= N) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head - tail_cache_ >= N) {
        dropped_.store(dropped_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
        return false;
      }
    }
    slots_[head & kMask] = value;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  /// Takes the oldest value into `out`; false (and `out` untouched) when the ring is empty.
  bool tryPop(T& out) {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_cache_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail == head_cache_) return false;
    }
    out = slots_[tail & kMask];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Values waiting to be popped.
  std::size_t size() const {
    const std::uint64_t tail = tail_.load(std::memory_order_acquire);
    const std::uint64_t head = head_.load(std::memory_order_acquire);
    return static_cast<std::size_t>(head - tail);
  }

  /// Values refused by tryPush() because the ring was full, since construction.
  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  static constexpr std::uint64_t kMask = N - 1;

  // Producer's line: its index, its cached view of the consumer's index, the drop counter.
  alignas(kCacheLineBytes) std::atomic<std::uint64_t> head_{0};
  std::uint64_t tail_cache_ = 0;
  std::atomic<std::uint64_t> dropped_{0};
  // Consumer's line.
  alignas(kCacheLineBytes) std::atomic<std::uint64_t> tail_{0};
  std::uint64_t head_cache_ = 0;
  alignas(kCacheLineBytes) std::array<T, N> slots_{};
};

}  // namespace wj::rt
