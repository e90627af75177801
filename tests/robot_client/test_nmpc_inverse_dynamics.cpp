// The RNEA of paper Eq. 9 against closed forms: a static robot under gravity and wheel loads
// (lever arms, and the virtual-work statics of the simulator), the mass matrix and gravity
// torques against kinetic and potential energy by finite differences, Coriolis terms against
// Lagrange's equations, the base wrench against the composite rigid body; and the paper's
// wheel law in the whole-body controller.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

#include "nmpc/inverse_dynamics.h"
#include "nmpc/whole_body_controller.h"
#include "nmpc_test_util.h"
#include "sim/statics.h"

namespace wj::nmpc {
namespace {

constexpr double kG = 9.81;

class InverseDynamicsTest : public ::testing::Test {
 protected:
  RobotJointVector posture(double scale = 1.0) const {
    RobotJointVector q;
    for (int j = 0; j < model::kNumJoints; ++j) q[j] = scale * 0.4 * std::sin(1.3 * j + 0.2);
    return q;
  }
  // Fixed base, no wheel forces: tau = M(q) qdd + C(q, qd) qd + g(q).
  RobotJointVector fixedBase(const RobotJointVector& q, const RobotJointVector& qd,
                             const RobotJointVector& qdd, double g) const {
    InverseDynamicsResult r;
    id_.calc(Eigen::Vector3d(0, 0, -g), BaseMotion{}, q, qd, qdd, {}, r);
    return r.tau;
  }
  Eigen::MatrixXd massMatrix(const RobotJointVector& q) const {
    Eigen::MatrixXd M(model::kNumJoints, model::kNumJoints);
    for (int i = 0; i < model::kNumJoints; ++i)
      M.col(i) = fixedBase(q, RobotJointVector::Zero(), RobotJointVector::Unit(i), 0.0);
    return M;
  }
  // Potential energy of the links in the base frame (fixed base).
  double potentialEnergy(const RobotJointVector& q) const {
    const auto X = robot_.calcLinkPoses(q);
    double V = 0.0;
    for (std::size_t i = 0; i < X.size(); ++i)
      V += robot_.links()[i].inertia.mass * kG * (X[i] * robot_.links()[i].inertia.com).z();
    return V;
  }
  // Kinetic energy from link velocities by central differences of the link poses.
  double kineticEnergy(const RobotJointVector& q, const RobotJointVector& qd) const {
    const double h = 1e-6;
    const auto Xp = robot_.calcLinkPoses(q + h * qd);
    const auto Xm = robot_.calcLinkPoses(q - h * qd);
    const auto X = robot_.calcLinkPoses(q);
    double T = 0.0;
    for (std::size_t i = 0; i < X.size(); ++i) {
      const model::Inertia& in = robot_.links()[i].inertia;
      const Eigen::Vector3d vc = (Xp[i] * in.com - Xm[i] * in.com) / (2 * h);
      const Eigen::Matrix3d W =
          (Xp[i].linear() - Xm[i].linear()) / (2 * h) * X[i].linear().transpose();
      const Eigen::Vector3d w(W(2, 1), W(0, 2), W(1, 0));
      const Eigen::Matrix3d I = X[i].linear() * in.inertia_com * X[i].linear().transpose();
      T += 0.5 * in.mass * vc.squaredNorm() + 0.5 * w.dot(I * w);
    }
    return T;
  }

