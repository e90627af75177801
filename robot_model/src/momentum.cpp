#include "robot_model/momentum.h"

#include <Eigen/Geometry>
#include <vector>

namespace wj::model {

Eigen::Vector3d calcCentralAngularMomentum(const RobotModel& robot, const Eigen::Matrix3d& R_WB,
                                           const Eigen::Vector3d& w_WB, const Eigen::VectorXd& q,
                                           const Eigen::VectorXd& qd) {
  constexpr double h = 1e-6;  // step of the central difference along qd [s]
  const auto X = robot.calcLinkPoses(q);
  const auto X_plus = robot.calcLinkPoses(q + h * qd);
  const auto X_minus = robot.calcLinkPoses(q - h * qd);
  const auto& links = robot.links();
  const std::size_t n = links.size();
  std::vector<Eigen::Vector3d> p(n), v(n), w(n);
  Eigen::Vector3d c = Eigen::Vector3d::Zero(), v_c = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Inertia& li = links[i].inertia;
    // Link CoM and its velocity relative to the base, in B; the link's angular velocity
    // relative to the base from dR R^T = [w]x.
    const Eigen::Vector3d v_rel = (X_plus[i] * li.com - X_minus[i] * li.com) / (2.0 * h);
    const Eigen::Matrix3d W =
        (X_plus[i].linear() - X_minus[i].linear()) / (2.0 * h) * X[i].linear().transpose();
    p[i] = R_WB * (X[i] * li.com);
    v[i] = w_WB.cross(p[i]) + R_WB * v_rel;
    w[i] = w_WB + R_WB * Eigen::Vector3d(W(2, 1), W(0, 2), W(1, 0));
    c += li.mass * p[i];
    v_c += li.mass * v[i];
  }
  c /= robot.totalMass();
  v_c /= robot.totalMass();
  Eigen::Vector3d H = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Inertia& li = links[i].inertia;
    const Eigen::Matrix3d R_WL = R_WB * X[i].linear();
    H += li.mass * (p[i] - c).cross(v[i] - v_c) + R_WL * li.inertia_com * R_WL.transpose() * w[i];
  }
  return H;
}

}  // namespace wj::model
