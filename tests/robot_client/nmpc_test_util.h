#pragma once
// Helpers shared by the NMPC tests: the robot, seeded random states and inputs, and central
// finite differences.

#include <Eigen/Core>
#include <algorithm>
#include <filesystem>
#include <random>

#include "nmpc/centroidal_model.h"
#include "robot_model/robot_model.h"
#include "test_robot.h"

namespace wj::nmpc::test {

using wj::test::loadRobot;

/// A generic state near standing: tilted, moving, turning, legs off the nominal posture.
inline State randomState(const CentroidalModel& m, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  State x;
  x.segment<3>(state_index::kTheta) = Eigen::Vector3d(0.3 * u(rng), 0.3 * u(rng), 1.5 * u(rng));
  x.segment<3>(state_index::kPos) = Eigen::Vector3d(u(rng), u(rng), 0.3 + 0.05 * u(rng));
  x.segment<3>(state_index::kOmega) = Eigen::Vector3d(u(rng), u(rng), u(rng));
  x.segment<3>(state_index::kVel) = Eigen::Vector3d(2.0 * u(rng), u(rng), 0.3 * u(rng));
  for (int j = 0; j < kNumLegJoints; ++j)
    x[state_index::kJoints + j] = m.nominalJoints()[j] + 0.2 * u(rng);
  return x;
}

/// Forces of about the robot's weight, not purely vertical, and joint velocities.
inline Input randomInput(const CentroidalModel& m, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Input v;
  const double w = m.mass() * m.settings().gravity_m_s2 / 4.0;
  for (int leg = 0; leg < kNumLegs; ++leg)
    v.segment<3>(input_index::force(leg)) =
        Eigen::Vector3d(0.3 * w * u(rng), 0.3 * w * u(rng), w * (1.0 + 0.3 * u(rng)));
  for (int j = 0; j < kNumLegJoints; ++j) v[input_index::kJointVel + j] = 2.0 * u(rng);
  return v;
}

/// Central-difference Jacobian of f: R^n -> R^m at x.
template <class F>
Eigen::MatrixXd numericJacobian(F&& f, const Eigen::VectorXd& x, double h = 1e-6) {
  const Eigen::VectorXd f0 = f(x);
  Eigen::MatrixXd J(f0.size(), x.size());
  for (int i = 0; i < x.size(); ++i) {
    Eigen::VectorXd xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    J.col(i) = (f(xp) - f(xm)) / (2.0 * h);
  }
  return J;
}

/// Largest |a - b| relative to max(1, |b|max).
inline double relativeError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

}  // namespace wj::nmpc::test
