#pragma once
/// @file Planar kinematics of one leg in its sagittal plane (HFE, KFE), in the base frame.
///
/// Convention (that of the URDF): x forward, z up, joint angles about +y, zero = leg straight
/// down. The wheel axle relative to the HFE axis is
///   b = (-l1 sin q1 - l2 sin(q1 + q2),  -l1 cos q1 - l2 cos(q1 + q2)),
/// and the knee is bent backward (q2 < 0), the branch the inverse kinematics returns.

#include <Eigen/Core>

namespace wj::planner {

/// Joint angles with their sines and cosines, so that callers need no further trigonometry.
struct LegPose {
  Eigen::Vector2d q = Eigen::Vector2d::Zero();  ///< (HFE, KFE) [rad]
  double s1 = 0.0, c1 = 1.0;                    ///< sin, cos of q1
  double s12 = 0.0, c12 = 1.0;                  ///< sin, cos of q1 + q2
  double s2 = 0.0, c2 = 1.0;                    ///< sin, cos of q2
  /// From inversePose(): the direction a of -b and the shank offset beta (sines, cosines),
  /// which PlanarLeg::solveAngles() needs.
  double sa = 0.0, ca = 1.0, sb = 0.0, cb = 1.0;
};

/// Two-link planar leg with thigh length l1 and shank length l2 [m].
struct PlanarLeg {
  double l1 = 0.2;
  double l2 = 0.2;

  /// Axle position b(q) relative to the HFE axis, base frame x-z [m].
  Eigen::Vector2d forward(const Eigen::Vector2d& q) const;
  /// The same from a pose's sines and cosines (no trigonometry).
  Eigen::Vector2d forward(const LegPose& p) const {
    return {-l1 * p.s1 - l2 * p.s12, -l1 * p.c1 - l2 * p.c12};
  }
  /// Jacobian db/dq (2 x 2).
  Eigen::Matrix2d jacobian(const Eigen::Vector2d& q) const;
  /// Knee position relative to the HFE axis [m].
  Eigen::Vector2d knee(const Eigen::Vector2d& q) const;
  /// Joint angles (q1, q2 <= 0) placing the axle at b. `reach_margin` receives the signed
  /// distance of |b| to the reachable annulus [|l1 - l2|, l1 + l2] (negative = out of reach,
  /// in which case b is projected onto the annulus first).
  Eigen::Vector2d inverse(const Eigen::Vector2d& b, double* reach_margin = nullptr) const;
  /// inverse() with the trigonometry of the result (two atan2 in all). With `angles` false
  /// only the sines and cosines are computed (no inverse trigonometry) and q is left zero.
  LegPose inversePose(const Eigen::Vector2d& b, double* reach_margin = nullptr,
                      bool angles = true) const;
  /// Fills in q of a pose that inversePose() returned without angles: afterwards it equals,
  /// bit for bit, what inversePose(b, ..., true) returns.
  void solveAngles(LegPose& pose) const;
  /// jacobian() at a pose from inversePose().
  Eigen::Matrix2d jacobian(const LegPose& pose) const;
  /// balancingTorque() at a pose from inversePose().
  Eigen::Vector2d balancingTorque(const LegPose& pose, const Eigen::Vector2d& p,
                                  const Eigen::Vector2d& f) const;
  /// Motor torques (HFE, KFE) [Nm] that balance force f [N] acting on the leg at point p
  /// (both in the base frame, p relative to the HFE axis), for massless links:
  ///   tau_j = (p - p_j)_x f_z - (p - p_j)_z f_x.
  Eigen::Vector2d balancingTorque(const Eigen::Vector2d& q, const Eigen::Vector2d& p,
                                  const Eigen::Vector2d& f) const;
};

}  // namespace wj::planner
