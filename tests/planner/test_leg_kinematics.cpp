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

// inversePose returns q1 = a - beta in (-pi, 3pi/2] (one atan2, unwrapped above pi), the same
// angle the two-atan2 formula gives, for equal and unequal links; without angles it returns the
// same sines and cosines.
TEST(PlanarLeg, InverseKeepsTheAngleBranchBeyondPi) {
  for (const PlanarLeg& leg : {kLeg, PlanarLeg{0.25, 0.18}, PlanarLeg{0.18, 0.25}}) {
    for (double q1 = -3.0; q1 <= 4.5; q1 += 0.1) {
      for (double q2 = -3.0; q2 <= -0.05; q2 += 0.2) {
        const Eigen::Vector2d b = leg.forward(Eigen::Vector2d(q1, q2));
        const LegPose pose = leg.inversePose(b);
        const double sa = -b.x() / b.norm(), ca = -b.y() / b.norm();
        const double c2 = std::cos(pose.q[1]), s2 = std::sin(pose.q[1]);
        const double lc = b.norm();
        const double reference =
            std::atan2(sa, ca) - std::atan2(leg.l2 * s2 / lc, (leg.l1 + leg.l2 * c2) / lc);
        EXPECT_NEAR(pose.q[0], reference, 1e-9) << leg.l1 << " " << q1 << " " << q2;
        EXPECT_NEAR(pose.q[1], q2, 1e-7) << leg.l1 << " " << q1 << " " << q2;
        EXPECT_LT(leg.l1 >= leg.l2 ? pose.q[0] : 0.0, 1.5 * M_PI + 1e-12);
        EXPECT_TRUE(leg.forward(pose).isApprox(b, 1e-9));
        const LegPose trig = leg.inversePose(b, nullptr, /*angles=*/false);
        EXPECT_EQ(trig.s1, pose.s1);
        EXPECT_EQ(trig.c12, pose.c12);
      }
    }
  }
}

// The take-off sweep solves a pose without angles first and its angles later (solveAngles):
// the result must be what inversePose with angles returns, to the bit, for equal and unequal
// links (the latter take the two-atan2 branch) and for points out of reach.
TEST(PlanarLeg, AnglesSolvedLaterAreTheSameToTheBit) {
  for (const PlanarLeg& leg : {PlanarLeg{0.2, 0.2}, PlanarLeg{0.25, 0.18}, PlanarLeg{0.15, 0.22}}) {
    for (double x = -0.45; x <= 0.45; x += 0.05) {
      for (double z = -0.45; z <= 0.2; z += 0.05) {
        const Eigen::Vector2d b(x, z);
        double reach_a = 0.0, reach_b = 0.0;
        const LegPose with = leg.inversePose(b, &reach_a, /*angles=*/true);
        LegPose later = leg.inversePose(b, &reach_b, /*angles=*/false);
        EXPECT_EQ(later.q, Eigen::Vector2d::Zero()) << b.transpose();
        leg.solveAngles(later);
        EXPECT_EQ(later.q[0], with.q[0]) << b.transpose();
        EXPECT_EQ(later.q[1], with.q[1]) << b.transpose();
        EXPECT_EQ(later.s1, with.s1);
        EXPECT_EQ(later.c12, with.c12);
        EXPECT_EQ(reach_a, reach_b);
      }
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
