#pragma once
/// @file The jump state machine of the robot client:
///
///   STAND -> ROLL -> PLAN -> TAKEOFF -> FLIGHT -> LANDING -> BRAKE -> STAND
///                                                           \-> ROLL (roll on) -> BRAKE -> STAND
///                                                           \-> ROLL (a course: the next wall)
///                                                                  -> PLAN -> TAKEOFF ...
///                      \-> BRAKE (no plan by the decision point, infeasible plan, planner
///                                 unreachable) -> STAND
///                      \-> PLAN (an infeasible or failed answer with retries left and the
///                                decision point ahead: the plan requested again)
///   any state -> DAMPING (estimator divergence, motor fault, watchdog, attitude limit)
///
/// Pure logic: step() takes what the loop measured and returns what the loop must do; it
/// neither allocates nor logs. Transitions are recorded in a fixed-size journal that a
/// non-real-time thread drains and logs.

#include <array>
#include <cstdint>
#include <string_view>

#include "robot_client/client_settings.h"

namespace wj::robot_client {

enum class Mode : std::uint8_t { Stand, Roll, Plan, Takeoff, Flight, Landing, Brake, Damping };
std::string_view toString(Mode mode);

/// Why a transition happened.
enum class Reason : std::uint8_t {
  Start,              ///< standing time over
  RunUpSpeedReached,  ///< speed within tolerance of the run-up speed: plan requested
  PlanRequested,      ///< standing jump: plan requested
  TakeoffPoint,       ///< plan in hand and the take-off point reached
  Lifted,             ///< the executor switched to flight
  TouchedDown,        ///< the executor switched to landing
  Landed,             ///< landing phase over
  RollOn,             ///< landing phase over, rolling on
  NextWall,           ///< landing phase over, rolling on to the next wall of a course
  RolledOn,           ///< rolled on after the landing for the scenario's time
  PlatformEnd,        ///< rolling on along a platform: a stop now ends at its edge margin
  NoPlanByDecisionPoint,
  PlanInfeasible,
  PlannerFailed,  ///< unreachable, deadline exceeded, or an error status
  PlanRetry,      ///< infeasible or failed answer, retries left: the plan requested again
  Stopped,        ///< speed below the stop threshold
  EstimatorDiverged,
  MotorFault,
  Watchdog,
  AttitudeLimit,
  EndOfRun,
};
std::string_view toString(Reason reason);

/// Status of the plan request as the loop sees it.
enum class PlanStatus : std::uint8_t { None, Pending, Feasible, Infeasible, Failed };

/// What the loop measured this period.
struct FsmInput {
  double t = 0.0;      ///< robot time [s]
  double com_x = 0.0;  ///< estimated CoM x in W [m]
  double speed = 0.0;  ///< estimated forward speed [m/s]
  double roll = 0.0;   ///< [rad]
  double pitch = 0.0;  ///< [rad]
  PlanStatus plan = PlanStatus::None;
  bool executor_in_flight = false;  ///< the plan executor is in its flight phase
  bool executor_landing = false;    ///< ... in its landing phase
  bool executor_finished = false;   ///< ... and the landing is over
  bool estimator_diverged = false;
  bool motor_fault = false;
  bool watchdog_tripped = false;
};

/// What the loop must do this period.
struct FsmOutput {
  Mode mode = Mode::Stand;
  bool request_plan = false;   ///< send the plan request now (once)
  bool start_takeoff = false;  ///< start executing the plan now (once)
  bool brake = false;          ///< set the speed command to a stop now (once)
  bool start_roll = false;     ///< set the run-up speed command now (once)
  bool roll_on = false;        ///< set the roll-on speed command now (once, after a landing)
};

/// One journal entry.
struct Transition {
  double t = 0.0;
  Mode from = Mode::Stand;
  Mode to = Mode::Stand;
  Reason reason = Reason::Start;
  double com_x = 0.0;
  double speed = 0.0;
};

class JumpStateMachine {
 public:
  static constexpr int kJournalSize = 64;

  /// `plan_retries`: how many times an infeasible or failed answer is followed by a new
  /// request while the decision point is ahead (PlannerConnection::retries).
  JumpStateMachine(const ScenarioSettings& scenario, const SafetySettings& safety,
                   int plan_retries = 0);

  /// One control period. No allocation, no logging.
  FsmOutput step(const FsmInput& in);

  Mode mode() const { return mode_; }
  /// Take-off point: CoM x at which the take-off starts (forward scenario) [m].
  double takeoffComX() const { return takeoff_com_x_; }
  /// The wall being approached (index into ScenarioSettings::wall_x_m): 0 until the first
  /// landing, then the next wall of a course; jumps() once every wall has been jumped.
  int wallIndex() const { return wall_index_; }
  /// The current wall's near face as perceived in the estimator's frame (odometry drifts, a
  /// range measurement does not): moves the take-off and decision points. Ignored during a
  /// jump, after the last one, or without a wall.
  void setWallX(double wall_x_m) {
    if (scenario_.has_wall && !inJump() && wall_index_ < scenario_.jumps())
      takeoff_com_x_ = wall_x_m - scenario_.takeoff_to_wall_m - scenario_.takeoff_lead_m;
  }
  /// Decision point: the plan must be in hand before the CoM passes it [m].
  double decisionComX() const { return takeoff_com_x_ - scenario_.decision_margin_m; }
  /// Whether the robot landed and rolled on (entered ROLL after LANDING).
  bool rolledOn() const { return rolled_on_; }
  /// Whether the robot jumped (take-off started) during the run.
  bool jumped() const { return jumped_; }
  /// Jumps whose landing phase is over.
  int landings() const { return landings_; }
  /// The current jump's plan request: 0 the first, n the n-th retry.
  int planAttempt() const { return plan_attempt_; }
  /// The abort that ended the jump attempt, or Reason::Start if none.
  Reason abortReason() const { return abort_reason_; }

  /// Transitions recorded so far (ring of kJournalSize; `count()` keeps counting).
  int journalCount() const { return journal_count_; }
  const Transition& journal(int i) const { return journal_[i % kJournalSize]; }

 private:
  void enter(Mode to, Reason why, const FsmInput& in);
  bool inJump() const {
    return mode_ == Mode::Takeoff || mode_ == Mode::Flight || mode_ == Mode::Landing;
  }
  // A jump is still to come (the run-up, the plan request and the take-off are armed).
  bool armed() const { return wall_index_ < scenario_.jumps(); }
  // After a landing on a platform: a stop from `in`'s speed at the safety brake's
  // deceleration would end within the scenario's edge margin of the platform's far end (the
  // near face as last perceived, setWallX, plus the thickness).
  bool platformEndAhead(const FsmInput& in) const;

  ScenarioSettings scenario_;
  SafetySettings safety_;
  Mode mode_ = Mode::Stand;
  double mode_since_ = 0.0;
  double takeoff_com_x_ = 0.0;
  double ramp_end_t_ = 0.0;  // end of the speed ramp of the current run-up [s]
  int wall_index_ = 0;
  int landings_ = 0;
  int plan_retries_ = 0;
  int plan_attempt_ = 0;
  bool jumped_ = false;
  bool rolled_on_ = false;
  Reason abort_reason_ = Reason::Start;
  std::array<Transition, kJournalSize> journal_{};
  int journal_count_ = 0;
};

}  // namespace wj::robot_client
