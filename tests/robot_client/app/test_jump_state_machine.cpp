#include <gtest/gtest.h>

#include "robot_client/jump_state_machine.h"

namespace wj::robot_client {
namespace {

ScenarioSettings forward() {
  ScenarioSettings s;  // defaults: run-up 3 m/s, wall at 6 m, take-off 1.2 m before it
  s.stand_s = 0.5;
  s.wall_x_m = {10.0};
  return s;
}

ScenarioSettings vertical() {
  ScenarioSettings s;
  s.name = "vertical";
  s.run_up_speed_m_s = 0.0;
  s.has_wall = false;
  s.stand_s = 1.0;
  s.plan_timeout_s = 2.0;
  return s;
}

// Drives the machine through time with a simple kinematic robot.
struct Drive {
  JumpStateMachine fsm;
  FsmInput in;
  int requests = 0, takeoffs = 0, brakes = 0, rolls = 0;
  explicit Drive(const ScenarioSettings& s, int retries = 0) : fsm(s, SafetySettings{}, retries) {}
  FsmOutput tick(double dt = 0.01) {
    in.t += dt;
    in.com_x += in.speed * dt;
    const FsmOutput out = fsm.step(in);
    requests += out.request_plan;
    takeoffs += out.start_takeoff;
    brakes += out.brake;
    rolls += out.start_roll;
    return out;
  }
  // Ticks until `mode` or the time limit.
  bool until(Mode mode, double t_max) {
    while (in.t < t_max) {
      if (tick().mode == mode) return true;
    }
    return false;
  }
};

TEST(JumpStateMachine, ForwardJumpGoesThroughEveryPhaseInOrder) {
  Drive d(forward());
  ASSERT_TRUE(d.until(Mode::Roll, 1.0));
  EXPECT_NEAR(d.in.t, 0.5, 0.011);
  EXPECT_EQ(d.rolls, 1);
  d.in.speed = 2.0;  // still accelerating: no request
  d.tick();
  EXPECT_EQ(d.fsm.mode(), Mode::Roll);
  d.in.speed = 2.99;  // at speed before the ramp ends (t = 0.5 + 3 / 1.5): no request yet
  d.tick();
  EXPECT_EQ(d.fsm.mode(), Mode::Roll);
  ASSERT_TRUE(d.until(Mode::Plan, 3.0));
  EXPECT_NEAR(d.in.t, 2.5, 0.011);
  EXPECT_EQ(d.requests, 1);
  d.in.plan = PlanStatus::Pending;
  d.tick();
  d.in.plan = PlanStatus::Feasible;  // in hand well before the decision point
  ASSERT_TRUE(d.until(Mode::Takeoff, 10.0));
  EXPECT_GE(d.in.com_x, 10.0 - 1.2 - 1e-9);  // the take-off point
  EXPECT_LT(d.in.com_x, 10.0 - 1.2 + 0.031);
  EXPECT_EQ(d.takeoffs, 1);
  EXPECT_TRUE(d.fsm.jumped());
  d.in.executor_in_flight = true;
  EXPECT_EQ(d.tick().mode, Mode::Flight);
  d.in.executor_in_flight = false;
  d.in.executor_landing = true;
  EXPECT_EQ(d.tick().mode, Mode::Landing);
  d.in.executor_finished = true;
  const FsmOutput out = d.tick();
  EXPECT_EQ(out.mode, Mode::Brake);
  EXPECT_TRUE(out.brake);
  d.in.speed = 0.01;
  EXPECT_EQ(d.tick().mode, Mode::Stand);
  // And it stays standing: one jump per run.
  for (int i = 0; i < 100; ++i) d.tick();
  EXPECT_EQ(d.fsm.mode(), Mode::Stand);
  EXPECT_EQ(d.requests, 1);
  ASSERT_EQ(d.fsm.journalCount(), 7);
  const Mode expected[] = {Mode::Roll,    Mode::Plan,  Mode::Takeoff, Mode::Flight,
                           Mode::Landing, Mode::Brake, Mode::Stand};
  for (int i = 0; i < 7; ++i) EXPECT_EQ(d.fsm.journal(i).to, expected[i]) << i;
}

TEST(JumpStateMachine, AfterTheLandingItRollsOnAtTheCommandedSpeedThenStops) {
  ScenarioSettings sc = forward();
  sc.after_landing = AfterLanding::RollOn;
  sc.roll_on_speed_m_s = 2.5;
  sc.roll_on_s = 1.5;
  Drive d(sc);
  int roll_ons = 0;
  d.in.speed = 3.0;
  ASSERT_TRUE(d.until(Mode::Plan, 5.0));
  d.in.plan = PlanStatus::Feasible;
  ASSERT_TRUE(d.until(Mode::Takeoff, 10.0));
  d.in.executor_in_flight = true;
  d.tick();
  d.in.executor_in_flight = false;
  d.in.executor_landing = true;
  d.tick();
  ASSERT_EQ(d.fsm.mode(), Mode::Landing);
  d.in.executor_finished = true;
  const FsmOutput out = d.tick();
  roll_ons += out.roll_on;
  EXPECT_EQ(out.mode, Mode::Roll);
  EXPECT_TRUE(out.roll_on);
  EXPECT_FALSE(out.brake);
  EXPECT_TRUE(d.fsm.rolledOn());
  const double since = d.in.t;
  // Rolling on past the wall and the decision point: no new request, no abort, no brake.
  d.in.speed = 2.5;
  while (d.in.t < since + 1.5 - 0.02) {
    const FsmOutput o = d.tick();
    roll_ons += o.roll_on;
    ASSERT_EQ(o.mode, Mode::Roll) << d.in.t;
  }
  EXPECT_EQ(d.requests, 1);
  EXPECT_EQ(d.brakes, 0);
  ASSERT_TRUE(d.until(Mode::Brake, since + 1.6));
  EXPECT_NEAR(d.in.t, since + 1.5, 0.011);
  EXPECT_EQ(d.brakes, 1);
  EXPECT_EQ(roll_ons, 1);
  EXPECT_EQ(d.fsm.abortReason(), Reason::Start);
  d.in.speed = 0.0;
  EXPECT_EQ(d.tick().mode, Mode::Stand);
  const int n = d.fsm.journalCount();
  ASSERT_GE(n, 4);
  EXPECT_EQ(d.fsm.journal(n - 3).to, Mode::Roll);
  EXPECT_EQ(d.fsm.journal(n - 3).reason, Reason::RollOn);
  EXPECT_EQ(d.fsm.journal(n - 2).reason, Reason::RolledOn);
}

// Flies the jump that the machine is taking off into: flight, landing, landing over.
FsmOutput flyJump(Drive& d) {
  d.in.executor_in_flight = true;
  d.tick();
  d.in.executor_in_flight = false;
  d.in.executor_landing = true;
  d.tick();
  EXPECT_EQ(d.fsm.mode(), Mode::Landing);
  d.in.executor_finished = true;
  const FsmOutput out = d.tick();
  d.in.executor_landing = false;
  d.in.executor_finished = false;
  return out;
}

// Onto a platform (12 to 16 m): the roll-on ends early, once a stop at the safety brake's
// 2.5 m/s^2 would end within the edge margin of the far end as last perceived.
TEST(JumpStateMachine, OnAPlatformTheRollOnBrakesBeforeItsFarEnd) {
  ScenarioSettings sc = forward();
  sc.wall_x_m = {12.0};
  sc.wall_thickness_m = 4.0;
  sc.takeoff_to_wall_m = 1.6;
  sc.target_dx_m = 2.0;
  sc.after_landing = AfterLanding::RollOn;
  sc.roll_on_speed_m_s = 1.0;
  sc.roll_on_s = 30.0;
  sc.edge_margin_m = 0.5;
  ASSERT_TRUE(sc.landsOnWall());
  // Runs up, takes off, and lands at `x` with `speed`: the landing is over, it rolls on.
  const auto landAt = [](Drive& d, double x, double speed) {
    d.in.speed = 3.0;
    ASSERT_TRUE(d.until(Mode::Plan, 5.0));
    d.in.plan = PlanStatus::Feasible;
    ASSERT_TRUE(d.until(Mode::Takeoff, 10.0));
    d.in.com_x = x;
    d.in.speed = speed;
    flyJump(d);
  };
  Drive d(sc);
  d.fsm.setWallX(12.1);  // the range sensor sees the platform 0.1 m further
  landAt(d, 14.5, 1.0);
  ASSERT_EQ(d.fsm.mode(), Mode::Roll);
  // Far end 16.1: the stop (0.2 m from 1 m/s) may end at 15.6, so the brake comes at 15.4.
  ASSERT_TRUE(d.until(Mode::Brake, d.in.t + 5.0));
  EXPECT_NEAR(d.in.com_x, 15.4, 0.011);
  EXPECT_EQ(d.brakes, 1);
  EXPECT_EQ(d.fsm.journal(d.fsm.journalCount() - 1).reason, Reason::PlatformEnd);
  EXPECT_EQ(d.fsm.abortReason(), Reason::Start);

  // A faster hand-over brakes at once (the next period).
  Drive fast(sc);
  landAt(fast, 14.8, 2.0);  // stops 0.8 m on, beyond 15.5
  ASSERT_EQ(fast.fsm.mode(), Mode::Roll);
  EXPECT_EQ(fast.tick().mode, Mode::Brake);
}

TEST(JumpStateMachine, ACourseJumpsEveryWallInTurnWithoutStoppingThenRollsOnAndStops) {
  ScenarioSettings sc = forward();
  sc.wall_x_m = {10.0, 20.0};
  sc.after_landing = AfterLanding::RollOn;
  sc.roll_on_s = 1.0;
  Drive d(sc);
  d.in.speed = 3.0;
  ASSERT_TRUE(d.until(Mode::Plan, 5.0));
  d.in.plan = PlanStatus::Feasible;
  ASSERT_TRUE(d.until(Mode::Takeoff, 10.0));
  EXPECT_NEAR(d.in.com_x, 10.0 - 1.2, 0.031);
  d.in.speed = 2.9;  // the landing hands over a little slow
  FsmOutput out = flyJump(d);
  EXPECT_EQ(out.mode, Mode::Roll);
  EXPECT_TRUE(out.start_roll);  // the run-up speed again, from where the landing left it
  EXPECT_FALSE(out.brake);
  EXPECT_EQ(d.fsm.landings(), 1);
  EXPECT_EQ(d.fsm.wallIndex(), 1);
  EXPECT_NEAR(d.fsm.takeoffComX(), 20.0 - 1.2, 1e-12);
  EXPECT_EQ(d.fsm.journal(d.fsm.journalCount() - 1).reason, Reason::NextWall);
  // The ramp from 2.9 to 3 m/s lasts 0.1 / 1.5 s: no request before it ends, even at speed.
  d.in.plan = PlanStatus::Feasible;  // the first plan's status is still there
  d.in.speed = 3.0;
  const double landed = d.in.t;
  EXPECT_EQ(d.tick().mode, Mode::Roll);
  ASSERT_TRUE(d.until(Mode::Plan, landed + 1.0));
  EXPECT_NEAR(d.in.t, landed + 0.1 / 1.5, 0.011);
  EXPECT_EQ(d.requests, 2);
  ASSERT_TRUE(d.until(Mode::Takeoff, landed + 5.0));
  EXPECT_GE(d.in.com_x, 20.0 - 1.2 - 1e-9);
  EXPECT_LT(d.in.com_x, 20.0 - 1.2 + 0.031);
  EXPECT_EQ(d.takeoffs, 2);
  out = flyJump(d);
  EXPECT_EQ(out.mode, Mode::Roll);
  EXPECT_TRUE(out.roll_on);  // the last wall: roll on at the roll-on speed
  EXPECT_EQ(d.fsm.landings(), 2);
  const double since = d.in.t;
  ASSERT_TRUE(d.until(Mode::Brake, since + 1.1));
  EXPECT_NEAR(d.in.t, since + 1.0, 0.011);
  EXPECT_EQ(d.brakes, 1);
  EXPECT_EQ(d.requests, 2);
  EXPECT_EQ(d.fsm.abortReason(), Reason::Start);
}

TEST(JumpStateMachine, TheTakeoffLeadMovesTheTakeoffAndDecisionPointsNotTheWall) {
  ScenarioSettings sc = forward();
  sc.takeoff_lead_m = 0.05;
  Drive d(sc);
  EXPECT_NEAR(d.fsm.takeoffComX(), 10.0 - 1.2 - 0.05, 1e-12);
  EXPECT_NEAR(d.fsm.decisionComX(), 10.0 - 1.2 - 0.05 - 1.0, 1e-12);
  d.fsm.setWallX(10.3);  // the range sensor's wall
  EXPECT_NEAR(d.fsm.takeoffComX(), 10.3 - 1.2 - 0.05, 1e-12);
  d.in.speed = 3.0;
  ASSERT_TRUE(d.until(Mode::Plan, 5.0));
  d.in.plan = PlanStatus::Feasible;
  ASSERT_TRUE(d.until(Mode::Takeoff, 10.0));
  EXPECT_GE(d.in.com_x, 10.3 - 1.25 - 1e-9);
  EXPECT_LT(d.in.com_x, 10.3 - 1.25 + 0.031);
}

TEST(JumpStateMachine, ACourseWithoutAPlanForTheNextWallBrakesBeforeIt) {
  ScenarioSettings sc = forward();
  sc.wall_x_m = {10.0, 20.0};
  sc.after_landing = AfterLanding::RollOn;
  Drive d(sc);
  d.in.speed = 3.0;
  ASSERT_TRUE(d.until(Mode::Plan, 5.0));
  d.in.plan = PlanStatus::Feasible;
  ASSERT_TRUE(d.until(Mode::Takeoff, 10.0));
  flyJump(d);
  d.in.plan = PlanStatus::Feasible;
  ASSERT_TRUE(d.until(Mode::Plan, d.in.t + 1.0));
  d.in.plan = PlanStatus::Pending;  // never answered
  ASSERT_TRUE(d.until(Mode::Brake, d.in.t + 10.0));
  EXPECT_NEAR(d.in.com_x, 20.0 - 1.2 - 1.0, 0.031);  // the second wall's decision point
  EXPECT_EQ(d.fsm.abortReason(), Reason::NoPlanByDecisionPoint);
  EXPECT_EQ(d.fsm.landings(), 1);
  EXPECT_EQ(d.takeoffs, 1);
}

TEST(JumpStateMachine, NoPlanByTheDecisionPointBrakesBeforeTheWall) {
  Drive d(forward());
  d.until(Mode::Roll, 1.0);
  d.in.speed = 3.0;
  ASSERT_TRUE(d.until(Mode::Plan, 5.0));
  ASSERT_EQ(d.fsm.mode(), Mode::Plan);
  d.in.plan = PlanStatus::Pending;
  ASSERT_TRUE(d.until(Mode::Brake, 10.0));
  EXPECT_GE(d.in.com_x, d.fsm.decisionComX() - 1e-9);
  EXPECT_LT(d.in.com_x, d.fsm.decisionComX() + 0.031);
  EXPECT_EQ(d.fsm.abortReason(), Reason::NoPlanByDecisionPoint);
  EXPECT_EQ(d.brakes, 1);
  // A plan arriving late changes nothing.
  d.in.plan = PlanStatus::Feasible;
  d.tick();
  EXPECT_EQ(d.fsm.mode(), Mode::Brake);
  EXPECT_EQ(d.takeoffs, 0);
  d.in.speed = 0.0;
  d.tick();
  EXPECT_EQ(d.fsm.mode(), Mode::Stand);
  EXPECT_FALSE(d.fsm.jumped());
}

TEST(JumpStateMachine, InfeasiblePlanOrFailedPlannerAbortsAtOnce) {
  for (const PlanStatus status : {PlanStatus::Infeasible, PlanStatus::Failed}) {
    Drive d(forward());
    d.until(Mode::Roll, 1.0);
    d.in.speed = 3.0;
    ASSERT_TRUE(d.until(Mode::Plan, 5.0));
    d.in.plan = status;
    EXPECT_EQ(d.tick().mode, Mode::Brake);
    EXPECT_EQ(d.fsm.abortReason(),
              status == PlanStatus::Infeasible ? Reason::PlanInfeasible : Reason::PlannerFailed);
    EXPECT_LT(d.in.com_x, d.fsm.decisionComX());
  }
}

TEST(JumpStateMachine, RetriesRequestAgainWhileTheDecisionPointIsAheadThenAbort) {
  Drive d(forward(), 2);
  d.until(Mode::Roll, 1.0);
  d.in.speed = 3.0;
  ASSERT_TRUE(d.until(Mode::Plan, 5.0));
  EXPECT_EQ(d.requests, 1);
  EXPECT_EQ(d.fsm.planAttempt(), 0);
  // Two answers without a plan: each is followed by a new request, in PLAN.
  for (const PlanStatus status : {PlanStatus::Infeasible, PlanStatus::Failed}) {
    d.in.plan = status;
    EXPECT_EQ(d.tick().mode, Mode::Plan);
    d.in.plan = PlanStatus::Pending;  // what the requester says once the loop has posted
    d.tick();
  }
  EXPECT_EQ(d.requests, 3);
  EXPECT_EQ(d.fsm.planAttempt(), 2);
  EXPECT_EQ(d.fsm.journal(d.fsm.journalCount() - 1).reason, Reason::PlanRetry);
  // The retries are spent: the third infeasible answer aborts.
  d.in.plan = PlanStatus::Infeasible;
  EXPECT_EQ(d.tick().mode, Mode::Brake);
  EXPECT_EQ(d.fsm.abortReason(), Reason::PlanInfeasible);
  EXPECT_EQ(d.requests, 3);

  // Past the decision point no retry is asked for, retries left or not.
  Drive late(forward(), 2);
  late.until(Mode::Roll, 1.0);
  late.in.speed = 3.0;
  ASSERT_TRUE(late.until(Mode::Plan, 5.0));
  late.in.plan = PlanStatus::Failed;
  late.in.speed = 0.0;
  late.in.com_x = late.fsm.decisionComX();
  EXPECT_EQ(late.tick().mode, Mode::Brake);
  EXPECT_EQ(late.fsm.abortReason(), Reason::PlannerFailed);
  EXPECT_EQ(late.requests, 1);

  // A feasible answer after a retry jumps at the take-off point.
  Drive ok(forward(), 1);
  ok.until(Mode::Roll, 1.0);
  ok.in.speed = 3.0;
  ASSERT_TRUE(ok.until(Mode::Plan, 5.0));
  ok.in.plan = PlanStatus::Infeasible;
  ok.tick();
  ok.in.plan = PlanStatus::Feasible;
  ASSERT_TRUE(ok.until(Mode::Takeoff, 10.0));
  EXPECT_GE(ok.in.com_x, ok.fsm.takeoffComX() - 1e-9);
  EXPECT_EQ(ok.requests, 2);
}

TEST(JumpStateMachine, NeverReachingRunUpSpeedAbortsAtTheDecisionPoint) {
  Drive d(forward());
  d.until(Mode::Roll, 1.0);
  d.in.speed = 2.0;  // a weak drive
  ASSERT_TRUE(d.until(Mode::Brake, 20.0));
  EXPECT_EQ(d.requests, 0);
  EXPECT_EQ(d.fsm.abortReason(), Reason::NoPlanByDecisionPoint);
}

TEST(JumpStateMachine, FaultsAndDivergenceGoToDampingFromAnyMode) {
  for (int which = 0; which < 3; ++which) {
    Drive d(forward());
    d.until(Mode::Roll, 1.0);
    d.in.speed = 3.0;
    ASSERT_TRUE(d.until(Mode::Plan, 5.0));
    d.in.plan = PlanStatus::Feasible;
    d.until(Mode::Takeoff, 20.0);
    d.in.executor_in_flight = true;
    d.tick();
    ASSERT_EQ(d.fsm.mode(), Mode::Flight);
    if (which == 0) d.in.motor_fault = true;
    if (which == 1) d.in.estimator_diverged = true;
    if (which == 2) d.in.watchdog_tripped = true;
    EXPECT_EQ(d.tick().mode, Mode::Damping);
    d.in.motor_fault = d.in.estimator_diverged = d.in.watchdog_tripped = false;
    d.tick();
    EXPECT_EQ(d.fsm.mode(), Mode::Damping) << "damping mode is final";
    const Reason expected[] = {Reason::MotorFault, Reason::EstimatorDiverged, Reason::Watchdog};
    EXPECT_EQ(d.fsm.journal(d.fsm.journalCount() - 1).reason, expected[which]);
  }
}

TEST(JumpStateMachine, AttitudeLimitCountsOutsideTheJumpOnly) {
  Drive d(forward());
  d.until(Mode::Roll, 1.0);
  d.in.speed = 3.0;
  ASSERT_TRUE(d.until(Mode::Plan, 5.0));
  d.in.plan = PlanStatus::Feasible;
  d.until(Mode::Takeoff, 20.0);
  d.in.pitch = 1.2;  // a flip in the air is no fault
  d.tick();
  EXPECT_EQ(d.fsm.mode(), Mode::Takeoff);
  d.in.executor_landing = true;
  d.tick();
  d.in.executor_finished = true;
  d.tick();
  ASSERT_EQ(d.fsm.mode(), Mode::Brake);
  d.tick();  // still tilted after landing: damping
  EXPECT_EQ(d.fsm.mode(), Mode::Damping);
  EXPECT_EQ(d.fsm.journal(d.fsm.journalCount() - 1).reason, Reason::AttitudeLimit);
}

TEST(JumpStateMachine, VerticalJumpRequestsAfterStandingAndJumpsWhenThePlanArrives) {
  Drive d(vertical());
  ASSERT_TRUE(d.until(Mode::Plan, 2.0));
  EXPECT_NEAR(d.in.t, 1.0, 0.011);
  EXPECT_EQ(d.requests, 1);
  EXPECT_EQ(d.rolls, 0);
  d.in.plan = PlanStatus::Feasible;
  EXPECT_EQ(d.tick().mode, Mode::Takeoff);
}

TEST(JumpStateMachine, VerticalJumpWithoutPlanStaysStanding) {
  Drive d(vertical());
  d.until(Mode::Plan, 2.0);
  d.in.plan = PlanStatus::Pending;
  ASSERT_TRUE(d.until(Mode::Stand, 10.0));
  EXPECT_NEAR(d.in.t, 1.0 + 2.0, 0.03);
  EXPECT_EQ(d.fsm.abortReason(), Reason::NoPlanByDecisionPoint);
  d.in.plan = PlanStatus::Feasible;
  for (int i = 0; i < 50; ++i) d.tick();
  EXPECT_EQ(d.takeoffs, 0);
  EXPECT_EQ(d.requests, 1);
}

// The backflip's run-up (docs/backflip.md): roll backward to the run-up speed, request the plan
// at that speed, take off as soon as it is in hand (no wall, no take-off point).
TEST(JumpStateMachine, ABackwardRunUpRollsBackThenRequestsAtSpeedAndJumps) {
  ScenarioSettings s = vertical();
  s.name = "backflip";
  s.run_up_speed_m_s = -1.0;
  s.acceleration_m_s2 = 1.0;
  Drive d(s);
  ASSERT_TRUE(d.until(Mode::Roll, 2.0));
  EXPECT_NEAR(d.in.t, 1.0, 0.011);
  EXPECT_EQ(d.rolls, 1);
  EXPECT_EQ(d.requests, 0);
  d.in.speed = -0.5;  // still accelerating backward
  d.tick();
  EXPECT_EQ(d.fsm.mode(), Mode::Roll);
  d.in.speed = -1.0;  // at speed, but the ramp (1 m/s / 1 m/s^2) has not ended: no request yet
  d.tick();
  EXPECT_EQ(d.fsm.mode(), Mode::Roll);
  ASSERT_TRUE(d.until(Mode::Plan, 3.0));
  EXPECT_NEAR(d.in.t, 2.0, 0.011);
  EXPECT_EQ(d.requests, 1);
  d.in.plan = PlanStatus::Feasible;
  EXPECT_EQ(d.tick().mode, Mode::Takeoff);  // moving backward, it still takes off at once
  EXPECT_EQ(d.takeoffs, 1);
}

TEST(JumpStateMachine, ABackwardRunUpWithoutAPlanBrakesToAStop) {
  ScenarioSettings s = vertical();
  s.run_up_speed_m_s = -1.0;
  Drive d(s);
  d.in.speed = -1.0;
  ASSERT_TRUE(d.until(Mode::Plan, 5.0));
  d.in.plan = PlanStatus::Infeasible;
  const FsmOutput out = d.tick();
  EXPECT_EQ(out.mode, Mode::Brake);
  EXPECT_TRUE(out.brake);
  EXPECT_EQ(d.fsm.abortReason(), Reason::PlanInfeasible);
  EXPECT_EQ(d.takeoffs, 0);
}

}  // namespace
}  // namespace wj::robot_client
