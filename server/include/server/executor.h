#pragma once
/// @file A fixed pool of worker threads with a bounded FIFO queue. Requests that find the queue
/// full are refused at once (the service answers RESOURCE_EXHAUSTED); nothing ever waits for a
/// slot, so an RPC thread that submits never blocks.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace wj::server {

/// One unit of work. `abandon` runs instead of `run` if the pool shuts down before the task
/// started (it must complete whatever the task would have completed, e.g. with UNAVAILABLE).
struct Task {
  std::function<void()> run;
  std::function<void()> abandon;
};

class BoundedExecutor {
 public:
  /// Which bound applies to a submission.
  enum class Lane {
    Request,   ///< work started by a client request: refused when `capacity` tasks wait
    Internal,  ///< continuation of work already admitted (bounded by its owner): always queued
  };

  /// `threads` >= 1 workers named `name`; at most `capacity` Request tasks wait.
  BoundedExecutor(std::string name, int threads, std::size_t capacity);
  /// Shuts down (see shutdown()).
  ~BoundedExecutor();
  BoundedExecutor(const BoundedExecutor&) = delete;
  BoundedExecutor& operator=(const BoundedExecutor&) = delete;

  /// Queues `task`; false (and the task untouched) if the lane is full or the pool is shut down.
  bool trySubmit(Task task, Lane lane = Lane::Request);
  /// Stops accepting tasks, abandons the queued ones, waits for the running ones. Idempotent.
  void shutdown();
  /// Tasks waiting (not running).
  std::size_t queued() const;
  /// Tasks running now.
  std::size_t running() const;
  int threads() const { return static_cast<int>(workers_.size()); }

 private:
  void workerLoop();

  std::string name_;
  std::size_t capacity_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Task> queue_;
  std::size_t running_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace wj::server
