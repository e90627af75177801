// Planar leg kinematics: IK/FK round trip, Jacobians and statics against finite differences.
#include <gtest/gtest.h>

#include <cmath>

#include "planner/leg_kinematics.h"

namespace wj::planner {
namespace {

const PlanarLeg kLeg{0.2, 0.2};

TEST(PlanarLeg, InverseForwardRoundTrip) {
  for (double q1 = -1.0; q1 <= 2.5; q1 += 0.25) {
    for (double q2 = -2.6; q2 <= -0.1; q2 += 0.25) {
      const Eigen::Vector2d q(q1, q2);
      double reach = 0.0;
      const LegPose pose = kLeg.inversePose(kLeg.forward(q), &reach);
      EXPECT_NEAR(std::remainder(pose.q[0] - q1, 2 * M_PI), 0.0, 1e-9) << q.transpose();
      EXPECT_NEAR(pose.q[1], q2, 1e-9) << q.transpose();
      EXPECT_GT(reach, 0.0);
      EXPECT_NEAR(pose.s1, std::sin(q1), 1e-9);
      EXPECT_NEAR(pose.c12, std::cos(q1 + q2), 1e-9);
      EXPECT_TRUE(kLeg.jacobian(pose).isApprox(kLeg.jacobian(q), 1e-9));
    }
  }
}

TEST(PlanarLeg, ReachMarginOutsideTheAnnulus) {
  double reach = 0.0;
  (void)kLeg.inverse(Eigen::Vector2d(0.0, -0.45), &reach);
  EXPECT_NEAR(reach, -0.05, 1e-6);
  (void)kLeg.inverse(Eigen::Vector2d(0.0, -0.3), &reach);
  EXPECT_NEAR(reach, 0.1, 1e-6);
}

TEST(PlanarLeg, JacobianMatchesFiniteDifferences) {
  const double h = 1e-6;
  for (const Eigen::Vector2d& q :
       {Eigen::Vector2d(0.8, -1.6), Eigen::Vector2d(1.2, -2.3), Eigen::Vector2d(-0.3, -0.7)}) {
    Eigen::Matrix2d fd;
    for (int i = 0; i < 2; ++i) {
      Eigen::Vector2d dq = Eigen::Vector2d::Zero();
      dq[i] = h;
      fd.col(i) = (kLeg.forward(q + dq) - kLeg.forward(q - dq)) / (2 * h);
    }
    EXPECT_TRUE(kLeg.jacobian(q).isApprox(fd, 1e-7)) << kLeg.jacobian(q) << "\n" << fd;
  }
}

TEST(PlanarLeg, BalancingTorqueIsVirtualWork) {
  // For a force applied at the axle, tau = -J^T f (the motor balances the external force).
  for (const Eigen::Vector2d& q : {Eigen::Vector2d(0.8, -1.6), Eigen::Vector2d(1.1, -2.0)}) {
    const Eigen::Vector2d f(30.0, 120.0);
    const Eigen::Vector2d tau = kLeg.balancingTorque(q, kLeg.forward(q), f);
    EXPECT_TRUE(tau.isApprox(-kLeg.jacobian(q).transpose() * f, 1e-12));
  }
  // Standing: a vertical load with the knee behind the foot needs a positive knee torque.
  const Eigen::Vector2d q(0.8, -1.6);
  EXPECT_GT(kLeg.balancingTorque(q, kLeg.forward(q), Eigen::Vector2d(0, 50))[1], 0.0);
}

}  // namespace
}  // namespace wj::planner
