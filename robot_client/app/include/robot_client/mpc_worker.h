#pragma once
/// @file The NMPC thread. The control loop hands it the latest estimated state and speed
/// command through a lock-free double buffer; the thread runs LocomotionController::updateMpc(),
/// which publishes the policy back to the loop through its own triple buffer. Two schedules:
///  - free-running (hardware): the thread cycles every mpc_period on its own clock with
///    the newest input;
///  - lockstep (simulation, simulated time): the loop posts an input at each MPC tick and
///    waits for that cycle to finish, as if the MPC always met its deadline. Runs are then
///    reproducible whatever the machine's load.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>

#include "nmpc/locomotion_controller.h"
#include "rt/double_buffer.h"

namespace wj::robot_client {

/// What the loop sends to the NMPC thread.
struct MpcInput {
  double t = 0.0;
  nmpc::State x = nmpc::State::Zero();
  nmpc::SpeedCommand command;
  std::uint32_t command_version = 0;  ///< bumped when `command` changes
  bool active = true;                 ///< false during a jump: the NMPC pauses
};

/// Counters of the NMPC thread.
struct MpcCounters {
  std::uint64_t cycles = 0;
  /// SQP iterations per cycle (1: a real-time iteration, which ends at its iteration limit
  /// by design; convergence is not its test).
  int iterations_per_cycle = 1;
  /// Cycles whose SQP step failed (line search or Riccati): the previous solution was kept.
  std::uint64_t failed = 0;
  double max_violation = 0.0;  ///< largest dynamics/equality residual after a cycle
  double last_ms = 0.0;
  double max_ms = 0.0;
};

class MpcWorker {
 public:
  /// `controller` must outlive the worker; only this worker's thread calls its MPC side.
  MpcWorker(nmpc::LocomotionController& controller, double mpc_period_s, bool lockstep);
  ~MpcWorker();
  MpcWorker(const MpcWorker&) = delete;
  MpcWorker& operator=(const MpcWorker&) = delete;

  void start();
  void stop();
  /// Loop side, real-time safe: hands over the newest input. In lockstep mode also waits
  /// until the NMPC cycle of this input has finished (simulated time stands still meanwhile).
  void post(const MpcInput& input);
  /// Counters (approximate while running).
  MpcCounters counters() const;

 private:
  void run();
  void cycle(const MpcInput& in);

  nmpc::LocomotionController& controller_;
  std::chrono::nanoseconds period_;
  bool lockstep_;
  rt::DoubleBuffer<MpcInput> inputs_;
  std::atomic<std::uint64_t> posted_{0};
  std::atomic<std::uint64_t> done_{0};
  std::atomic<bool> stop_{false};
  std::uint32_t applied_command_ = 0;
  bool was_active_ = false;
  std::atomic<std::uint64_t> cycles_{0}, failed_{0};
  std::atomic<double> last_ms_{0.0}, max_ms_{0.0}, max_violation_{0.0};
  std::thread thread_;
};

}  // namespace wj::robot_client
