#pragma once
/// @file Lock-free hand-over of whole values from one writer thread to one reader thread
/// (e.g. the NMPC thread's policy to the control loop). Implemented as a triple buffer, so
/// that neither side ever waits for the other and the reader never sees a half-written value.
///
/// nmpc::PolicyExchange (robot_client/nmpc/include/nmpc/policy.h) is the same algorithm
/// written for nmpc::Policy, whose copy goes through copyFrom(); DoubleBuffer takes that copy
/// as its `Copy` parameter, so PolicyExchange is DoubleBuffer<Policy, CopyFrom>-shaped.

#include <array>
#include <atomic>
#include <cstdint>
#include <utility>

namespace wj::rt {

/// Default copy of DoubleBuffer: plain assignment.
struct AssignCopy {
  template <class T>
  void operator()(T& dst, const T& src) const {
    dst = src;
  }
};

/// Single-writer single-reader triple buffer of T. publish() only from one thread, fetch()
/// only from one (other) thread. Both are lock-free; they allocate only if `Copy` does
/// (assignment of fixed-size types does not). `Copy(dst, src)` copies a whole value.
template <class T, class Copy = AssignCopy>
class DoubleBuffer {
 public:
  /// Three copies of `initial` (the reader gets nothing before the first publish()).
  explicit DoubleBuffer(const T& initial = T{}, Copy copy = Copy{})
      : buffers_{initial, initial, initial}, copy_(std::move(copy)) {}

  /// Copies `value` into the writer's buffer and makes it the latest.
  void publish(const T& value) {
    copy_(buffers_[back_], value);
    // Hand the written buffer over as the fresh middle one; the old middle becomes the back.
    const std::uint8_t old =
        middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel);
    back_ = old & kIndexMask;
  }

  /// If a value newer than the last fetched one was published, copies it into `out` and
  /// returns true; otherwise leaves `out` untouched and returns false.
  bool fetch(T& out) {
    if ((middle_.load(std::memory_order_acquire) & kFresh) == 0) return false;
    const std::uint8_t old =
        middle_.exchange(static_cast<std::uint8_t>(front_), std::memory_order_acq_rel);
    front_ = old & kIndexMask;
    copy_(out, buffers_[front_]);
    return true;
  }

  /// True if a value newer than the last fetched one is waiting (either thread; a hint).
  bool hasNew() const { return (middle_.load(std::memory_order_acquire) & kFresh) != 0; }

 private:
  static constexpr std::uint8_t kFresh = 4;  // flag bit in middle_: not fetched yet
  static constexpr std::uint8_t kIndexMask = 3;

  std::array<T, 3> buffers_;
  Copy copy_;
  std::uint8_t back_ = 0;                // writer's
  std::atomic<std::uint8_t> middle_{1};  // shared: index | kFresh
  std::uint8_t front_ = 2;               // reader's
};

}  // namespace wj::rt
