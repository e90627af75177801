#pragma once
// The ground's contact law: Simbody's HertzCircular sphere-on-half-space force, written out.
// Internal to wj_sim_simbody (C++17, sees Simbody); inline, as it runs per sphere and per
// force evaluation.

#include <Simbody.h>

#include <cmath>

namespace wj::sim::detail {

// Simbody's compliant contact of a sphere with a half-space, written out so that the ground
// needs neither ContactTrackerSubsystem nor CompliantContactSubsystem (their broad phase,
// contact bookkeeping and per-contact virtual calls cost more than the forces themselves).
// Term by term what ContactTracker::HalfSpaceSphere and ContactForceGenerator::HertzCircular
// of Simbody 3.7 compute: overlap x = r - height of the centre, contact point halfway into the
// overlap, effective radius r, f_H = 4/3 k x sqrt(R k x) with k = E^(2/3), Hunt-Crossley
// f_n = f_H (1 + 3/2 c xdot), no force while f_n <= 0, friction -mu(v) f_n v_t / |v_t| with
// Simbody's quintic Stribeck curve.
struct HertzCircularLaw {
  double k = 0.0;   // combined stiffness^(2/3)
  double c = 0.0;   // combined dissipation [s/m]
  double us = 0.0;  // combined static, dynamic and viscous friction
  double ud = 0.0;
  double uv = 0.0;
  double vt = 1.0;     // friction transition velocity [m/s]
  double oo_vt = 1.0;  // 1 / vt
};

// Combination rules of HertzCircular for surfaces of materials m1 and m2.
inline HertzCircularLaw makeHertzCircularLaw(const SimTK::ContactMaterial& m1,
                                             const SimTK::ContactMaterial& m2, double vt) {
  HertzCircularLaw law;
  const double k1 = m1.getStiffness23(), k2 = m2.getStiffness23();
  const double s1 = k2 / (k1 + k2), s2 = 1 - s1;
  law.k = k1 * s1;
  law.c = m1.getDissipation() * s1 + m2.getDissipation() * s2;
  const auto mean = [](double a, double b) {
    double m = 2 * a * b;
    if (m != 0) m /= (a + b);
    return m;
  };
  law.us = mean(m1.getStaticFriction(), m2.getStaticFriction());
  law.ud = mean(m1.getDynamicFriction(), m2.getDynamicFriction());
  law.uv = mean(m1.getViscousFriction(), m2.getViscousFriction());
  law.vt = vt;
  law.oo_vt = 1 / vt;
  return law;
}

// Simbody's smooth step 10x^3 - 15x^4 + 6x^5 on [0, 1].
inline double step5(double x) {
  const double x3 = x * x * x;
  return x3 * (10 + x * (6 * x - 15));
}

// Simbody's friction coefficient at slip speed v (in multiples of the transition velocity):
// quintic rise from 0 to us at v = 1, quintic fall to ud at v = 3, plus viscous uv v.
inline double stribeck(double us, double ud, double uv, double v) {
  const double mu_wet = uv * v;
  double mu_dry;
  if (v >= 3)
    mu_dry = ud;
  else if (v >= 1)
    mu_dry = us - (us - ud) * step5((v - 1) / 2);
  else
    mu_dry = us * step5(v);
  return mu_dry + mu_wet;
}

// Force of the ground on a sphere of effective radius R overlapping it by x > 0, with `normal`
// pointing out of the ground and `vel` the velocity of the sphere's material point at the
// contact point; `potential_energy` receives the elastic energy (0 while pulling, as Simbody).
inline SimTK::Vec3 calcHertzCircularForce(const HertzCircularLaw& law, double R, double x,
                                          const SimTK::UnitVec3& normal, const SimTK::Vec3& vel,
                                          double& potential_energy) {
  const double fH = (4. / 3.) * law.k * x * std::sqrt(R * law.k * x);
  const double xdot = -SimTK::dot(vel, normal);
  const SimTK::Vec3 vel_normal = -xdot * normal;
  const SimTK::Vec3 vel_tangent = vel - vel_normal;
  const double fHC = fH * 1.5 * law.c * xdot;
  const double f_normal = fH + fHC;
  if (f_normal <= 0) {
    potential_energy = 0;
    return SimTK::Vec3(0);
  }
  potential_energy = (2. / 5.) * fH * x;
  SimTK::Vec3 force_friction(0);
  const double vslip_sq = vel_tangent.normSqr();
  if (vslip_sq > SimTK::square(SimTK::SignificantReal)) {
    const double vslip = std::sqrt(vslip_sq);
    const double mu = stribeck(law.us, law.ud, law.uv * law.vt, vslip * law.oo_vt);
    force_friction = (-(f_normal * mu) / vslip) * vel_tangent;
  }
  return fH * normal + (fHC * normal + force_friction);
}

// One sphere overlapping the ground.
struct GroundContact {
  double depth = 0.0;      // overlap [m]
  SimTK::Vec3 point{0.0};  // contact point, in G [m]
  SimTK::Vec3 arm{0.0};    // from the link origin to the contact point, in G [m]
  SimTK::Vec3 force{0.0};  // force of the ground on the sphere, in G [N]
  double potential_energy = 0.0;
};

}  // namespace wj::sim::detail
