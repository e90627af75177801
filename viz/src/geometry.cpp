#include "viz/geometry.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace wj::viz {

Eigen::Isometry3d basePose(const Frame& frame) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = frame.q_WB.normalized().toRotationMatrix();
  X.translation() = frame.p_WB;
  return X;
}

std::vector<Eigen::Isometry3d> calcLinkPosesW(const model::RobotModel& robot, const Frame& frame) {
  Eigen::VectorXd q(model::kNumJoints);
  for (int j = 0; j < model::kNumJoints; ++j) q[j] = frame.q[j];
  std::vector<Eigen::Isometry3d> X = robot.calcLinkPoses(q);
  const Eigen::Isometry3d X_WB = basePose(frame);
  for (auto& x : X) x = X_WB * x;
  return X;
}

std::vector<PosedShape> calcPosedShapes(const model::RobotModel& robot, const Frame& frame) {
  const auto X_WL = calcLinkPosesW(robot, frame);
  std::vector<PosedShape> out;
  for (std::size_t i = 0; i < robot.links().size(); ++i)
    for (const model::LinkShape& s : robot.links()[i].shapes)
      out.push_back({static_cast<int>(i), s, X_WL[i] * s.X_LS});
  return out;
}

std::array<Eigen::Vector3d, model::kNumLegs> calcWheelCentersW(const model::RobotModel& robot,
                                                               const Frame& frame) {
  const auto X_WL = calcLinkPosesW(robot, frame);
  std::array<Eigen::Vector3d, model::kNumLegs> c;
  for (const model::Leg leg : model::kLegs)
    c[static_cast<int>(leg)] =
        X_WL[robot.joint(leg, model::JointKind::Wheel).child_link].translation();
  return c;
}

std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> p) {
  std::sort(p.begin(), p.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  if (p.size() < 3) return p;
  const auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a,
                        const Eigen::Vector2d& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  std::vector<Eigen::Vector2d> h(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {  // lower hull
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0.0) --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, lower = k + 1; i-- > 0;) {  // upper hull
    while (k >= lower && cross(h[k - 2], h[k - 1], p[i]) <= 0.0) --k;
    h[k++] = p[i];
  }
  h.resize(k - 1);  // the last point repeats the first
  return h;
}

std::vector<Eigen::Vector2d> sideOutline(const PosedShape& s, int segments) {
  const auto side = [](const Eigen::Vector3d& p) { return Eigen::Vector2d(p.x(), p.z()); };
  std::vector<Eigen::Vector2d> pts;
  const Eigen::Vector3d& d = s.shape.size;
  switch (s.shape.kind) {
    case model::LinkShape::Kind::Box:
      for (const double sx : {-0.5, 0.5})
        for (const double sy : {-0.5, 0.5})
          for (const double sz : {-0.5, 0.5})
            pts.push_back(side(s.X_WS * Eigen::Vector3d(sx * d.x(), sy * d.y(), sz * d.z())));
      break;
    case model::LinkShape::Kind::Cylinder:
      for (int i = 0; i < segments; ++i) {
        const double a = 2.0 * std::numbers::pi * i / segments;
        for (const double h : {-0.5 * d.z(), 0.5 * d.z()})
          pts.push_back(
              side(s.X_WS * Eigen::Vector3d(d.x() * std::cos(a), d.x() * std::sin(a), h)));
      }
      break;
    case model::LinkShape::Kind::Sphere: {
      const Eigen::Vector2d c = side(s.X_WS.translation());
      for (int i = 0; i < segments; ++i) {
        const double a = 2.0 * std::numbers::pi * i / segments;
        pts.push_back(c + d.x() * Eigen::Vector2d(std::cos(a), std::sin(a)));
      }
      break;
    }
  }
  return convexHull(std::move(pts));
}

}  // namespace wj::viz
