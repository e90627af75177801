#include "robot_client/mpc_worker.h"

#include <algorithm>

#include "rt/periodic_timer.h"

namespace wj::robot_client {

MpcWorker::MpcWorker(nmpc::LocomotionController& controller, double mpc_period_s, bool lockstep)
    : controller_(controller),
      period_(std::chrono::nanoseconds(static_cast<long>(mpc_period_s * 1e9))),
      lockstep_(lockstep) {}

MpcWorker::~MpcWorker() {
  stop();
}

void MpcWorker::start() {
  if (thread_.joinable()) return;
  stop_.store(false);
  thread_ = std::thread([this] { run(); });
}

void MpcWorker::stop() {
  if (!thread_.joinable()) return;
  stop_.store(true);
  posted_.fetch_add(1);
  posted_.notify_all();
  thread_.join();
}

void MpcWorker::post(const MpcInput& input) {
  inputs_.publish(input);
  if (!lockstep_) return;
  const std::uint64_t ticket = posted_.fetch_add(1, std::memory_order_acq_rel) + 1;
  posted_.notify_one();
  // Wait for the cycle of this ticket (futex wait: no spinning, no lock).
  for (std::uint64_t d = done_.load(std::memory_order_acquire); d < ticket;
       d = done_.load(std::memory_order_acquire))
    done_.wait(d, std::memory_order_acquire);
}

void MpcWorker::cycle(const MpcInput& in) {
  if (!in.active) {
    was_active_ = false;
    return;
  }
  if (in.command_version != applied_command_) {
    controller_.setSpeedCommand(in.command);
    applied_command_ = in.command_version;
  }
  if (!was_active_) controller_.restart();
  const auto t0 = std::chrono::steady_clock::now();
  nmpc::SqpStatus status = controller_.updateMpc(in.t, in.x);
  // (Re)starting: a few more iterations at the same instant, from a stale or empty guess.
  if (!was_active_)
    for (int i = 0; i < 4; ++i) status = controller_.updateMpc(in.t, in.x);
  was_active_ = true;
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  cycles_.fetch_add(1, std::memory_order_relaxed);
  if (status == nmpc::SqpStatus::LineSearchFailed || status == nmpc::SqpStatus::RiccatiFailed)
    failed_.fetch_add(1, std::memory_order_relaxed);
  const double violation = controller_.solver().stats().violation;
  if (violation > max_violation_.load(std::memory_order_relaxed))
    max_violation_.store(violation, std::memory_order_relaxed);
  last_ms_.store(ms, std::memory_order_relaxed);
  if (ms > max_ms_.load(std::memory_order_relaxed)) max_ms_.store(ms, std::memory_order_relaxed);
}

void MpcWorker::run() {
  MpcInput in;
  if (lockstep_) {
    std::uint64_t handled = 0;
    while (!stop_.load()) {
      const std::uint64_t p = posted_.load(std::memory_order_acquire);
      if (p == handled) {
        posted_.wait(p, std::memory_order_acquire);
        continue;
      }
      if (stop_.load()) break;
      inputs_.fetch(in);
      cycle(in);
      handled = p;
      done_.store(p, std::memory_order_release);
      done_.notify_one();
    }
    done_.store(~std::uint64_t{0});
    done_.notify_all();
    return;
  }
  rt::PeriodicTimer timer(period_);
  timer.start();
  bool have = false;
  while (!stop_.load()) {
    if (inputs_.fetch(in)) have = true;
    if (have) cycle(in);
    timer.waitNext();
  }
}

MpcCounters MpcWorker::counters() const {
  MpcCounters c;
  c.cycles = cycles_.load();
  c.iterations_per_cycle = controller_.solver().settings().max_iterations;
  c.failed = failed_.load();
  c.max_violation = max_violation_.load();
  c.last_ms = last_ms_.load();
  c.max_ms = max_ms_.load();
  return c;
}

}  // namespace wj::robot_client
