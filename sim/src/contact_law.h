#pragma once
/// @file Sphere-against-box geometry and the compliant contact law used for the box terrain
/// (walls, steps). Internal to the sim library; header-only and C++17-compatible because both
/// the Simbody force element (C++17) and the clearance metric use it.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/settings.h"

namespace wj::sim::detail {

/// Signed distance of a point to a box, with the outward normal and closest surface point.
struct BoxDistance {
  double distance = 0.0;                              ///< > 0 outside, < 0 inside [m]
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, pointing out of the box
  Eigen::Vector3d closest = Eigen::Vector3d::Zero();  ///< closest point on the box surface
};

/// Signed distance from `p` to the surface of `box`.
inline BoxDistance signedDistance(const Box& box, const Eigen::Vector3d& p) {
  BoxDistance out;
  const Eigen::Vector3d clamped = p.cwiseMax(box.min).cwiseMin(box.max);
  const Eigen::Vector3d d = p - clamped;
  const double outside = d.norm();
  if (outside > 0.0) {
    out.distance = outside;
    out.normal = d / outside;
    out.closest = clamped;
    return out;
  }
  // Inside: leave through the nearest face.
  double best = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    const double to_min = p[axis] - box.min[axis];
    const double to_max = box.max[axis] - p[axis];
    if (to_min < best) {
      best = to_min;
      out.normal = -Eigen::Vector3d::Unit(axis);
      out.closest = p;
      out.closest[axis] = box.min[axis];
    }
    if (to_max < best) {
      best = to_max;
      out.normal = Eigen::Vector3d::Unit(axis);
      out.closest = p;
      out.closest[axis] = box.max[axis];
    }
  }
  out.distance = -best;
  return out;
}

/// Effective constants of a contact between two surfaces of the same material.
struct ContactLaw {
  double modulus_pa = 0.0;               ///< effective Hertz modulus E [Pa]
  double dissipation_s_m = 0.0;          ///< Hunt-Crossley c [s/m]
  double static_friction = 0.0;          ///< mu_s
  double dynamic_friction = 0.0;         ///< mu_d
  double viscous_friction_s_m = 0.0;     ///< mu_v [s/m]
  double transition_velocity_m_s = 1.0;  ///< v_t [m/s]
};

/// The law for two surfaces made of the material of `c`. Same combination rule as Simbody's
/// Hertz generators: equal materials give E = k / 2^(3/2) and unchanged c and mu.
inline ContactLaw makeContactLaw(const ContactSettings& c) {
  ContactLaw law;
  law.modulus_pa = c.stiffness_pa / std::pow(2.0, 1.5);
  law.dissipation_s_m = c.dissipation_s_m;
  law.static_friction = c.static_friction;
  law.dynamic_friction = c.dynamic_friction;
  law.viscous_friction_s_m = c.viscous_friction_s_m;
  law.transition_velocity_m_s = c.transition_velocity_m_s;
  return law;
}

/// Friction coefficient at slip speed `v`: rises smoothly from 0 to mu_s at v_t (a
/// regularised stiction), falls towards mu_d above it (Stribeck), plus viscous mu_v v.
inline double frictionCoefficient(const ContactLaw& law, double v) {
  const double x = v / law.transition_velocity_m_s;
  double mu_dry = 0.0;
  if (x < 1.0) {
    mu_dry = law.static_friction * x * (2.0 - x);
  } else {
    const double s = x - 1.0;
    mu_dry = law.dynamic_friction + (law.static_friction - law.dynamic_friction) / (1.0 + s * s);
  }
  return mu_dry + law.viscous_friction_s_m * v;
}

/// Result of one sphere-surface contact.
struct SphereContact {
  bool touching = false;                            ///< the sphere overlaps the surface
  double depth = 0.0;                               ///< overlap [m]
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< where the force acts [m]
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  ///< force on the sphere [N]
  double potential_energy = 0.0;                    ///< stored elastic energy [J]
};

/// Hertz normal force of a sphere of `radius` on a flat surface with outward `normal`, overlap
/// `depth`, penetration rate `depth_rate` and tangential slip velocity `slip` of the sphere's
/// material point: f_n = 4/3 E sqrt(R) x^(3/2) (1 + 3/2 c xdot) (Hunt and Crossley 1975),
/// friction -mu(|slip|) f_n slip/|slip|.
inline Eigen::Vector3d calcContactForce(const ContactLaw& law, double radius, double depth,
                                        double depth_rate, const Eigen::Vector3d& normal,
                                        const Eigen::Vector3d& slip, double* potential_energy) {
  const double f_hertz =
      (4.0 / 3.0) * law.modulus_pa * std::sqrt(radius) * depth * std::sqrt(depth);
  if (potential_energy) *potential_energy = 0.4 * f_hertz * depth;
  const double f_normal = f_hertz * (1.0 + 1.5 * law.dissipation_s_m * depth_rate);
  if (f_normal <= 0.0) return Eigen::Vector3d::Zero();  // separating faster than it recovers
  Eigen::Vector3d force = f_normal * normal;
  const double v = slip.norm();
  if (v > 1e-12) force -= (f_normal * frictionCoefficient(law, v) / v) * slip;
  return force;
}

}  // namespace wj::sim::detail
