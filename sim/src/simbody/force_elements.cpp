// SimRobot's Simbody force elements: gravity, the drives, and the contacts of the collision
// spheres with the ground and with the terrain boxes (see sim_robot_impl.h).
#include "sim_robot_impl.h"

namespace wj::sim {

using detail::GroundContact;
using detail::GroundSphere;
using detail::SphereGroup;
using detail::toVec3;

// Uniform gravity on every link: what SimTK::Force::Gravity computes (m g at the link's centre
// of mass, potential energy -m g . p_CoM), with the mass properties cached instead of looked
// up per evaluation; Force::Gravity's look-ups and whole-vector addition cost more than the
// arithmetic.
class SimRobot::Impl::GravityElement : public SimTK::Force::Custom::Implementation {
 public:
  explicit GravityElement(const Impl& impl)
      : impl_(impl), gravity_(0.0, 0.0, -impl.settings.gravity_m_s2) {}
  void calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>& body_forces,
                 SimTK::Vector_<SimTK::Vec3>&, SimTK::Vector&) const override {
    for (const int b : impl_.bodies) {
      const SimTK::Vec3 p_CB_G = impl_.mobods[b].getBodyTransform(s).R() * impl_.link_com[b];
      const SimTK::Vec3 F_CB_G = impl_.link_mass[b] * gravity_;
      body_forces[impl_.mobods[b].getMobilizedBodyIndex()] +=
          SimTK::SpatialVec(p_CB_G % F_CB_G, F_CB_G);
    }
  }
  SimTK::Real calcPotentialEnergy(const SimTK::State& s) const override {
    double pe = 0.0;
    for (const int b : impl_.bodies) {
      const SimTK::Vec3 p_G_CB = impl_.mobods[b].getBodyTransform(s) * impl_.link_com[b];
      pe -= impl_.link_mass[b] * (~gravity_ * p_G_CB);
    }
    return pe;
  }

 private:
  const Impl& impl_;
  SimTK::Vec3 gravity_;  // in G [m/s^2]
};

// The drives: one Force::Custom applying tau_i to the mobility of each pin joint (sagittal:
// twice a left joint's, for it and its mirror joint).
class SimRobot::Impl::DriveElement : public SimTK::Force::Custom::Implementation {
 public:
  explicit DriveElement(const Impl& impl) : impl_(impl) {}
  void calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>&,
                 SimTK::Vector_<SimTK::Vec3>&, SimTK::Vector& mobility_forces) const override {
    const bool hold = impl_.settings.actuator_update == ActuatorUpdate::ZeroOrderHold;
    const SimTK::Vector& q = impl_.matter.getQ(s);
    const SimTK::Vector& u = impl_.matter.getU(s);
    for (int i = 0; i < model::kNumJoints; ++i) {
      if (impl_.drive_weight[i] == 0.0) continue;
      const double tau =
          hold ? impl_.held_torque[i]
               : impl_.driveTorque(i, impl_.jointQ(q, i), impl_.jointU(u, i), nullptr);
      // = pins[i].applyOneMobilityForce()
      mobility_forces[impl_.u_index[i]] += impl_.drive_weight[i] * tau;
    }
  }
  SimTK::Real calcPotentialEnergy(const SimTK::State&) const override { return 0.0; }

 private:
  const Impl& impl_;
};

// Contact of the robot's collision spheres with the terrain boxes (Simbody 3.7 has no
// sphere-brick tracker; see docs/sim.md).
class SimRobot::Impl::BoxElement : public SimTK::Force::Custom::Implementation {
 public:
  explicit BoxElement(const Impl& impl) : impl_(impl) {}
  void calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>& body_forces,
                 SimTK::Vector_<SimTK::Vec3>&, SimTK::Vector&) const override {
    impl_.forEachBoxContact(s, [&](const SphereGroup& g, const detail::SphereContact& c) {
      const SimTK::MobilizedBody& mb = impl_.mobods[g.link];
      const SimTK::Vec3 station = ~mb.getBodyTransform(s) * toVec3(c.point);
      mb.applyForceToBodyPoint(s, station, g.weight * toVec3(c.force), body_forces);
    });
  }
  SimTK::Real calcPotentialEnergy(const SimTK::State& s) const override {
    double pe = 0.0;
    impl_.forEachBoxContact(s, [&](const SphereGroup& g, const detail::SphereContact& c) {
      pe += g.weight * c.potential_energy;
    });
    return pe;
  }

 private:
  const Impl& impl_;
};

// Contact of the wheel, knee and base-corner spheres with the ground half-space (Simbody's
// Hertz law, see HertzCircularLaw).
class SimRobot::Impl::GroundElement : public SimTK::Force::Custom::Implementation {
 public:
  explicit GroundElement(const Impl& impl) : impl_(impl) {}
  void calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>& body_forces,
                 SimTK::Vector_<SimTK::Vec3>&, SimTK::Vector&) const override {
    impl_.forEachGroundContact(s, [&](const GroundSphere& g, const GroundContact& c) {
      const SimTK::Vec3 force = g.weight * c.force;
      body_forces[impl_.mobods[g.link].getMobilizedBodyIndex()] +=
          SimTK::SpatialVec(c.arm % force, force);
    });
  }
  SimTK::Real calcPotentialEnergy(const SimTK::State& s) const override {
    double pe = 0.0;
    impl_.forEachGroundContact(s, [&](const GroundSphere& g, const GroundContact& c) {
      pe += g.weight * c.potential_energy;
    });
    return pe;
  }

 private:
  const Impl& impl_;
};

//==============================================================================================
void SimRobot::Impl::addGravityElement() {
  SimTK::Force::Custom(forces, new GravityElement(*this));
}

void SimRobot::Impl::addDriveAndContactElements() {
  SimTK::Force::Custom(forces, new DriveElement(*this));
  if (settings.terrain.has_ground) SimTK::Force::Custom(forces, new GroundElement(*this));
  if (!settings.terrain.boxes.empty()) SimTK::Force::Custom(forces, new BoxElement(*this));
}

}  // namespace wj::sim
