#include "planner/leg_kinematics.h"

#include <algorithm>
#include <cmath>

namespace wj::planner {

Eigen::Vector2d PlanarLeg::forward(const Eigen::Vector2d& q) const {
  const double s12 = std::sin(q[0] + q[1]), c12 = std::cos(q[0] + q[1]);
  return {-l1 * std::sin(q[0]) - l2 * s12, -l1 * std::cos(q[0]) - l2 * c12};
}

Eigen::Matrix2d PlanarLeg::jacobian(const Eigen::Vector2d& q) const {
  const double s1 = std::sin(q[0]), c1 = std::cos(q[0]);
  const double s12 = std::sin(q[0] + q[1]), c12 = std::cos(q[0] + q[1]);
  Eigen::Matrix2d J;
  J << -l1 * c1 - l2 * c12, -l2 * c12, l1 * s1 + l2 * s12, l2 * s12;
  return J;
}

Eigen::Vector2d PlanarLeg::knee(const Eigen::Vector2d& q) const {
  return {-l1 * std::sin(q[0]), -l1 * std::cos(q[0])};
}

Eigen::Vector2d PlanarLeg::inverse(const Eigen::Vector2d& b, double* reach_margin) const {
  return inversePose(b, reach_margin).q;
}

LegPose PlanarLeg::inversePose(const Eigen::Vector2d& b, double* reach_margin, bool angles) const {
  const double r_min = std::abs(l1 - l2) + 1e-9, r_max = l1 + l2 - 1e-9;
  const double L = b.norm();
  if (reach_margin) *reach_margin = std::min(L - r_min, r_max - L);
  const double Lc = std::clamp(L, r_min, r_max);
  const double c2 = std::clamp((Lc * Lc - l1 * l1 - l2 * l2) / (2.0 * l1 * l2), -1.0, 1.0);
  const double s2 = -std::sqrt(std::max(0.0, 1.0 - c2 * c2));  // knee bent backward: q2 <= 0
  // -b = L (sin a, cos a); l1 sin q1 + l2 sin(q1 + q2) = Lc sin(q1 + beta) with
  // (sin beta, cos beta) = (l2 s2, l1 + l2 c2) / Lc; so q1 = a - beta.
  LegPose p;
  p.sa = L > 0.0 ? -b.x() / L : 0.0;
  p.ca = L > 0.0 ? -b.y() / L : 1.0;
  p.sb = l2 * s2 / Lc;
  p.cb = (l1 + l2 * c2) / Lc;
  p.s2 = s2;
  p.c2 = c2;
  p.s1 = p.sa * p.cb - p.ca * p.sb;
  p.c1 = p.ca * p.cb + p.sa * p.sb;
  p.s12 = p.s1 * c2 + p.c1 * s2;
  p.c12 = p.c1 * c2 - p.s1 * s2;
  if (angles) solveAngles(p);
  return p;
}

void PlanarLeg::solveAngles(LegPose& p) const {
  // q1 = a - beta with a = atan2(sa, ca) and beta = atan2(sb, cb) in [-pi/2, 0] (sb <= 0,
  // cb >= 0 for l1 >= l2), so q1 lies in (-pi, 3pi/2]: one atan2 of (s1, c1), unwrapped
  // above pi where a is in the upper half-plane. q2 = -acos(c2) = atan2(s2, c2), s2 <= 0.
  double q1;
  if (l1 >= l2) {
    q1 = std::atan2(p.s1, p.c1);
    if (q1 < -M_PI_2 && p.sa > 0.0) q1 += 2.0 * M_PI;
  } else {
    q1 = std::atan2(p.sa, p.ca) - std::atan2(p.sb, p.cb);
  }
  p.q = {q1, std::atan2(p.s2, p.c2)};
}

Eigen::Matrix2d PlanarLeg::jacobian(const LegPose& p) const {
  Eigen::Matrix2d J;
  J << -l1 * p.c1 - l2 * p.c12, -l2 * p.c12, l1 * p.s1 + l2 * p.s12, l2 * p.s12;
  return J;
}

Eigen::Vector2d PlanarLeg::balancingTorque(const LegPose& pose, const Eigen::Vector2d& p,
                                           const Eigen::Vector2d& f) const {
  const Eigen::Vector2d pk = p - Eigen::Vector2d(-l1 * pose.s1, -l1 * pose.c1);
  return {p.x() * f.y() - p.y() * f.x(), pk.x() * f.y() - pk.y() * f.x()};
}

Eigen::Vector2d PlanarLeg::balancingTorque(const Eigen::Vector2d& q, const Eigen::Vector2d& p,
                                           const Eigen::Vector2d& f) const {
  const Eigen::Vector2d k = knee(q);
  const Eigen::Vector2d pk = p - k;
  return {p.x() * f.y() - p.y() * f.x(), pk.x() * f.y() - pk.y() * f.x()};
}

}  // namespace wj::planner
