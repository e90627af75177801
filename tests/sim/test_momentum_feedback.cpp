// The take-off's momentum feedback (ExecutorSettings::takeoff_momentum_kp; issue 22,
// docs/planner.md "The take-off's momentum feedback"): the moment kp e + kd e' on the error of
// the whole robot's nose-up momentum, put on the ground as normal force moved from the hind
// pair to the front one. Checked against the robot's kinematics by finite differences (each
// leg's torques are -J^T of its wheel's share), clamped, off in flight, in two-step plans and
// with zero gains, rejected by name out of range, and without allocation in update(), which
// this test binary checks by replacing the global operator new.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "allocation_counter.h"
#include "error_of.h"
#include "robot_model/momentum.h"
#include "sim/plan_executor.h"
#include "test_robot.h"

namespace wj::sim {
namespace {

using model::jointIndex;
using model::JointKind;
using model::Leg;

using wj::test::allocations;

// A crouch (HFE 0.8, KFE -2.0 rad on every leg: the axles off the vertical through the hips).
Eigen::VectorXd crouch() {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(model::kNumJoints);
  for (const Leg leg : model::kLegs) {
    q[jointIndex(leg, JointKind::HFE)] = 0.8;
    q[jointIndex(leg, JointKind::KFE)] = -2.0;
  }
  return q;
}

// The robot holding the crouch level and at rest, every joint torque 2 Nm. With `lifted`, a
// two-step plan: the front legs carry no torque in [t1, t2).
planner::JumpPlan holdingPlan(bool lifted) {
  planner::JumpPlan plan;
  plan.dt = 0.002;
  plan.t1 = lifted ? 0.1 : 0.3;
  plan.t2 = 0.3;
  plan.t3 = 0.5;
  const int n = 251;
  plan.centroidal.assign(n, planner::PlanarState{0.0, 0.3, 0.0, 0.0, 0.0, 0.0});
  plan.q = crouch().transpose().replicate(n, 1);
  plan.qd = Eigen::MatrixXd::Zero(n, model::kNumJoints);
  plan.tau = Eigen::MatrixXd::Constant(n, model::kNumJoints, 2.0);
  if (lifted)
    for (int k = 50; k < 150; ++k)
      for (const Leg leg : {Leg::LF, Leg::RF})
        for (const JointKind kind : model::kJointKinds) plan.tau(k, jointIndex(leg, kind)) = 0.0;
  return plan;
}

// The robot in the crouch, level, turning nose-down at `rate` [rad/s] (about +y).
model::SensorData noseDown(double rate) {
  model::SensorData s;
  const Eigen::VectorXd q = crouch();
  for (int j = 0; j < model::kNumJoints; ++j) s.joints[j].q = q[j];
  s.imu.omega_B = Eigen::Vector3d(0.0, rate, 0.0);
  return s;
}

ExecutorSettings feedback(double kp, double kd, double max_nm) {
  ExecutorSettings s;
  s.landing_gravity_feedforward = false;
  s.takeoff_momentum_kp = kp;
  s.takeoff_momentum_kd = kd;
  s.takeoff_momentum_max_nm = max_nm;
  return s;
}

// The nose-up momentum error of noseDown(rate) against the plan at rest: the plan's 0 less
// the measured, -H_y (the model's own function).
double momentumError(const model::RobotModel& robot, double rate) {
  const Eigen::Vector3d H = model::calcCentralAngularMomentum(
      robot, Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, rate, 0.0), crouch(),
      Eigen::VectorXd::Zero(model::kNumJoints));
  return H.y();
}

// The torque changes that put a nose-up moment M on the ground of the level crouch: dF up on
// each front wheel and down on each hind one, 2 dF times the pairs' lever = M, and each leg's
// joint torques -(d p_axle / d q_j) . F with the axle's Jacobian by central differences.
JointVector expectedTorques(const model::RobotModel& robot, double M) {
  const auto axle = [&](const Eigen::VectorXd& q, Leg leg) -> Eigen::Vector3d {
    return robot.calcLinkPoses(q)[robot.joint(leg, JointKind::Wheel).child_link].translation();
  };
  const Eigen::VectorXd q = crouch();
  const double lever =
      0.5 * (axle(q, Leg::LF) + axle(q, Leg::RF) - axle(q, Leg::LH) - axle(q, Leg::RH)).x();
  EXPECT_GT(lever, 0.2);
  const double df = M / (2.0 * lever);
  JointVector dtau = JointVector::Zero();
  constexpr double h = 1e-6;
  for (const Leg leg : model::kLegs) {
    const double fz = leg == Leg::LF || leg == Leg::RF ? df : -df;
    for (const JointKind kind : {JointKind::HAA, JointKind::HFE, JointKind::KFE}) {
      const int j = jointIndex(leg, kind);
      Eigen::VectorXd qp = q, qm = q;
      qp[j] += h;
      qm[j] -= h;
      dtau[j] = -(axle(qp, leg) - axle(qm, leg)).z() / (2.0 * h) * fz;
    }
  }
  return dtau;
}

// Commands at `t` of an executor fed `sensors` (after one update at t = 0 at rest).
model::JointCommands commandsAt(const model::RobotModel& robot, const planner::JumpPlan& plan,
                                const ExecutorSettings& s, double t,
                                const model::SensorData& sensors) {
  PlanExecutor ex(robot, plan, s, 9.81);
  model::JointCommands c{};
  ex.update(0.0, noseDown(0.0), true, c);
  ex.update(t, sensors, true, c);
  return c;
}

void expectTorqueChange(const model::JointCommands& on, const model::JointCommands& off,
                        const JointVector& expected) {
  for (int j = 0; j < model::kNumJoints; ++j)
    EXPECT_NEAR(on[j].tau_ff - off[j].tau_ff, expected[j], 1e-6 + 1e-6 * std::abs(expected[j]))
        << "joint " << j;
}

TEST(MomentumFeedback, MovesNormalForceFromTheHindPairToTheFrontOnAMomentumError) {
  const model::RobotModel robot = test::loadRobot();
  const planner::JumpPlan plan = holdingPlan(false);
  const double rate = 0.2;  // nose-down: the robot is behind the plan's momentum
  const double e = momentumError(robot, rate);
  ASSERT_GT(e, 0.1);  // nose-up to do
  const model::JointCommands on =
      commandsAt(robot, plan, feedback(150.0, 0.0, 1000.0), 0.05, noseDown(rate));
  const model::JointCommands off =
      commandsAt(robot, plan, feedback(0.0, 0.0, 1000.0), 0.05, noseDown(rate));
  const JointVector expected = expectedTorques(robot, 150.0 * e);
  expectTorqueChange(on, off, expected);
  // The knees carry it, the front ones pushing harder than the plan, the hind ones less.
  EXPECT_GT(std::abs(expected[jointIndex(Leg::LF, JointKind::KFE)]), 0.5);
  EXPECT_LT(
      expected[jointIndex(Leg::LF, JointKind::KFE)] * expected[jointIndex(Leg::LH, JointKind::KFE)],
      0.0);
  // At the plan's momentum there is nothing to add.
  expectTorqueChange(commandsAt(robot, plan, feedback(150.0, 0.0, 1000.0), 0.05, noseDown(0.0)),
                     off, JointVector::Zero());
}

TEST(MomentumFeedback, IsClampedAndActsOnTheErrorsRate) {
  const model::RobotModel robot = test::loadRobot();
  const planner::JumpPlan plan = holdingPlan(false);
  const model::JointCommands off =
      commandsAt(robot, plan, feedback(0.0, 0.0, 1.0), 0.05, noseDown(0.2));
  // Clamped to +-max.
  expectTorqueChange(commandsAt(robot, plan, feedback(1e6, 0.0, 5.0), 0.05, noseDown(0.2)), off,
                     expectedTorques(robot, 5.0));
  expectTorqueChange(commandsAt(robot, plan, feedback(1e6, 0.0, 5.0), 0.05, noseDown(-0.2)), off,
                     expectedTorques(robot, -5.0));
  // kd on the error's change since the last period: 0 at t = 0, e at t = 0.002.
  const double e = momentumError(robot, 0.2);
  expectTorqueChange(commandsAt(robot, plan, feedback(0.0, 0.5, 1000.0), 0.002, noseDown(0.2)), off,
                     expectedTorques(robot, 0.5 * e / 0.002));
}

TEST(MomentumFeedback, IsOffInFlightInTwoStepPlansAndWithZeroGains) {
  const model::RobotModel robot = test::loadRobot();
  for (const bool lifted : {false, true}) {
    const planner::JumpPlan plan = holdingPlan(lifted);
    for (const double t : {0.05, 0.31}) {
      if (!lifted && t < plan.t2) continue;  // the case of the test above
      const model::JointCommands on =
          commandsAt(robot, plan, feedback(150.0, 0.5, 40.0), t, noseDown(0.2));
      const model::JointCommands off =
          commandsAt(robot, plan, feedback(0.0, 0.0, 40.0), t, noseDown(0.2));
      expectTorqueChange(on, off, JointVector::Zero());
    }
  }
}

TEST(MomentumFeedback, OutOfRangeSettingsAreRejectedByName) {
  const model::RobotModel robot = test::loadRobot();
  const planner::JumpPlan plan = holdingPlan(false);
  for (const char* field :
       {"takeoff_momentum_kp", "takeoff_momentum_kd", "takeoff_momentum_max_nm"}) {
    ExecutorSettings s = feedback(1.0, 1.0, 1.0);
    if (std::string(field) == "takeoff_momentum_kp") s.takeoff_momentum_kp = -1.0;
    if (std::string(field) == "takeoff_momentum_kd") s.takeoff_momentum_kd = std::nan("");
    if (std::string(field) == "takeoff_momentum_max_nm") s.takeoff_momentum_max_nm = -2.0;
    EXPECT_THAT(
        test::errorOf<std::invalid_argument>([&] { return PlanExecutor(robot, plan, s, 9.81); }),
        test::HasSubstr(field));
  }
}

TEST(MomentumFeedback, UpdateDoesNotAllocate) {
  const model::RobotModel robot = test::loadRobot();
  const planner::JumpPlan plan = holdingPlan(false);
  PlanExecutor ex(robot, plan, feedback(150.0, 0.5, 40.0), 9.81);
  model::JointCommands c{};
  model::SensorData s = noseDown(0.2);
  ex.update(0.0, s, true, c);
  const long before = allocations();
  double sum = 0.0;
  for (int k = 1; k < 290; ++k) {
    s.imu.omega_B.y() = 0.2 * std::sin(0.1 * k);
    ex.update(0.001 * k, s, true, c);
    sum += c[jointIndex(Leg::LF, JointKind::KFE)].tau_ff;
  }
  EXPECT_EQ(allocations() - before, 0);
  EXPECT_TRUE(std::isfinite(sum));
  // The counter sees an allocation (this binary's operator new is the counting one).
  auto* p = new std::array<double, 4>();
  EXPECT_EQ(allocations() - before, 1);
  delete p;
}

}  // namespace
}  // namespace wj::sim
