// The robot's collision spheres (see collision_spheres.h).
#include "collision_spheres.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "simbody_conversions.h"

namespace wj::sim::detail {

namespace {

void finishBounds(SphereGroup& g) {
  Eigen::Vector3d lo = g.centers.front(), hi = g.centers.front();
  for (const auto& c : g.centers) {
    lo = lo.cwiseMin(c);
    hi = hi.cwiseMax(c);
  }
  g.bound_center = 0.5 * (lo + hi);
  g.bound_radius = 0.0;
  for (const auto& c : g.centers)
    g.bound_radius = std::max(g.bound_radius, (c - g.bound_center).norm());
  g.bound_radius += g.radius;
}

// Spheres of `radius` along the segment a-b, spaced at most `radius` apart.
std::vector<Eigen::Vector3d> segmentSpheres(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                            double radius) {
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / radius)));
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i <= n; ++i) out.push_back(a + (b - a) * (static_cast<double>(i) / n));
  return out;
}

// Spheres of `radius` whose union is the box of full size `size` centred at the origin with
// edges rounded by `radius`: centres on the surface of the box shrunk by `radius`, spaced at
// most `radius` apart.
std::vector<Eigen::Vector3d> boxSurfaceSpheres(const Eigen::Vector3d& size, double radius) {
  const Eigen::Vector3d half =
      (0.5 * size).cwiseMax(Eigen::Vector3d::Constant(radius)) - Eigen::Vector3d::Constant(radius);
  int n[3];
  for (int a = 0; a < 3; ++a)
    n[a] = std::max(1, static_cast<int>(std::ceil(2.0 * half[a] / radius)));
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i <= n[0]; ++i)
    for (int j = 0; j <= n[1]; ++j)
      for (int k = 0; k <= n[2]; ++k) {
        const bool on_surface = i == 0 || i == n[0] || j == 0 || j == n[1] || k == 0 || k == n[2];
        if (!on_surface) continue;
        out.emplace_back(-half.x() + 2.0 * half.x() * i / n[0],
                         -half.y() + 2.0 * half.y() * j / n[1],
                         -half.z() + 2.0 * half.z() * k / n[2]);
      }
  return out;
}

}  // namespace

std::vector<GroundSphere> makeGroundSpheres(const model::RobotModel& model,
                                            const ContactSettings& cs, bool ellipsoid_wheels) {
  std::vector<GroundSphere> ground_spheres;
  const double r = model.wheelRadius();
  const double base_r = cs.base_sphere_radius_m;
  const double body_r = cs.body_sphere_radius_m;
  for (const model::Leg leg : model::kLegs) {
    const int l = static_cast<int>(leg);
    const model::JointSpec& wheel = model.joint(leg, model::JointKind::Wheel);
    const model::JointSpec& knee = model.joint(leg, model::JointKind::KFE);
    if (!ellipsoid_wheels)
      ground_spheres.push_back({wheel.child_link, Part::Wheel, l, SimTK::Vec3(0.0), r});
    ground_spheres.push_back(
        {knee.parent_link, Part::Leg, l, toVec3(knee.X_PJ.translation()), body_r});
  }
  const Eigen::Vector3d corner =
      (0.5 * model.baseBoxSize()).cwiseMax(Eigen::Vector3d::Constant(base_r)) -
      Eigen::Vector3d::Constant(base_r);
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d c((i & 1 ? 1 : -1) * corner.x(), (i & 2 ? 1 : -1) * corner.y(),
                            (i & 4 ? 1 : -1) * corner.z());
    ground_spheres.push_back({0, Part::Base, -1, toVec3(c), base_r});
  }
  // By link, so that forEachGroundContact() fetches each link's pose once.
  std::stable_sort(ground_spheres.begin(), ground_spheres.end(),
                   [](const GroundSphere& a, const GroundSphere& b) { return a.link < b.link; });
  return ground_spheres;
}

std::vector<SphereGroup> makeBoxSphereGroups(const model::RobotModel& model,
                                             const ContactSettings& cs) {
  std::vector<SphereGroup> groups;
  const double r = model.wheelRadius();
  const double base_r = cs.base_sphere_radius_m;
  const double body_r = cs.body_sphere_radius_m;
  {
    SphereGroup base;
    base.link = 0;
    base.part = Part::Base;
    base.radius = base_r;
    base.centers = boxSurfaceSpheres(model.baseBoxSize(), base_r);
    finishBounds(base);
    groups.push_back(std::move(base));
  }
  for (const model::Leg leg : model::kLegs) {
    const int l = static_cast<int>(leg);
    const model::JointSpec& knee = model.joint(leg, model::JointKind::KFE);
    const model::JointSpec& wheel = model.joint(leg, model::JointKind::Wheel);
    SphereGroup w;
    w.link = wheel.child_link;
    w.part = Part::Wheel;
    w.leg = l;
    w.radius = r;
    w.centers = {Eigen::Vector3d::Zero()};
    finishBounds(w);
    groups.push_back(std::move(w));
    for (const model::JointSpec* j : {&knee, &wheel}) {
      SphereGroup g;
      g.link = j->parent_link;  // thigh (ends at the knee) or shank (ends at the axle)
      g.part = Part::Leg;
      g.leg = l;
      g.radius = body_r;
      g.centers = segmentSpheres(Eigen::Vector3d::Zero(), j->X_PJ.translation(), body_r);
      finishBounds(g);
      groups.push_back(std::move(g));
    }
  }
  return groups;
}

void keepSagittal(std::vector<GroundSphere>& ground_spheres, std::vector<SphereGroup>& groups) {
  // A base sphere within this of y = 0 lies on the plane (the sphere grids put centres there
  // up to round-off); the mirror images of the others are the same within round-off too.
  constexpr double kOnPlane = 1e-12;
  const auto right = [](int leg) {
    return leg == static_cast<int>(model::Leg::RF) || leg == static_cast<int>(model::Leg::RH);
  };
  std::vector<GroundSphere> kept_spheres;
  for (GroundSphere g : ground_spheres) {
    if (g.part == Part::Base) {
      if (g.center[1] < -kOnPlane) continue;
      g.weight = g.center[1] > kOnPlane ? 2.0 : 1.0;
    } else {
      if (right(g.leg)) continue;
      g.weight = 2.0;
    }
    kept_spheres.push_back(g);
  }
  ground_spheres = std::move(kept_spheres);
  std::vector<SphereGroup> kept_groups;
  for (SphereGroup& g : groups) {
    if (g.part != Part::Base) {
      if (right(g.leg)) continue;
      g.weight = 2.0;
      kept_groups.push_back(std::move(g));
      continue;
    }
    // The base's spheres split into those off the plane (twice) and those on it (once).
    SphereGroup off = g, on = g;
    off.centers.clear();
    on.centers.clear();
    for (const Eigen::Vector3d& c : g.centers) {
      if (c.y() > kOnPlane) off.centers.push_back(c);
      if (std::abs(c.y()) <= kOnPlane) on.centers.push_back(c);
    }
    off.weight = 2.0;
    for (SphereGroup* h : {&off, &on}) {
      if (h->centers.empty()) continue;
      finishBounds(*h);
      kept_groups.push_back(std::move(*h));
    }
  }
  groups = std::move(kept_groups);
}

}  // namespace wj::sim::detail