  model::RobotModel robot_ = test::loadRobot();
  InverseDynamics id_{robot_};
};

TEST_F(InverseDynamicsTest, StaticLegBalancesGravityAndWheelForceByLeverArms) {
  const RobotJointVector q = posture();
  const auto X = robot_.calcLinkPoses(q);
  const Eigen::Vector3d g(0, 0, -kG);
  std::array<WheelForce, model::kNumLegs> forces{};
  for (int leg = 0; leg < model::kNumLegs; ++leg) {
    const int w = robot_.joint(static_cast<model::Leg>(leg), model::JointKind::Wheel).child_link;
    forces[leg].f_B = Eigen::Vector3d(10.0 * leg - 5.0, 3.0, 40.0 + leg);
    forces[leg].p_B = X[w].translation() - Eigen::Vector3d(0, 0, robot_.wheelRadius());
  }
  InverseDynamicsResult r;
  id_.calc(g, BaseMotion{}, q, RobotJointVector::Zero(), RobotJointVector::Zero(), forces, r);
  // tau_j = -a_j . sum over links below j of (c_l - o_j) x m_l g  -  a_j . (p_F - o_j) x F.
  for (int j = 0; j < model::kNumJoints; ++j) {
    const model::JointSpec& js = robot_.joints()[j];
    const Eigen::Isometry3d X_J = X[js.parent_link] * js.X_PJ;
    const Eigen::Vector3d o = X_J.translation(), a = X_J.linear() * js.axis;
    Eigen::Vector3d moment = Eigen::Vector3d::Zero();
    for (std::size_t l = 1; l < X.size(); ++l) {
      // Is link l in the subtree of joint j? Walk up from l.
      int link = static_cast<int>(l);
      bool below = false;
      while (link > 0) {
        const int pj = robot_.links()[link].parent_joint;
        if (pj == j) below = true;
        link = robot_.joints()[pj].parent_link;
      }
      if (!below) continue;
      const model::Inertia& in = robot_.links()[l].inertia;
      moment += (X[l] * in.com - o).cross(in.mass * g);
    }
    const int leg = static_cast<int>(js.leg);
    moment += (forces[leg].p_B - o).cross(forces[leg].f_B);
    EXPECT_NEAR(r.tau[j], -a.dot(moment), 1e-10) << js.name;
  }
}

TEST_F(InverseDynamicsTest, StandingTorquesEqualTheSimulatorsVirtualWorkStatics) {
  sim::JointVector q_stand = sim::JointVector::Zero();
  const CentroidalModel cm(robot_);
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int j = 0; j < kLegDofs; ++j)
      q_stand[robotJointIndex(leg, j)] = cm.nominalJoints()[kLegDofs * leg + j];
  const sim::StandingStatics st = sim::calcStandingStatics(robot_, q_stand, kG);
  const auto centres = sim::calcWheelCenters(robot_, q_stand);
  std::array<WheelForce, model::kNumLegs> forces{};
  for (int leg = 0; leg < model::kNumLegs; ++leg) {
    forces[leg].f_B = Eigen::Vector3d(0, 0, st.wheel_load_n[leg]);
    forces[leg].p_B = centres[leg] - Eigen::Vector3d(0, 0, robot_.wheelRadius());
  }
  InverseDynamicsResult r;
  id_.calc(Eigen::Vector3d(0, 0, -kG), BaseMotion{}, q_stand, RobotJointVector::Zero(),
           RobotJointVector::Zero(), forces, r);
  for (int j = 0; j < model::kNumJoints; ++j)
    EXPECT_NEAR(r.tau[j], st.tau[j], 1e-6) << robot_.joints()[j].name;  // FD Jacobians in sim
  // The loads carry the weight: the base needs no wrench from outside.
  EXPECT_LT(r.base_force_B.norm(), 1e-9);
  EXPECT_LT(r.base_torque_B.norm(), 1e-6);
}

TEST_F(InverseDynamicsTest, MassMatrixIsTheHessianOfKineticEnergy) {
  const RobotJointVector q = posture();
  const Eigen::MatrixXd M = massMatrix(q);
  EXPECT_LT((M - M.transpose()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M).eigenvalues().minCoeff(), 0.0);
  std::mt19937 rng(9);
  std::normal_distribution<double> nd(0.0, 2.0);
  for (int trial = 0; trial < 3; ++trial) {
    RobotJointVector qd;
    for (int j = 0; j < model::kNumJoints; ++j) qd[j] = nd(rng);
    EXPECT_NEAR(0.5 * qd.dot(M * qd), kineticEnergy(q, qd), 1e-7);
  }
}

TEST_F(InverseDynamicsTest, GravityTorquesAreTheGradientOfPotentialEnergy) {
  const RobotJointVector q = posture();
  const RobotJointVector g = fixedBase(q, RobotJointVector::Zero(), RobotJointVector::Zero(), kG);
  const double h = 1e-6;
  for (int j = 0; j < model::kNumJoints; ++j) {
    const RobotJointVector e = RobotJointVector::Unit(j);
    EXPECT_NEAR(g[j], (potentialEnergy(q + h * e) - potentialEnergy(q - h * e)) / (2 * h), 1e-7);
  }
}

TEST_F(InverseDynamicsTest, CoriolisTermsFollowLagrangesEquations) {
  // With qdd = 0 and no gravity: tau = d/dt(dT/dqd) - dT/dq = Mdot qd - 1/2 d(qd' M qd)/dq.
  const RobotJointVector q = posture();
  RobotJointVector qd;
  for (int j = 0; j < model::kNumJoints; ++j) qd[j] = 1.5 * std::cos(0.7 * j);
  const RobotJointVector c = fixedBase(q, qd, RobotJointVector::Zero(), 0.0);
  const double h = 1e-6;
  const Eigen::MatrixXd Mdot = (massMatrix(q + h * qd) - massMatrix(q - h * qd)) / (2 * h);
  RobotJointVector dTdq;
  for (int j = 0; j < model::kNumJoints; ++j) {
    const RobotJointVector e = RobotJointVector::Unit(j);
    dTdq[j] = (qd.dot(massMatrix(q + h * e) * qd) - qd.dot(massMatrix(q - h * e) * qd)) / (4 * h);
  }
  EXPECT_LT((c - (Mdot * qd - dTdq)).cwiseAbs().maxCoeff(), 1e-6);
  // The power identity: qd' (Mdot/2 qd - C qd) = 0.
  EXPECT_NEAR(qd.dot(0.5 * Mdot * qd - c), 0.0, 1e-6);
}

TEST_F(InverseDynamicsTest, LockedJointsMoveAsOneCompositeRigidBody) {
  const RobotJointVector q = posture();
  const model::Inertia I = robot_.calcCompositeInertia(q);
  BaseMotion b;
  b.omega_B = Eigen::Vector3d(0.3, -0.5, 0.8);
  b.v_B = Eigen::Vector3d(1.0, 0.2, -0.1);
  b.omegadot_B = Eigen::Vector3d(2.0, 1.0, -3.0);
  b.a_B = Eigen::Vector3d(0.5, -1.0, 2.0);
  const Eigen::Vector3d g(0.5, 0.0, -kG);
  InverseDynamicsResult r;
  id_.calc(g, b, q, RobotJointVector::Zero(), RobotJointVector::Zero(), {}, r);
  const Eigen::Vector3d& w = b.omega_B;
  const Eigen::Vector3d a_com = b.a_B + b.omegadot_B.cross(I.com) + w.cross(w.cross(I.com));
  const Eigen::Vector3d F = I.mass * (a_com - g);
  const Eigen::Vector3d N = I.inertia_com * b.omegadot_B + w.cross(I.inertia_com * w);
  EXPECT_LT((r.base_force_B - F).norm(), 1e-9);
  EXPECT_LT((r.base_torque_B - (N + I.com.cross(F))).norm(), 1e-9);
}

TEST(WholeBody, WheelLawAddsTractionAndSpeedError) {
  const model::RobotModel robot = test::loadRobot();
  const CentroidalModel cm(robot);
  WholeBodySettings s;
  s.policy_feedback = false;
  const WholeBodyController wbc(robot, cm, s);
  // A policy that holds a level standing state rolling at 1 m/s with 20 N traction per wheel.
  Policy policy(2);
  policy.reset(0.0, 0.5, 2);
  State x = State::Zero();
  x.segment<kNumLegJoints>(state_index::kJoints) = cm.nominalJoints();
  x[state_index::kPos + 2] = 0.4;
  x[state_index::kVel] = 1.0;
  Input u = Input::Zero();
  for (int leg = 0; leg < kNumLegs; ++leg)
    u.segment<3>(input_index::force(leg)) = Eigen::Vector3d(20.0, 0.0, 55.0);
  for (int k = 0; k <= 2; ++k) policy.stateAt(k) = x;
  for (int k = 0; k < 2; ++k) policy.inputAt(k) = u;
  model::SensorData sensors;
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int j = 0; j < kLegDofs; ++j)
      sensors.joints[robotJointIndex(leg, j)].q = cm.nominalJoints()[kLegDofs * leg + j];
  State measured = x;
  measured[state_index::kVel] = 0.9;  // 0.1 m/s slower than planned
  const double r = robot.wheelRadius();
  for (int leg = 0; leg < kNumLegs; ++leg)
    sensors.joints[robotJointIndex(leg, 3)].qd = 0.9 / r;  // rolling without slip
  sensors.joints[robotJointIndex(3, 3)].qd = 0.0;          // RH slips: locked wheel
  model::JointCommands cmd{};
  WholeBodyOutput diag;
  wbc.calcCommands(0.2, policy, measured, sensors, {true, true, false, true},
                   Eigen::Vector3d::UnitZ(), cmd, diag);
  for (const int leg : {0, 1, 3}) {
    const model::JointCommand& c = cmd[robotJointIndex(leg, 3)];
    // Paper: tau = K_d (v_des - v) + f_t r; the slip damper adds only for the slipping wheel.
    const double slip = leg == 3 ? 0.9 / r : 0.0;
    EXPECT_NEAR(c.tau_ff, s.wheel_kd * 0.1 + 20.0 * r + s.wheel_slip_kd * slip, 1e-9);
    EXPECT_EQ(c.kp, 0.0);
  }
  // The swinging wheel spins at the rolling speed of its centre.
  const model::JointCommand& sw = cmd[robotJointIndex(2, 3)];
  EXPECT_NEAR(sw.qd_des, 0.9 / r, 1e-9);
  EXPECT_GT(sw.kd, 0.0);
  // Legs track the planned posture; the swinging leg carries no contact force.
  EXPECT_EQ(diag.u.segment<3>(input_index::force(2)).norm(), 0.0);
  EXPECT_DOUBLE_EQ(cmd[robotJointIndex(0, 1)].q_des, cm.nominalJoints()[1]);
}

}  // namespace
}  // namespace wj::nmpc
