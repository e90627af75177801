#pragma once
// SimRobot's implementation: the Simbody system, the contact geometry, the drives and the
// integrator. Internal to wj_sim_simbody (C++17, sees Simbody). Built in sim_robot_build.cpp,
// its force elements in force_elements.cpp, run in sim_robot.cpp.

#include <Simbody.h>

#include <array>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include "../contact_law.h"
#include "collision_spheres.h"
#include "euler_stepper.h"
#include "ground_contact.h"
#include "sim/sim_robot.h"
#include "simbody_conversions.h"

namespace wj::sim {

struct SimRobot::Impl {
  class GravityElement;
  class DriveElement;
  class BoxElement;
  class GroundElement;

  Impl(const model::RobotModel& m, const SimSettings& s, SimModel k);

  // Construction steps (sim_robot_build.cpp), in the order Impl() takes them.
  // The ground half-space: its normal, and its surface for Simbody's tracker (ellipsoid wheels).
  void addGround(const SimTK::ContactMaterial& material, bool ellipsoid_wheels);
  // Multibody tree: free base, then per leg HAA -> HFE -> KFE -> WHEEL pins. Sagittal: planar
  // base, and only the left legs, with double mass and inertia.
  void buildTree();
  // Sagittal: each right joint read as its left mirror joint (jointQ, jointU), each left drive
  // acting twice (DriveElement).
  void mapJoints();
  // The contact geometry: ellipsoid wheels on Simbody's tracker, the ground spheres and the
  // sphere groups against the boxes.
  void addContactGeometry(const SimTK::ContactMaterial& material, bool ellipsoid_wheels);
  // The plant's drive envelopes and the motor-latency ring.
  void makeDrives();
  // Topology and model stages; the q and u indices and the mass properties they fix.
  void realizeAndCache();
  // Classification of Simbody's contact surfaces by the body that carries them.
  void classifySurfaces();
  // Force elements (force_elements.cpp): gravity, then drives and contacts, in this order.
  void addGravityElement();
  void addDriveAndContactElements();

  // Drive torque of joint i (PD law on the current command, clipped by the envelope) at
  // joint position q and speed qd; `demand` receives the unclipped value.
  double driveTorque(int i, double q, double qd, double* demand) const {
    const model::JointCommand& c = commands[i];
    const double tau = c.kp * (c.q_des - q) + c.kd * (c.qd_des - qd) + c.tau_ff;
    if (demand) *demand = tau;
    return envelopes[i].saturate(tau, qd);
  }
  // Position and speed of joint i at state s, read from the matter subsystem's q and u by the
  // indices cached after realizeModel (MobilizedBody::getOneQ() looks them up per call).
  // Sagittal: a right joint is its left mirror joint times mirrorSign().
  double jointQ(const SimTK::Vector& q, int i) const { return joint_sign[i] * q[q_index[i]]; }
  double jointU(const SimTK::Vector& u, int i) const { return joint_sign[i] * u[u_index[i]]; }
  // Sagittal: throws AsymmetryError unless the right commands mirror the left ones.
  void checkSymmetric(const model::JointCommands& c) const;
  // Sagittal: throws AsymmetryError unless the placement is planar and symmetric.
  void checkSymmetric(const RobotPlacement& p) const;
  // Whole-robot centre of mass location p_GC and velocity v_GC in Ground, as
  // SimbodyMatterSubsystem::calcSystemMassCenter{Location,Velocity}InGround compute them
  // (same bodies, same order) with the mass properties cached and each body's pose and
  // velocity fetched once (every Simbody accessor costs cache look-ups and dynamic_casts).
  void calcMassCenter(const SimTK::State& s, SimTK::Vec3& p_GC, SimTK::Vec3& v_GC) const;
  // Calls f(group, sphere index, contact) for every sphere overlapping a box.
  template <class F>
  void forEachBoxContact(const SimTK::State& s, F&& f) const;
  // Calls f(sphere, contact) for every ground sphere overlapping the ground half-space; the
  // forces are filled once the state is realized to Velocity.
  template <class F>
  void forEachGroundContact(const SimTK::State& s, F&& f) const;
  double calcClearance(const SimTK::State& s) const;
  const SimTK::State& state() const { return stepper ? stepper->getState() : integ->getState(); }
  double time() const { return state().getTime(); }
  // The commands live outside the Simbody state: after changing them, drop the cached forces
  // and accelerations so that the integrator's next step starts from fresh derivatives.
  void invalidateForces() {
    SimTK::State& s = stepper ? stepper->updState() : integ->updAdvancedState();
    s.invalidateAllCacheAtOrAbove(SimTK::Stage::Dynamics);
  }
  // The integrator of the settings; the semi-explicit Euler method as EulerStepper when it
  // applies to this system (euler_stepper.h), else as Simbody's integrator.
  void makeIntegrator();
  // Starts the integrator (or the stepper) from `s`.
  void initializeIntegrator(const SimTK::State& s);

