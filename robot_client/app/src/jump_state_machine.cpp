#include "robot_client/jump_state_machine.h"

#include <cmath>

namespace wj::robot_client {

std::string_view toString(Mode mode) {
  switch (mode) {
    case Mode::Stand:
      return "STAND";
    case Mode::Roll:
      return "ROLL";
    case Mode::Plan:
      return "PLAN";
    case Mode::Takeoff:
      return "TAKEOFF";
    case Mode::Flight:
      return "FLIGHT";
    case Mode::Landing:
      return "LANDING";
    case Mode::Brake:
      return "BRAKE";
    case Mode::Damping:
      return "DAMPING";
  }
  return "?";
}

std::string_view toString(Reason reason) {
  switch (reason) {
    case Reason::Start:
      return "start";
    case Reason::RunUpSpeedReached:
      return "run-up speed reached, plan requested";
    case Reason::PlanRequested:
      return "plan requested";
    case Reason::TakeoffPoint:
      return "plan in hand at the take-off point";
    case Reason::Lifted:
      return "all wheels off the ground";
    case Reason::TouchedDown:
      return "touchdown";
    case Reason::Landed:
      return "landing over";
    case Reason::RollOn:
      return "landing over, rolling on";
    case Reason::NextWall:
      return "landing over, rolling on to the next wall";
    case Reason::RolledOn:
      return "rolled on";
    case Reason::PlatformEnd:
      return "the platform's far end ahead";
    case Reason::NoPlanByDecisionPoint:
      return "no plan by the decision point";
    case Reason::PlanInfeasible:
      return "no usable plan (infeasible, or refused by the service's verification)";
    case Reason::PlannerFailed:
      return "planner unreachable or failed";
    case Reason::PlanRetry:
      return "no usable plan, requested again";
    case Reason::Stopped:
      return "stopped";
    case Reason::EstimatorDiverged:
      return "state estimator diverged";
    case Reason::MotorFault:
      return "motor fault";
    case Reason::Watchdog:
      return "control loop watchdog";
    case Reason::AttitudeLimit:
      return "attitude beyond the safety limit";
    case Reason::EndOfRun:
      return "end of run";
  }
  return "?";
}

JumpStateMachine::JumpStateMachine(const ScenarioSettings& scenario, const SafetySettings& safety,
                                   int plan_retries)
    : scenario_(scenario), safety_(safety), plan_retries_(plan_retries) {
  takeoff_com_x_ = scenario_.has_wall
                       ? scenario_.wallX(0) - scenario_.takeoff_to_wall_m - scenario_.takeoff_lead_m
                       : 0.0;
}

bool JumpStateMachine::platformEndAhead(const FsmInput& in) const {
  if (!scenario_.landsOnWall()) return false;
  const double far_end = takeoff_com_x_ + scenario_.takeoff_to_wall_m + scenario_.takeoff_lead_m +
                         scenario_.wall_thickness_m;
  const double stop_x = in.com_x + in.speed * std::abs(in.speed) / (2.0 * safety_.brake_decel_m_s2);
  return stop_x >= far_end - scenario_.edge_margin_m;
}

void JumpStateMachine::enter(Mode to, Reason why, const FsmInput& in) {
  Transition& tr = journal_[journal_count_ % kJournalSize];
  tr = {in.t, mode_, to, why, in.com_x, in.speed};
  ++journal_count_;
  mode_ = to;
  mode_since_ = in.t;
}

FsmOutput JumpStateMachine::step(const FsmInput& in) {
  FsmOutput out;
  const bool jumping = inJump();
  if (mode_ != Mode::Damping) {
    Reason fault = Reason::Start;
    if (in.motor_fault)
      fault = Reason::MotorFault;
    else if (in.estimator_diverged)
      fault = Reason::EstimatorDiverged;
    else if (in.watchdog_tripped)
      fault = Reason::Watchdog;
    else if (!jumping && (std::abs(in.roll) > safety_.max_roll_rad ||
                          std::abs(in.pitch) > safety_.max_pitch_rad))
      fault = Reason::AttitudeLimit;
    if (fault != Reason::Start) {
      if (!jumped_ && abort_reason_ == Reason::Start) abort_reason_ = fault;
      enter(Mode::Damping, fault, in);
    }
  }
  const bool standing_jump = scenario_.run_up_speed_m_s == 0.0;
  const auto abort = [&](Reason why) {
    abort_reason_ = why;
    out.brake = true;
    enter(standing_jump ? Mode::Stand : Mode::Brake, why, in);
  };

  switch (mode_) {
    case Mode::Stand:
      if (!jumped_ && abort_reason_ == Reason::Start && in.t >= scenario_.stand_s) {
        if (standing_jump) {
          takeoff_com_x_ = in.com_x;
          out.request_plan = true;
          plan_attempt_ = 0;
          enter(Mode::Plan, Reason::PlanRequested, in);
        } else {
          out.start_roll = true;
          ramp_end_t_ = in.t + std::abs(scenario_.run_up_speed_m_s) / scenario_.acceleration_m_s2;
          enter(Mode::Roll, Reason::Start, in);
        }
      }
      break;
    case Mode::Roll:
      if (!armed()) {
        // Rolling on after the last landing, then a stop: after the scenario's time, or
        // sooner where a platform ends.
        if (in.t >= mode_since_ + scenario_.roll_on_s) {
          out.brake = true;
          enter(Mode::Brake, Reason::RolledOn, in);
        } else if (platformEndAhead(in)) {
          out.brake = true;
          enter(Mode::Brake, Reason::PlatformEnd, in);
        }
      } else if (scenario_.has_wall && in.com_x >= decisionComX()) {
        abort(Reason::NoPlanByDecisionPoint);
      } else if (in.t >= ramp_end_t_ &&
                 std::abs(in.speed - scenario_.run_up_speed_m_s) < scenario_.speed_tolerance_m_s) {
        if (!scenario_.has_wall) takeoff_com_x_ = in.com_x;
        out.request_plan = true;
        plan_attempt_ = 0;
        enter(Mode::Plan, Reason::RunUpSpeedReached, in);
      }
      break;
    case Mode::Plan:
      if ((in.plan == PlanStatus::Infeasible || in.plan == PlanStatus::Failed) &&
          plan_attempt_ < plan_retries_ && (!scenario_.has_wall || in.com_x < decisionComX())) {
        // Another search (the next seed) from the state measured now; the decision point
        // still bounds the wait.
        ++plan_attempt_;
        out.request_plan = true;
        enter(Mode::Plan, Reason::PlanRetry, in);
      } else if (in.plan == PlanStatus::Infeasible) {
        abort(Reason::PlanInfeasible);
      } else if (in.plan == PlanStatus::Failed) {
        abort(Reason::PlannerFailed);
      } else if (in.plan == PlanStatus::Feasible) {
        if (!scenario_.has_wall || in.com_x >= takeoff_com_x_) {
          out.start_takeoff = true;
          jumped_ = true;
          enter(Mode::Takeoff, Reason::TakeoffPoint, in);
        }
      } else if (scenario_.has_wall ? in.com_x >= decisionComX()
                                    : in.t - mode_since_ > scenario_.plan_timeout_s) {
        abort(Reason::NoPlanByDecisionPoint);
      }
      break;
    case Mode::Takeoff:
      if (in.executor_in_flight) enter(Mode::Flight, Reason::Lifted, in);
      if (in.executor_landing) enter(Mode::Landing, Reason::TouchedDown, in);
      break;
    case Mode::Flight:
      if (in.executor_landing) enter(Mode::Landing, Reason::TouchedDown, in);
      break;
    case Mode::Landing:
      if (in.executor_finished) {
        ++landings_;
        ++wall_index_;
        if (armed()) {
          // A course: the next wall's run-up starts from the landing's hand-over speed (the
          // roll-on speed) and ramps for what remains to the run-up speed.
          out.start_roll = true;
          rolled_on_ = true;
          takeoff_com_x_ =
              scenario_.wallX(wall_index_) - scenario_.takeoff_to_wall_m - scenario_.takeoff_lead_m;
          ramp_end_t_ =
              in.t + std::abs(scenario_.run_up_speed_m_s - in.speed) / scenario_.acceleration_m_s2;
          enter(Mode::Roll, Reason::NextWall, in);
        } else if (scenario_.after_landing == AfterLanding::RollOn) {
          out.roll_on = true;
          rolled_on_ = true;
          enter(Mode::Roll, Reason::RollOn, in);
        } else {
          out.brake = true;
          enter(Mode::Brake, Reason::Landed, in);
        }
      }
      break;
    case Mode::Brake:
      if (std::abs(in.speed) < safety_.stopped_speed_m_s) enter(Mode::Stand, Reason::Stopped, in);
      break;
    case Mode::Damping:
      break;
  }
  out.mode = mode_;
  return out;
}

}  // namespace wj::robot_client
