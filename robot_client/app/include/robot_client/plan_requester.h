#pragma once
/// @file Asynchronous jump-plan requests for the control loop. The loop posts a fixed-size
/// snapshot (no allocation, no lock: an atomic flag and a futex wake-up); a worker thread builds
/// the PlanJumpRequest, calls the planning service through wj::client::PlannerClient with a
/// deadline, converts the answer into a planner::JumpPlan off the loop, and publishes it with
/// a release store of the status. The loop polls status() and, once it says Feasible, reads
/// plan() (immutable from then on until the next post()).

#include <array>
#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "planner/jump_plan.h"
#include "robot_client/client_settings.h"
#include "robot_client/jump_state_machine.h"
#include "robot_model/robot_model.h"
#include "sim/plan_executor.h"

namespace wheeljump::planner::v1 {
class PlanJumpResponse;
}
namespace wj::client {
class PlannerClient;
}

namespace wj::robot_client {

/// What the loop hands over for one request (fixed size).
struct PlanRequestSnapshot {
  double t = 0.0;                                  ///< robot time [s]
  Eigen::Vector3d p_WB = Eigen::Vector3d::Zero();  ///< base position [m]
  Eigen::Quaterniond q_WB = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_WB = Eigen::Vector3d::Zero();     ///< base velocity in W [m/s]
  Eigen::Vector3d omega_B = Eigen::Vector3d::Zero();  ///< angular velocity in B [rad/s]
  std::array<double, model::kNumJoints> q{};          ///< [rad]
  std::array<double, model::kNumJoints> qd{};         ///< [rad/s]
  // The task, in the jump frame J (origin on the ground below the CoM at take-off start).
  double target_dx_m = 0.0;
  double target_height_m = 0.0;  ///< CoM height at the event [m]
  double target_pitch_change_rad = 0.0;
  planner::TargetEvent event = planner::TargetEvent::Touchdown;
  planner::TakeoffMode mode = planner::TakeoffMode::Simultaneous;
  bool has_obstacle = false;
  double obstacle_x_min_m = 0.0, obstacle_x_max_m = 0.0, obstacle_height_m = 0.0;
  /// Fly a plan that meets every constraint but misses the target (the planner's closest
  /// approach, e.g. the highest apex in reach), if its verification passed.
  bool accept_closest_approach = false;
  /// DE seed of this request; 0: the connection's (PlannerConnection::seed).
  std::uint64_t seed = 0;
};

/// How the last request went (for the summary; read outside the loop).
/// The base velocity a plan request carries: `v_WB` with its speed along the base's heading
/// (x_B on the ground, as the service reads it) clamped to the planner's lowest,
/// kPlannerLowestSpeedMS; a backward run-up at -1 m/s is measured up to its speed tolerance
/// past it. Unchanged otherwise.
Eigen::Vector3d requestVelocity(const Eigen::Vector3d& v_WB, const Eigen::Quaterniond& q_WB);

/// The leg angles a plan request carries with a take-off posture (ScenarioSettings::
/// has_takeoff_posture): every HFE and KFE of `q` set to the scenario's when each measured one
/// is within its takeoff_posture_max_offset_rad; `q` unchanged otherwise (the wheels and the
/// hip abductions are never changed). Returns whether the posture was applied.
bool applyTakeoffPosture(const ScenarioSettings& scenario,
                         std::array<double, model::kNumJoints>& q);

struct PlanRequestInfo {
  double latency_ms = 0.0;   ///< post() to the answer, wall time
  std::string source;        ///< cache_hit, cache_hit_ready, cache_miss, warm_start, coalesced
  std::string verification;  ///< passed, failed, not_run
  std::string summary;       ///< feasibility summary or the error status
  int attempts = 0;
  bool feasible = false;
  /// Not feasible, but every constraint held and the request accepted the closest approach.
  bool closest_approach = false;
  double target_height_m = 0.0;  ///< the CoM height the request asked for [m]
  planner::JumpOutcome predicted;
  planner::JumpOutcome simulated;  ///< the service's verification run, if any
};

class PlanRequester {
 public:
  /// `target` is HOST:PORT (or any gRPC target). The executor of a feasible plan is built on
  /// the worker thread with `robot`, `executor` and `gravity_m_s2` (its construction
  /// allocates). Starts the worker thread.
  PlanRequester(const std::string& target, const PlannerConnection& connection,
                const model::RobotModel& robot, const sim::ExecutorSettings& executor,
                double gravity_m_s2);
  ~PlanRequester();
  PlanRequester(const PlanRequester&) = delete;
  PlanRequester& operator=(const PlanRequester&) = delete;

  /// Real-time safe. Starts a request from `snapshot`; returns false if one is in flight.
  bool post(const PlanRequestSnapshot& snapshot);
  /// Status of the last request (acquire load).
  PlanStatus status() const { return status_.load(std::memory_order_acquire); }
  /// The plan, valid once status() == Feasible.
  const planner::JumpPlan& plan() const { return plan_; }
  /// Its executor, ready to run, once status() == Feasible (the loop's thread only).
  sim::PlanExecutor* executor() { return executor_ ? &*executor_ : nullptr; }
  /// Details of the last finished request (not real-time: copies strings under the worker's
  /// publication; call once status() is final).
  const PlanRequestInfo& info() const { return info_; }

  /// Converts a response into a plan; returns "" or what makes the plan unusable.
  static std::string convert(const wheeljump::planner::v1::PlanJumpResponse& response,
                             planner::JumpPlan& plan);

 private:
  void run();
  void handle(const PlanRequestSnapshot& snapshot);

  PlannerConnection connection_;
  const model::RobotModel& robot_;
  sim::ExecutorSettings executor_settings_;
  double gravity_;
  std::unique_ptr<client::PlannerClient> client_;
  PlanRequestSnapshot slot_;
  std::atomic<int> slot_state_{0};  // 0 empty, 1 posted, 2 taken
  std::atomic<bool> stop_{false};
  std::atomic<PlanStatus> status_{PlanStatus::None};
  planner::JumpPlan plan_;
  std::optional<sim::PlanExecutor> executor_;
  PlanRequestInfo info_;
  std::thread worker_;
};

}  // namespace wj::robot_client
