#pragma once
// Conversions between Eigen and Simbody's vectors, rotations and transforms. Internal to
// wj_sim_simbody (C++17, sees Simbody).

#include <Simbody.h>

#include <Eigen/Geometry>

namespace wj::sim::detail {

inline SimTK::Vec3 toVec3(const Eigen::Vector3d& v) {
  return {v.x(), v.y(), v.z()};
}
inline Eigen::Vector3d toEigen(const SimTK::Vec3& v) {
  return {v[0], v[1], v[2]};
}
inline SimTK::Rotation toRotation(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return SimTK::Rotation(SimTK::Quaternion(q.w(), q.x(), q.y(), q.z()));
}
inline Eigen::Matrix3d toEigen(const SimTK::Rotation& R) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = R[r][c];
  return out;
}
inline SimTK::Transform toTransform(const Eigen::Isometry3d& X) {
  return SimTK::Transform(toRotation(X.linear()), toVec3(X.translation()));
}
inline Eigen::Isometry3d toEigen(const SimTK::Transform& X) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = toEigen(X.R());
  out.translation() = toEigen(X.p());
  return out;
}

}  // namespace wj::sim::detail