  model::RobotModel model;
  SimSettings settings;
  SimModel kind = SimModel::Full;
  detail::ContactLaw law;

  SimTK::MultibodySystem system;
  SimTK::SimbodyMatterSubsystem matter;
  SimTK::GeneralForceSubsystem forces;
  // Simbody's contact subsystems, only for ellipsoid wheels (HalfSpaceEllipsoid tracker,
  // HertzElliptical generator); every sphere meets the ground in GroundElement.
  std::optional<SimTK::ContactTrackerSubsystem> tracker;
  std::optional<SimTK::CompliantContactSubsystem> contact;

  std::vector<SimTK::MobilizedBody> mobods;  // per RobotModel link (sagittal: right ones empty)
  std::vector<int> bodies;                   // the links built, parent before child
  // The base mobilizer's frames: F on Ground, M on the base (identity for the free base).
  SimTK::Transform base_X_GF, base_X_BM;
  // Per joint: its pin (sagittal: a right joint's is its left mirror joint's), the sign that
  // turns the pin's q and u into the joint's, and how many legs its drive torque acts for
  // (sagittal: 2 on the left, 0 on the right).
  std::array<SimTK::MobilizedBody, model::kNumJoints> pins;
  std::array<double, model::kNumJoints> joint_sign{};
  std::array<double, model::kNumJoints> drive_weight{};
  std::array<int, model::kNumLegs> wheel_link{};
  std::vector<detail::SphereGroup> groups;
  std::vector<detail::GroundSphere> ground_spheres;
  SimTK::UnitVec3 ground_normal{SimTK::ZAxis};  // out of the ground, in G (plane through 0)
  detail::HertzCircularLaw ground_law;
  // Per pin joint, jointIndex() order: index of its q and u in the matter subsystem.
  std::array<SimTK::QIndex, model::kNumJoints> q_index;
  std::array<SimTK::UIndex, model::kNumJoints> u_index;
  // Per link (mobods order): mass and centre of mass in the body frame.
  std::vector<double> link_mass;
  std::vector<SimTK::Vec3> link_com;

  // Classification of Simbody's contact surfaces (ellipsoid wheels), after realizeTopology().
  std::vector<detail::Part> surface_part;
  std::vector<int> surface_leg;
  std::vector<bool> surface_is_robot;

  model::JointCommands commands{};  // the commands the drives act on now
  std::array<double, model::kNumJoints> held_torque{};
  // Drive envelopes of the plant (the model's, scaled by PlantSettings).
  std::array<model::ActuatorEnvelope, model::kNumJoints> envelopes{};
  // Motor latency: commands written but not yet acting, oldest first (a ring sized at
  // construction), each with the time it starts acting.
  struct PendingCommand {
    double t_apply = 0.0;
    model::JointCommands commands{};
  };
  std::vector<PendingCommand> pending;
  std::size_t pending_head = 0, pending_count = 0;
  // Integrates to time t with the commands in force, switching to each pending command at
  // its time (a step ends there).
  void integrateTo(double t);

