#pragma once
/// @file The hand-off of one DE generation's evaluations between the threads of an OpenMP team.
///
/// The DE evaluates a batch per generation and then runs a few microseconds of serial work
/// (selection, ranking, mutation). An `omp parallel for` per generation pays libgomp's wake-up
/// at both ends of every batch: with OMP_WAIT_POLICY=passive (which the deployment sets, since
/// spinning threads starve a loaded machine) a sleeping thread takes 45 us at the median to
/// start on this machine's VM, and the caller sleeps again at the closing barrier, so a batch of
/// 0.5 ms ran barely faster on two threads than on one. Here the team lives for the whole
/// solve: thread 0 runs the algorithm and the others wait for batches, spinning for a bounded
/// time (longer than the serial work between batches) before they sleep on a futex
/// (std::atomic::wait). A loaded machine loses at most that spin per batch.
///
/// Protocol: one 64-bit word holds (epoch, count, next index) of the current batch. Workers claim
/// an index with a compare-exchange that also checks the epoch, so a thread that wakes late can
/// never take an index of a batch it did not see published; the caller publishes a new batch
/// only once every index of the last one is done.

#include <omp.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <utility>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace wj::planner::de {

class BatchTeam {
 public:
  /// Largest batch (indices are 20 bits of the shared word).
  static constexpr int kMaxCount = (1 << 20) - 1;

  explicit BatchTeam(std::chrono::microseconds spin) : spin_(spin) {}

  /// Runs task(i, thread) for i in [0, count) on the calling thread (thread 0) and the workers
  /// that are in work(); returns when all are done. `task` must not throw. Caller only.
  template <class Task>
  void run(int count, Task& task) {
    task_ = &task;
    invoke_ = [](void* t, int i, int thread) { (*static_cast<Task*>(t))(i, thread); };
    done_.store(0, std::memory_order_relaxed);
    ++epoch_;
    word_.store(pack(epoch_, count, 0), std::memory_order_release);
    word_.notify_all();
    claimAll(epoch_, 0);
    // Wait for the indices the workers hold (at most one each): short, so spin, then sleep.
    int done = done_.load(std::memory_order_acquire);
    const auto until = std::chrono::steady_clock::now() + spin_;
    while (done < count && std::chrono::steady_clock::now() < until) {
      pause();
      done = done_.load(std::memory_order_acquire);
    }
    while (done < count) {
      done_.wait(done, std::memory_order_acquire);
      done = done_.load(std::memory_order_acquire);
    }
  }

  /// Releases the workers from work(). Caller only.
  void stop() {
    stop_.store(true, std::memory_order_release);
    ++epoch_;
    word_.store(pack(epoch_, 0, 0), std::memory_order_release);
    word_.notify_all();
  }

  /// A worker's loop: takes part in every batch published until stop().
  void work(int thread) {
    std::uint64_t seen = 0;
    for (;;) {
      std::uint64_t w = word_.load(std::memory_order_acquire);
      const auto until = std::chrono::steady_clock::now() + spin_;
      while (epochOf(w) == seen && std::chrono::steady_clock::now() < until) {
        for (int k = 0; k < 32; ++k) pause();
        w = word_.load(std::memory_order_acquire);
      }
      while (epochOf(w) == seen) {
        word_.wait(w, std::memory_order_acquire);
        w = word_.load(std::memory_order_acquire);
      }
      if (stop_.load(std::memory_order_acquire)) return;
      seen = epochOf(w);
      claimAll(seen, thread);
    }
  }

 private:
  static std::uint64_t pack(std::uint64_t epoch, int count, int index) {
    return (epoch << 40) | (static_cast<std::uint64_t>(count) << 20) |
           static_cast<std::uint64_t>(index);
  }
  static std::uint64_t epochOf(std::uint64_t w) { return w >> 40; }
  static int countOf(std::uint64_t w) { return static_cast<int>((w >> 20) & kMaxCount); }
  static int indexOf(std::uint64_t w) { return static_cast<int>(w & kMaxCount); }

  static void pause() {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#endif
  }

  // Claims and runs indices of batch `epoch` until none is left (or a newer batch is up).
  void claimAll(std::uint64_t epoch, int thread) {
    std::uint64_t w = word_.load(std::memory_order_acquire);
    for (;;) {
      if (epochOf(w) != epoch) return;
      const int i = indexOf(w), count = countOf(w);
      if (i >= count) return;
      if (!word_.compare_exchange_weak(w, w + 1, std::memory_order_acq_rel,
                                       std::memory_order_acquire))
        continue;
      invoke_(task_, i, thread);
      if (done_.fetch_add(1, std::memory_order_acq_rel) + 1 == count) done_.notify_one();
      w = word_.load(std::memory_order_acquire);
    }
  }

  const std::chrono::microseconds spin_;
  std::uint64_t epoch_ = 0;  // caller's count of published batches
  void* task_ = nullptr;
  void (*invoke_)(void*, int, int) = nullptr;
  alignas(64) std::atomic<std::uint64_t> word_{0};
  alignas(64) std::atomic<int> done_{0};
  alignas(64) std::atomic<bool> stop_{false};
};

/// Runs body(team) on the calling thread with a team of `threads` OpenMP threads (the calling
/// one included) taking part in every team->run() it makes, and returns its result; with
/// threads <= 1, body(nullptr) runs alone. `spin` should outlast the serial work between two
/// batches. An exception from body is rethrown here.
template <class Body>
auto runWithTeam(int threads, std::chrono::microseconds spin, Body&& body)
    -> decltype(body(static_cast<BatchTeam*>(nullptr))) {
  using Value = decltype(body(static_cast<BatchTeam*>(nullptr)));
  if (threads <= 1) return body(nullptr);
  BatchTeam team(spin);
  Value result{};
  std::exception_ptr error;
#pragma omp parallel num_threads(threads)
  {
    if (omp_get_thread_num() == 0) {
      try {
        result = body(&team);
      } catch (...) {  // an exception must not escape an OpenMP region
        error = std::current_exception();
      }
      team.stop();
    } else {
      team.work(omp_get_thread_num());
    }
  }
  if (error) std::rethrow_exception(error);
  return result;
}

}  // namespace wj::planner::de
