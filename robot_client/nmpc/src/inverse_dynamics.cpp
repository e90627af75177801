#include "nmpc/inverse_dynamics.h"

#include <stdexcept>

namespace wj::nmpc {

InverseDynamics::InverseDynamics(const model::RobotModel& robot) {
  if (static_cast<int>(robot.links().size()) != kNumLinks)
    throw std::invalid_argument("InverseDynamics: expected 17 links");
  for (int i = 0; i < kNumLinks; ++i) {
    const model::LinkSpec& spec = robot.links()[i];
    Link& link = links_[i];
    link.mass = spec.inertia.mass;
    link.com = spec.inertia.com;
    link.inertia_com = spec.inertia.inertia_com;
    if (i == 0) continue;
    const model::JointSpec& j = robot.joints()[spec.parent_joint];
    link.joint = spec.parent_joint;
    link.parent = j.parent_link;
    if (link.parent >= i)
      throw std::invalid_argument("InverseDynamics: links must be ordered parent first");
    link.R_PJ = j.X_PJ.linear();
    link.p_PJ = j.X_PJ.translation();
    link.axis = j.axis;
  }
  for (int leg = 0; leg < model::kNumLegs; ++leg)
    wheel_link_[leg] =
        robot.joint(static_cast<model::Leg>(leg), model::JointKind::Wheel).child_link;
}

void InverseDynamics::calc(const Eigen::Vector3d& gravity_B, const BaseMotion& base,
                           const RobotJointVector& q, const RobotJointVector& qd,
                           const RobotJointVector& qdd,
                           const std::array<WheelForce, model::kNumLegs>& wheel_forces,
                           InverseDynamicsResult& out) const {
  // Per link, in its own frame: angular velocity w, origin velocity v, angular acceleration
  // wd, classical origin acceleration a (gravity folded in as an upward acceleration of the
  // base), pose in B, and the wrench (n about the origin, f) its parent exerts on it.
  std::array<Eigen::Vector3d, kNumLinks> w, v, wd, a, n, f, p_B;
  std::array<Eigen::Matrix3d, kNumLinks> R_B;
  w[0] = base.omega_B;
  v[0] = base.v_B;
  wd[0] = base.omegadot_B;
  a[0] = base.a_B - gravity_B;
  R_B[0].setIdentity();
  p_B[0].setZero();
  for (int i = 0; i < kNumLinks; ++i) {
    const Link& L = links_[i];
    if (i > 0) {
      const int p = L.parent;
      const Eigen::Matrix3d R = L.R_PJ * Eigen::AngleAxisd(q[L.joint], L.axis).matrix();
      const Eigen::Matrix3d Rt = R.transpose();
      const Eigen::Vector3d& r = L.p_PJ;  // joint origin in the parent frame
      const Eigen::Vector3d s = L.axis * qd[L.joint];
      const Eigen::Vector3d w_p = Rt * w[p];
      w[i] = w_p + s;
      v[i] = Rt * (v[p] + w[p].cross(r));
      wd[i] = Rt * wd[p] + L.axis * qdd[L.joint] + w_p.cross(s);
      a[i] = Rt * (a[p] + wd[p].cross(r) + w[p].cross(w[p].cross(r)));
      R_B[i] = R_B[p] * R;
      p_B[i] = p_B[p] + R_B[p] * r;
    }
    // Newton-Euler of the link about its CoM, moved to its origin.
    const Eigen::Vector3d a_c = a[i] + wd[i].cross(L.com) + w[i].cross(w[i].cross(L.com));
    f[i] = L.mass * a_c;
    n[i] = L.inertia_com * wd[i] + w[i].cross(L.inertia_com * w[i]) + L.com.cross(f[i]);
  }
  // External forces on the wheels: subtract what the ground provides.
  for (int leg = 0; leg < model::kNumLegs; ++leg) {
    const int i = wheel_link_[leg];
    const Eigen::Vector3d f_L = R_B[i].transpose() * wheel_forces[leg].f_B;
    const Eigen::Vector3d p_L = R_B[i].transpose() * (wheel_forces[leg].p_B - p_B[i]);
    f[i] -= f_L;
    n[i] -= p_L.cross(f_L);
  }
  for (int i = kNumLinks - 1; i > 0; --i) {
    const Link& L = links_[i];
    out.tau[L.joint] = L.axis.dot(n[i]);
    const Eigen::Matrix3d R = L.R_PJ * Eigen::AngleAxisd(q[L.joint], L.axis).matrix();
    const Eigen::Vector3d f_p = R * f[i];
    f[L.parent] += f_p;
    n[L.parent] += R * n[i] + L.p_PJ.cross(f_p);
  }
  out.base_force_B = f[0];
  out.base_torque_B = n[0];
}

}  // namespace wj::nmpc