  SimTK::State default_state;
  std::unique_ptr<SimTK::Integrator> integ;       // null when `stepper` steps
  std::unique_ptr<detail::EulerStepper> stepper;  // null when `integ` steps
  bool euler_stepper_applies = false;             // EulerStepper::applies() to this system
  long step_count = 0;
  std::mt19937_64 rng;
  // IMU: base origin velocity at the start of the last period, or the exact acceleration
  // right after reset() when there is no last period yet.
  SimTK::Vec3 previous_v_GB{0.0};
  SimTK::Vec3 reset_a_GB{0.0};
  bool have_previous_velocity = false;
};

template <class F>
inline void SimRobot::Impl::forEachGroundContact(const SimTK::State& s, F&& f) const {
  if (!settings.terrain.has_ground) return;
  const bool with_forces = s.getSystemStage() >= SimTK::Stage::Velocity;
  const SimTK::Transform* X_GB = nullptr;  // pose of the current link (spheres sorted by link)
  int link = -1;
  for (const detail::GroundSphere& g : ground_spheres) {
    const SimTK::MobilizedBody& mb = mobods[g.link];
    if (g.link != link) {
      link = g.link;
      X_GB = &mb.getBodyTransform(s);
    }
    const SimTK::Vec3 center = *X_GB * g.center;
    const double height = SimTK::dot(ground_normal, center);
    detail::GroundContact c;
    c.depth = g.radius - height;
    if (c.depth <= 0.0) continue;
    // Halfway into the overlap (the surfaces have equal stiffness).
    c.point = center - (height + 0.5 * c.depth) * ground_normal;
    c.arm = c.point - X_GB->p();
    if (with_forces) {
      const SimTK::SpatialVec& V_GB = mb.getBodyVelocity(s);
      const SimTK::Vec3 velocity = V_GB[1] + V_GB[0] % c.arm;
      c.force = detail::calcHertzCircularForce(ground_law, g.radius, c.depth, ground_normal,
                                               velocity, c.potential_energy);
    } else {
      c.potential_energy = 0.4 * (4. / 3.) * ground_law.k * c.depth *
                           std::sqrt(g.radius * ground_law.k * c.depth) * c.depth;
    }
    f(g, c);
  }
}

template <class F>
inline void SimRobot::Impl::forEachBoxContact(const SimTK::State& s, F&& f) const {
  for (const Box& box : settings.terrain.boxes) {
    for (const detail::SphereGroup& g : groups) {
      const SimTK::MobilizedBody& mb = mobods[g.link];
      const SimTK::Transform& X_GB = mb.getBodyTransform(s);
      const Eigen::Vector3d bound = detail::toEigen(X_GB * detail::toVec3(g.bound_center));
      if (detail::signedDistance(box, bound).distance >= g.bound_radius) continue;
      for (const Eigen::Vector3d& center : g.centers) {
        const Eigen::Vector3d p = detail::toEigen(X_GB * detail::toVec3(center));
        const detail::BoxDistance d = detail::signedDistance(box, p);
        const double depth = g.radius - d.distance;
        if (depth <= 0.0) continue;
        detail::SphereContact c;
        c.touching = true;
        c.depth = depth;
        // Halfway into the overlap, as Simbody does for two surfaces of equal stiffness.
        c.point = p - d.normal * (g.radius - 0.5 * depth);
        if (s.getSystemStage() >= SimTK::Stage::Velocity) {
          const Eigen::Vector3d v =
              detail::toEigen(mb.findStationVelocityInGround(s, ~X_GB * detail::toVec3(c.point)));
          const double rate = -v.dot(d.normal);  // > 0 while the overlap grows
          const Eigen::Vector3d slip = v + rate * d.normal;
          c.force = detail::calcContactForce(law, g.radius, depth, rate, d.normal, slip,
                                             &c.potential_energy);
        } else {
          detail::calcContactForce(law, g.radius, depth, 0.0, d.normal, Eigen::Vector3d::Zero(),
                                   &c.potential_energy);
        }
        f(g, c);
      }
    }
  }
}

}  // namespace wj::sim
