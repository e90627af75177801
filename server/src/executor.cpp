#include "server/executor.h"

#include <pthread.h>

namespace wj::server {

BoundedExecutor::BoundedExecutor(std::string name, int threads, std::size_t capacity)
    : name_(std::move(name)), capacity_(capacity) {
  const int n = threads < 1 ? 1 : threads;
  workers_.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    workers_.emplace_back([this] { workerLoop(); });
    // Thread names help in top/gdb; Linux limits them to 15 characters.
    const std::string thread_name = (name_ + "-" + std::to_string(i)).substr(0, 15);
    pthread_setname_np(workers_.back().native_handle(), thread_name.c_str());
  }
}

BoundedExecutor::~BoundedExecutor() {
  shutdown();
}

bool BoundedExecutor::trySubmit(Task task, Lane lane) {
  {
    std::lock_guard lock(mu_);
    if (stopping_) return false;
    if (lane == Lane::Request && queue_.size() >= capacity_) return false;
    queue_.push_back(std::move(task));
  }
  cv_.notify_one();
  return true;
}

void BoundedExecutor::workerLoop() {
  for (;;) {
    Task task;
    {
      std::unique_lock lock(mu_);
      cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping and drained
      task = std::move(queue_.front());
      queue_.pop_front();
      ++running_;
    }
    if (task.run) task.run();
    std::lock_guard lock(mu_);
    --running_;
  }
}

void BoundedExecutor::shutdown() {
  std::deque<Task> abandoned;
  {
    std::lock_guard lock(mu_);
    if (stopping_ && workers_.empty()) return;
    stopping_ = true;
    abandoned.swap(queue_);
  }
  cv_.notify_all();
  for (auto& t : abandoned)
    if (t.abandon) t.abandon();
  for (auto& w : workers_)
    if (w.joinable()) w.join();
  workers_.clear();
}

std::size_t BoundedExecutor::queued() const {
  std::lock_guard lock(mu_);
  return queue_.size();
}

std::size_t BoundedExecutor::running() const {
  std::lock_guard lock(mu_);
  return running_;
}

}  // namespace wj::server
