// The robot in Simbody. This translation unit is compiled as C++17 (Simbody 3.7's headers do
// not compile as C++20 with GCC 12) and is the only place of the sim library that sees Simbody.
#include "sim/sim_robot.h"

#include <Simbody.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "../contact_law.h"
#include "sim/plant.h"

namespace wj::sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

SimTK::Vec3 toVec3(const Eigen::Vector3d& v) {
  return {v.x(), v.y(), v.z()};
}
Eigen::Vector3d toEigen(const SimTK::Vec3& v) {
  return {v[0], v[1], v[2]};
}
SimTK::Rotation toRotation(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return SimTK::Rotation(SimTK::Quaternion(q.w(), q.x(), q.y(), q.z()));
}
Eigen::Matrix3d toEigen(const SimTK::Rotation& R) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = R[r][c];
  return out;
}
SimTK::Transform toTransform(const Eigen::Isometry3d& X) {
  return SimTK::Transform(toRotation(X.linear()), toVec3(X.translation()));
}
Eigen::Isometry3d toEigen(const SimTK::Transform& X) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = toEigen(X.R());
  out.translation() = toEigen(X.p());
  return out;
}

// Simbody wants the rotational inertia about the body origin; the model gives it about the CoM.
SimTK::Body::Rigid makeBody(const model::Inertia& in) {
  if (!(in.mass > 0.0)) throw std::invalid_argument("SimRobot: every link needs a positive mass");
  SimTK::Mat33 I_c;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) I_c[r][c] = in.inertia_com(r, c);
  const SimTK::Vec3 com = toVec3(in.com);
  const SimTK::Inertia I_o = SimTK::Inertia(I_c).shiftFromMassCenter(com, in.mass);
  return SimTK::Body::Rigid(SimTK::MassProperties(in.mass, com, I_o));
}

// Which part of the robot a collision sphere belongs to.
enum class Part : std::uint8_t { Wheel, Base, Leg };

// Spheres fixed to one link, for contact with boxes and for the clearance metric.
struct SphereGroup {
  int link = 0;  // index into RobotModel::links()
  Part part = Part::Base;
  int leg = -1;                                            // 0..3 for wheels and legs
  std::vector<Eigen::Vector3d> centers;                    // in the link frame
  double radius = 0.0;                                     // of each sphere
  Eigen::Vector3d bound_center = Eigen::Vector3d::Zero();  // bounding sphere, link frame
  double bound_radius = 0.0;
};

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
HertzCircularLaw makeHertzCircularLaw(const SimTK::ContactMaterial& m1,
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
double step5(double x) {
  const double x3 = x * x * x;
  return x3 * (10 + x * (6 * x - 15));
}

// Simbody's friction coefficient at slip speed v (in multiples of the transition velocity):
// quintic rise from 0 to us at v = 1, quintic fall to ud at v = 3, plus viscous uv v.
double stribeck(double us, double ud, double uv, double v) {
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
SimTK::Vec3 calcHertzCircularForce(const HertzCircularLaw& law, double R, double x,
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

// A sphere fixed to a link, against the ground half-space.
struct GroundSphere {
  int link = 0;  // index into RobotModel::links()
  Part part = Part::Base;
  int leg = -1;             // 0..3 for wheels and knees
  SimTK::Vec3 center{0.0};  // in the link frame
  double radius = 0.0;
};

// One sphere overlapping the ground.
struct GroundContact {
  double depth = 0.0;      // overlap [m]
  SimTK::Vec3 point{0.0};  // contact point, in G [m]
  SimTK::Vec3 arm{0.0};    // from the link origin to the contact point, in G [m]
  SimTK::Vec3 force{0.0};  // force of the ground on the sphere, in G [N]
  double potential_energy = 0.0;
};

}  // namespace

//==============================================================================================
struct SimRobot::Impl {
  class GravityElement;
  class DriveElement;
  class BoxElement;
  class GroundElement;

  Impl(const model::RobotModel& m, const SimSettings& s);

  // Drive torque of joint i (PD law on the current command, clipped by the envelope) at
  // joint position q and speed qd; `demand` receives the unclipped value.
  double driveTorque(int i, double q, double qd, double* demand) const;
  // Position and speed of joint i at state s, read from the matter subsystem's q and u by the
  // indices cached after realizeModel (MobilizedBody::getOneQ() looks them up per call).
  double jointQ(const SimTK::Vector& q, int i) const { return q[q_index[i]]; }
  double jointU(const SimTK::Vector& u, int i) const { return u[u_index[i]]; }
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
  const SimTK::State& state() const { return integ->getState(); }
  // The commands live outside the Simbody state: after changing them, drop the cached forces
  // and accelerations so that the integrator's next step starts from fresh derivatives.
  void invalidateForces() {
    integ->updAdvancedState().invalidateAllCacheAtOrAbove(SimTK::Stage::Dynamics);
  }
  void makeIntegrator();

  model::RobotModel model;
  SimSettings settings;
  detail::ContactLaw law;

  SimTK::MultibodySystem system;
  SimTK::SimbodyMatterSubsystem matter;
  SimTK::GeneralForceSubsystem forces;
  // Simbody's contact subsystems, only for ellipsoid wheels (HalfSpaceEllipsoid tracker,
  // HertzElliptical generator); every sphere meets the ground in GroundElement.
  std::optional<SimTK::ContactTrackerSubsystem> tracker;
  std::optional<SimTK::CompliantContactSubsystem> contact;

  std::vector<SimTK::MobilizedBody> mobods;  // per RobotModel link
  std::array<SimTK::MobilizedBody, model::kNumJoints> pins;
  std::array<int, model::kNumLegs> wheel_link{};
  std::vector<SphereGroup> groups;
  std::vector<GroundSphere> ground_spheres;
  SimTK::UnitVec3 ground_normal{SimTK::ZAxis};  // out of the ground, in G (plane through 0)
  HertzCircularLaw ground_law;
  // Per pin joint, jointIndex() order: index of its q and u in the matter subsystem.
  std::array<SimTK::QIndex, model::kNumJoints> q_index;
  std::array<SimTK::UIndex, model::kNumJoints> u_index;
  // Per link (mobods order): mass and centre of mass in the body frame.
  std::vector<double> link_mass;
  std::vector<SimTK::Vec3> link_com;

  // Classification of Simbody's contact surfaces (ellipsoid wheels), after realizeTopology().
  std::vector<Part> surface_part;
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
  std::unique_ptr<SimTK::Integrator> integ;
  long step_count = 0;
  std::mt19937_64 rng;
  // IMU: base origin velocity at the start of the last period, or the exact acceleration
  // right after reset() when there is no last period yet.
  SimTK::Vec3 previous_v_GB{0.0};
  SimTK::Vec3 reset_a_GB{0.0};
  bool have_previous_velocity = false;
};

//==============================================================================================
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
    for (std::size_t b = 0; b < impl_.mobods.size(); ++b) {
      const SimTK::Vec3 p_CB_G = impl_.mobods[b].getBodyTransform(s).R() * impl_.link_com[b];
      const SimTK::Vec3 F_CB_G = impl_.link_mass[b] * gravity_;
      body_forces[impl_.mobods[b].getMobilizedBodyIndex()] +=
          SimTK::SpatialVec(p_CB_G % F_CB_G, F_CB_G);
    }
  }
  SimTK::Real calcPotentialEnergy(const SimTK::State& s) const override {
    double pe = 0.0;
    for (std::size_t b = 0; b < impl_.mobods.size(); ++b) {
      const SimTK::Vec3 p_G_CB = impl_.mobods[b].getBodyTransform(s) * impl_.link_com[b];
      pe -= impl_.link_mass[b] * (~gravity_ * p_G_CB);
    }
    return pe;
  }

 private:
  const Impl& impl_;
  SimTK::Vec3 gravity_;  // in G [m/s^2]
};

// The drives: one Force::Custom applying tau_i to the mobility of each pin joint.
class SimRobot::Impl::DriveElement : public SimTK::Force::Custom::Implementation {
 public:
  explicit DriveElement(const Impl& impl) : impl_(impl) {}
  void calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>&,
                 SimTK::Vector_<SimTK::Vec3>&, SimTK::Vector& mobility_forces) const override {
    const bool hold = impl_.settings.actuator_update == ActuatorUpdate::ZeroOrderHold;
    const SimTK::Vector& q = impl_.matter.getQ(s);
    const SimTK::Vector& u = impl_.matter.getU(s);
    for (int i = 0; i < model::kNumJoints; ++i) {
      const double tau =
          hold ? impl_.held_torque[i]
               : impl_.driveTorque(i, impl_.jointQ(q, i), impl_.jointU(u, i), nullptr);
      mobility_forces[impl_.u_index[i]] += tau;  // = pins[i].applyOneMobilityForce()
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
      mb.applyForceToBodyPoint(s, station, toVec3(c.force), body_forces);
    });
  }
  SimTK::Real calcPotentialEnergy(const SimTK::State& s) const override {
    double pe = 0.0;
    impl_.forEachBoxContact(
        s, [&](const SphereGroup&, const detail::SphereContact& c) { pe += c.potential_energy; });
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
      body_forces[impl_.mobods[g.link].getMobilizedBodyIndex()] +=
          SimTK::SpatialVec(c.arm % c.force, c.force);
    });
  }
  SimTK::Real calcPotentialEnergy(const SimTK::State& s) const override {
    double pe = 0.0;
    impl_.forEachGroundContact(
        s, [&](const GroundSphere&, const GroundContact& c) { pe += c.potential_energy; });
    return pe;
  }

 private:
  const Impl& impl_;
};

//==============================================================================================
SimRobot::Impl::Impl(const model::RobotModel& m, const SimSettings& s)
    : model(m),
      settings(s),
      law(detail::makeContactLaw(s.contact)),
      matter(system),
      forces(system),
      rng(s.noise.seed) {
  settings.validate();
  const ContactSettings& cs = settings.contact;
  const SimTK::ContactMaterial material(cs.stiffness_pa, cs.dissipation_s_m, cs.static_friction,
                                        cs.dynamic_friction, cs.viscous_friction_s_m);
  SimTK::Force::Custom(forces, new GravityElement(*this));
  const bool ellipsoid_wheels = cs.wheel_shape == WheelShape::Ellipsoid;
  if (ellipsoid_wheels) {
    tracker.emplace(system);
    contact.emplace(system, *tracker);
    contact->setTransitionVelocity(cs.transition_velocity_m_s);
  }
  ground_law = makeHertzCircularLaw(material, material, cs.transition_velocity_m_s);

  // Ground: a half-space occupies x > 0 of its frame; turn that x to point into the ground.
  const Terrain& terrain = settings.terrain;
  if (terrain.has_ground) {
    const SimTK::Rotation R_GH(SimTK::Pi / 2 - terrain.slope_rad, SimTK::YAxis);
    ground_normal = SimTK::UnitVec3(-R_GH.x());
    if (ellipsoid_wheels)
      matter.updGround().updBody().addContactSurface(
          SimTK::Transform(R_GH),
          SimTK::ContactSurface(SimTK::ContactGeometry::HalfSpace(), material));
  }

  // Multibody tree: free base, then per leg HAA -> HFE -> KFE -> WHEEL pins. A pin turns
  // about z of its frames, so both frames are turned to put z on the URDF axis.
  const auto& links = model.links();
  mobods.resize(links.size());
  // The plant's masses (PlantSettings): every link scaled, the payload on the base.
  const PlantSettings& plant = settings.plant;
  mobods[0] = SimTK::MobilizedBody::Free(
      matter.updGround(), SimTK::Transform(),
      makeBody(addPointMass(scaleInertia(links[0].inertia, plant.link_mass_scale), plant.payload)),
      SimTK::Transform());
  // Links were appended parent-before-child by the loader.
  for (std::size_t li = 1; li < links.size(); ++li) {
    const model::JointSpec& j = model.joints()[links[li].parent_joint];
    const SimTK::Rotation R_JA(SimTK::UnitVec3(toVec3(j.axis)), SimTK::ZAxis);
    const SimTK::Transform X_PF = toTransform(j.X_PJ) * SimTK::Transform(R_JA);
    const SimTK::Transform X_BM(R_JA);
    const SimTK::MobilizedBody::Pin pin(
        mobods[j.parent_link], X_PF,
        makeBody(scaleInertia(links[li].inertia, plant.link_mass_scale)), X_BM);
    mobods[li] = pin;
    pins[model::jointIndex(j.leg, j.kind)] = pin;
  }

  // Surfaces against the ground: wheel, knee, base corners. Spheres go to GroundElement;
  // ellipsoid wheels to Simbody's tracker, in one clique so that they never collide with
  // each other.
  const SimTK::ContactCliqueId clique = SimTK::ContactSurface::createNewContactClique();
  const double r = model.wheelRadius();
  const double base_r = cs.base_sphere_radius_m;
  const double body_r = cs.body_sphere_radius_m;
  for (const model::Leg leg : model::kLegs) {
    const int l = static_cast<int>(leg);
    const model::JointSpec& wheel = model.joint(leg, model::JointKind::Wheel);
    const model::JointSpec& knee = model.joint(leg, model::JointKind::KFE);
    wheel_link[l] = wheel.child_link;
    // The loader guarantees the wheel axis is y of the wheel link.
    if (ellipsoid_wheels)
      mobods[wheel.child_link].updBody().addContactSurface(
          SimTK::Transform(), SimTK::ContactSurface(SimTK::ContactGeometry::Ellipsoid(SimTK::Vec3(
                                                        r, 0.5 * model.wheelWidth(), r)),
                                                    material)
                                  .joinClique(clique));
    else
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

  // Sphere groups against the terrain boxes: wheels, base surface, thighs and shanks.
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

  SimTK::Force::Custom(forces, new DriveElement(*this));
  if (terrain.has_ground) SimTK::Force::Custom(forces, new GroundElement(*this));
  if (!terrain.boxes.empty()) SimTK::Force::Custom(forces, new BoxElement(*this));

  for (int i = 0; i < model::kNumJoints; ++i) {
    envelopes[i] =
        scaleEnvelope(model.joints()[i].actuator, plant.torque_scale, plant.corner_speed_scale);
    if (envelopes[i].corner_speed_rad_s >= envelopes[i].no_load_speed_rad_s)
      throw std::invalid_argument("plant settings: corner_speed_scale puts the corner speed of " +
                                  model.joints()[i].name + " beyond its no-load speed");
  }
  pending.resize(
      static_cast<std::size_t>(std::ceil(plant.motor_latency_s / settings.control_period_s)) + 2);

  default_state = system.realizeTopology();
  system.realizeModel(default_state);
  for (int i = 0; i < model::kNumJoints; ++i) {
    q_index[i] = pins[i].getFirstQIndex(default_state);
    u_index[i] = pins[i].getFirstUIndex(default_state);
  }
  for (const SimTK::MobilizedBody& mb : mobods) {
    const SimTK::MassProperties& mp = mb.getBodyMassProperties(default_state);
    link_mass.push_back(mp.getMass());
    link_com.push_back(mp.getMassCenter());
  }

  // Classify Simbody's contact surfaces by the body that carries them.
  const int num_surfaces = tracker ? tracker->getNumSurfaces() : 0;
  surface_part.resize(num_surfaces, Part::Base);
  surface_leg.resize(num_surfaces, -1);
  surface_is_robot.resize(num_surfaces, false);
  for (int i = 0; i < num_surfaces; ++i) {
    const SimTK::MobilizedBodyIndex mbx =
        tracker->getMobilizedBody(SimTK::ContactSurfaceIndex(i)).getMobilizedBodyIndex();
    if (mbx == SimTK::GroundIndex) continue;
    surface_is_robot[i] = true;
    for (int l = 0; l < model::kNumLegs; ++l) {
      if (mobods[wheel_link[l]].getMobilizedBodyIndex() == mbx) {
        surface_part[i] = Part::Wheel;
        surface_leg[i] = l;
      }
      const model::JointSpec& knee = model.joint(model::kLegs[l], model::JointKind::KFE);
      if (mobods[knee.parent_link].getMobilizedBodyIndex() == mbx) {
        surface_part[i] = Part::Leg;
        surface_leg[i] = l;
      }
    }
  }
  makeIntegrator();
  integ->initialize(default_state);
}

//==============================================================================================
void SimRobot::Impl::makeIntegrator() {
  const IntegratorSettings& is = settings.integrator;
  switch (is.kind) {
    case IntegratorKind::SemiExplicitEuler:
      integ = std::make_unique<SimTK::SemiExplicitEulerIntegrator>(system, is.max_step_s);
      break;
    case IntegratorKind::SemiExplicitEuler2:
      integ = std::make_unique<SimTK::SemiExplicitEuler2Integrator>(system);
      break;
    case IntegratorKind::RungeKutta3:
      integ = std::make_unique<SimTK::RungeKutta3Integrator>(system);
      break;
    case IntegratorKind::RungeKuttaMerson:
      integ = std::make_unique<SimTK::RungeKuttaMersonIntegrator>(system);
      break;
  }
  if (is.kind != IntegratorKind::SemiExplicitEuler) {
    integ->setAccuracy(is.accuracy);
    integ->setMaximumStepSize(is.max_step_s);
  }
  // Every control instant must be a step boundary: the commands change there.
  integ->setAllowInterpolation(false);
}

double SimRobot::Impl::driveTorque(int i, double q, double qd, double* demand) const {
  const model::JointCommand& c = commands[i];
  const double tau = c.kp * (c.q_des - q) + c.kd * (c.qd_des - qd) + c.tau_ff;
  if (demand) *demand = tau;
  return envelopes[i].saturate(tau, qd);
}

void SimRobot::Impl::calcMassCenter(const SimTK::State& s, SimTK::Vec3& p_GC,
                                    SimTK::Vec3& v_GC) const {
  double mass = 0.0;
  SimTK::Vec3 com(0), com_v(0);
  for (std::size_t b = 0; b < mobods.size(); ++b) {
    const SimTK::Transform& X_GB = mobods[b].getBodyTransform(s);
    const SimTK::SpatialVec& V_GB = mobods[b].getBodyVelocity(s);
    const SimTK::Vec3 r_G = X_GB.R() * link_com[b];  // body origin to body CoM, in G
    mass += link_mass[b];
    com += link_mass[b] * (X_GB.p() + r_G);
    com_v += link_mass[b] * (V_GB[1] + V_GB[0] % r_G);
  }
  p_GC = com / mass;
  v_GC = com_v / mass;
}

template <class F>
void SimRobot::Impl::forEachGroundContact(const SimTK::State& s, F&& f) const {
  if (!settings.terrain.has_ground) return;
  const bool with_forces = s.getSystemStage() >= SimTK::Stage::Velocity;
  const SimTK::Transform* X_GB = nullptr;  // pose of the current link (spheres sorted by link)
  int link = -1;
  for (const GroundSphere& g : ground_spheres) {
    const SimTK::MobilizedBody& mb = mobods[g.link];
    if (g.link != link) {
      link = g.link;
      X_GB = &mb.getBodyTransform(s);
    }
    const SimTK::Vec3 center = *X_GB * g.center;
    const double height = SimTK::dot(ground_normal, center);
    GroundContact c;
    c.depth = g.radius - height;
    if (c.depth <= 0.0) continue;
    // Halfway into the overlap (the surfaces have equal stiffness).
    c.point = center - (height + 0.5 * c.depth) * ground_normal;
    c.arm = c.point - X_GB->p();
    if (with_forces) {
      const SimTK::SpatialVec& V_GB = mb.getBodyVelocity(s);
      const SimTK::Vec3 velocity = V_GB[1] + V_GB[0] % c.arm;
      c.force = calcHertzCircularForce(ground_law, g.radius, c.depth, ground_normal, velocity,
                                       c.potential_energy);
    } else {
      c.potential_energy = 0.4 * (4. / 3.) * ground_law.k * c.depth *
                           std::sqrt(g.radius * ground_law.k * c.depth) * c.depth;
    }
    f(g, c);
  }
}

template <class F>
void SimRobot::Impl::forEachBoxContact(const SimTK::State& s, F&& f) const {
  for (const Box& box : settings.terrain.boxes) {
    for (const SphereGroup& g : groups) {
      const SimTK::MobilizedBody& mb = mobods[g.link];
      const SimTK::Transform& X_GB = mb.getBodyTransform(s);
      const Eigen::Vector3d bound = toEigen(X_GB * toVec3(g.bound_center));
      if (detail::signedDistance(box, bound).distance >= g.bound_radius) continue;
      for (const Eigen::Vector3d& center : g.centers) {
        const Eigen::Vector3d p = toEigen(X_GB * toVec3(center));
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
              toEigen(mb.findStationVelocityInGround(s, ~X_GB * toVec3(c.point)));
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

double SimRobot::Impl::calcClearance(const SimTK::State& s) const {
  double best = kInf;
  for (const Box& box : settings.terrain.boxes) {
    if (!box.obstacle) continue;
    for (const SphereGroup& g : groups) {
      const SimTK::Transform& X_GB = mobods[g.link].getBodyTransform(s);
      const Eigen::Vector3d bound = toEigen(X_GB * toVec3(g.bound_center));
      if (detail::signedDistance(box, bound).distance - g.bound_radius >= best) continue;
      for (const Eigen::Vector3d& center : g.centers) {
        const Eigen::Vector3d p = toEigen(X_GB * toVec3(center));
        best = std::min(best, detail::signedDistance(box, p).distance - g.radius);
      }
    }
  }
  return best;
}

//==============================================================================================
SimRobot::SimRobot(const model::RobotModel& model, const SimSettings& settings)
    : impl_(std::make_unique<Impl>(model, settings)) {}
SimRobot::~SimRobot() = default;
SimRobot::SimRobot(SimRobot&&) noexcept = default;
SimRobot& SimRobot::operator=(SimRobot&&) noexcept = default;

double SimRobot::controlPeriod() const {
  return impl_->settings.control_period_s;
}

void SimRobot::read(model::SensorData& out) {
  Impl& m = *impl_;
  const SimTK::State& s = m.state();
  m.system.realize(s, SimTK::Stage::Velocity);
  out.t = s.getTime();
  const SimTK::Vector& all_q = m.matter.getQ(s);
  const SimTK::Vector& all_u = m.matter.getU(s);
  for (int i = 0; i < model::kNumJoints; ++i) {
    model::JointMeasurement& j = out.joints[i];
    j.q = m.jointQ(all_q, i);
    j.qd = m.jointU(all_u, i);
    j.tau = m.settings.actuator_update == ActuatorUpdate::ZeroOrderHold
                ? m.held_torque[i]
                : m.driveTorque(i, j.q, j.qd, nullptr);
  }
  const SimTK::MobilizedBody& base = m.mobods[0];
  const SimTK::Rotation& R_GB = base.getBodyRotation(s);
  const SimTK::Quaternion q = R_GB.convertRotationToQuaternion();
  out.imu.q_WB = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
  out.imu.omega_B = toEigen(~R_GB * base.getBodyAngularVelocity(s));
  // The mean specific force over the last control period, as an accelerometer sampled at the
  // control rate behind its anti-aliasing filter reports it (and no extra dynamics solve).
  const SimTK::Vec3 gravity(0, 0, -m.settings.gravity_m_s2);
  const SimTK::Vec3 a_GB =
      m.have_previous_velocity
          ? (base.getBodyOriginVelocity(s) - m.previous_v_GB) / m.settings.control_period_s
          : m.reset_a_GB;
  out.imu.accel_B = toEigen(~R_GB * (a_GB - gravity));
  // The plant's IMU biases (constant, also without noise).
  out.imu.omega_B += m.settings.plant.imu_gyro_bias_rad_s;
  out.imu.accel_B += m.settings.plant.imu_accel_bias_m_s2;

  const NoiseSettings& n = m.settings.noise;
  if (!n.enabled) return;
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto noise = [&](double sigma) { return sigma * normal(m.rng); };
  for (auto& j : out.joints) {
    j.q += noise(n.joint_position_rad);
    j.qd += noise(n.joint_velocity_rad_s);
    j.tau += noise(n.joint_torque_nm);
  }
  for (int a = 0; a < 3; ++a) {
    out.imu.omega_B[a] += noise(n.gyro_rad_s);
    out.imu.accel_B[a] += noise(n.accel_m_s2);
  }
  const Eigen::Vector3d tilt(noise(n.orientation_rad), noise(n.orientation_rad),
                             noise(n.orientation_rad));
  if (tilt.norm() > 0.0)
    out.imu.q_WB =
        (out.imu.q_WB * Eigen::Quaterniond(Eigen::AngleAxisd(tilt.norm(), tilt.normalized())))
            .normalized();
}

void SimRobot::write(const model::JointCommands& commands) {
  Impl& m = *impl_;
  const double latency = m.settings.plant.motor_latency_s;
  if (latency > 0.0) {
    // Acts `latency` from now; a full ring (commands written faster than the periods pass)
    // drops the oldest.
    if (m.pending_count == m.pending.size()) {
      m.pending_head = (m.pending_head + 1) % m.pending.size();
      --m.pending_count;
    }
    Impl::PendingCommand& p = m.pending[(m.pending_head + m.pending_count) % m.pending.size()];
    p.t_apply = m.state().getTime() + latency;
    p.commands = commands;
    ++m.pending_count;
    return;
  }
  m.commands = commands;
  if (m.settings.actuator_update == ActuatorUpdate::Continuous) m.invalidateForces();
}

void SimRobot::Impl::integrateTo(double t) {
  const auto stepTo = [&](double t_end) {
    // stepTo() may return before t_end: right after initialize() it returns at once with
    // StartOfSimulation, without advancing (the first period after reset() used to be lost and
    // the next one integrated twice). Step until the interval is really covered.
    for (int attempt = 0; integ->getTime() < t_end - 1e-12; ++attempt) {
      if (attempt == 100)
        throw std::runtime_error("the integrator did not reach the end of the period");
      integ->stepTo(t_end);
    }
  };
  const auto hold = [&] {
    if (settings.actuator_update != ActuatorUpdate::ZeroOrderHold) return;
    const SimTK::State& s = state();
    const SimTK::Vector& q = matter.getQ(s);
    const SimTK::Vector& u = matter.getU(s);
    for (int i = 0; i < model::kNumJoints; ++i)
      held_torque[i] = driveTorque(i, jointQ(q, i), jointU(u, i), nullptr);
  };
  for (;;) {
    // Commands whose time has come act from now on.
    bool changed = false;
    while (pending_count > 0 && pending[pending_head].t_apply <= integ->getTime() + 1e-9) {
      commands = pending[pending_head].commands;
      pending_head = (pending_head + 1) % pending.size();
      --pending_count;
      changed = true;
    }
    if (changed) {
      hold();
      invalidateForces();
    }
    if (pending_count > 0 && pending[pending_head].t_apply < t - 1e-9) {
      stepTo(pending[pending_head].t_apply);
    } else {
      stepTo(t);
      return;
    }
  }
}

void SimRobot::advance() {
  Impl& m = *impl_;
  if (m.settings.actuator_update == ActuatorUpdate::ZeroOrderHold) {
    const SimTK::State& s = m.state();
    const SimTK::Vector& q = m.matter.getQ(s);
    const SimTK::Vector& u = m.matter.getU(s);
    for (int i = 0; i < model::kNumJoints; ++i)
      m.held_torque[i] = m.driveTorque(i, m.jointQ(q, i), m.jointU(u, i), nullptr);
    m.invalidateForces();
  }
  m.system.realize(m.state(), SimTK::Stage::Velocity);
  m.previous_v_GB = m.mobods[0].getBodyOriginVelocity(m.state());
  m.have_previous_velocity = true;
  ++m.step_count;
  const double t_next = static_cast<double>(m.step_count) * m.settings.control_period_s;
  try {
    m.integrateTo(t_next);
  } catch (const std::exception& e) {
    throw std::runtime_error("SimRobot: integration failed at t = " +
                             std::to_string(m.state().getTime()) + " s: " + e.what());
  }
}

void SimRobot::reset(const RobotPlacement& placement) {
  Impl& m = *impl_;
  SimTK::State s = m.default_state;
  s.setTime(0.0);
  m.mobods[0].setQToFitTransform(s, toTransform(placement.X_WB));
  m.mobods[0].setUToFitVelocity(s,
                                SimTK::SpatialVec(toVec3(placement.w_WB), toVec3(placement.v_WB)));
  for (int i = 0; i < model::kNumJoints; ++i) {
    m.pins[i].setOneQ(s, 0, placement.q[i]);
    m.pins[i].setOneU(s, 0, placement.qd[i]);
  }
  m.commands = {};
  m.held_torque = {};
  m.pending_head = 0;
  m.pending_count = 0;
  m.step_count = 0;
  m.rng.seed(m.settings.noise.seed);
  m.makeIntegrator();
  m.integ->initialize(s);
  m.system.realize(m.state(), SimTK::Stage::Acceleration);
  m.reset_a_GB = m.mobods[0].getBodyOriginAcceleration(m.state());
  m.have_previous_velocity = false;
}

double SimRobot::time() const {
  return impl_->state().getTime();
}

void SimRobot::calcGroundTruth(GroundTruth& out, bool with_forces) const {
  const Impl& m = *impl_;
  const SimTK::State& s = m.state();
  // Only Simbody's compliant contact subsystem (ellipsoid wheels) needs the Dynamics stage.
  m.system.realize(s, with_forces && m.contact ? SimTK::Stage::Dynamics : SimTK::Stage::Velocity);
  const SimTK::MobilizedBody& base = m.mobods[0];
  out.t = s.getTime();
  out.X_WB = toEigen(base.getBodyTransform(s));
  out.v_WB = toEigen(base.getBodyOriginVelocity(s));
  out.w_WB = toEigen(base.getBodyAngularVelocity(s));
  SimTK::Vec3 p_GC, v_GC;
  m.calcMassCenter(s, p_GC, v_GC);
  out.p_WC = toEigen(p_GC);
  out.v_WC = toEigen(v_GC);
  const SimTK::Vector& q = m.matter.getQ(s);
  const SimTK::Vector& u = m.matter.getU(s);
  for (int i = 0; i < model::kNumJoints; ++i) {
    out.q[i] = m.jointQ(q, i);
    out.qd[i] = m.jointU(u, i);
    double demand = 0.0;
    const double tau = m.driveTorque(i, out.q[i], out.qd[i], &demand);
    out.tau[i] =
        m.settings.actuator_update == ActuatorUpdate::ZeroOrderHold ? m.held_torque[i] : tau;
    out.tau_demand[i] = demand;
  }

  out.wheels = {};
  out.base_in_contact = false;
  out.legs_in_contact = false;
  const auto record = [&](Part part, int leg, const Eigen::Vector3d& force, double depth) {
    if (part == Part::Wheel) {
      WheelContact& w = out.wheels[leg];
      w.in_contact = true;
      w.force_W += force;
      w.penetration_m = std::max(w.penetration_m, depth);
    } else if (part == Part::Base) {
      out.base_in_contact = true;
    } else {
      out.legs_in_contact = true;
    }
  };
  // Ground contacts of the spheres (their forces need only the Velocity stage).
  m.forEachGroundContact(s, [&](const GroundSphere& g, const GroundContact& c) {
    record(g.part, g.leg, toEigen(c.force), c.depth);
  });
  // Ellipsoid wheels through Simbody's contact tracker (overlap) and compliant contact
  // subsystem (forces, Dynamics stage).
  if (m.tracker) {
    const SimTK::ContactSnapshot& active = m.tracker->getActiveContacts(s);
    const auto depthOf = [](const SimTK::Contact& c) {
      if (SimTK::CircularPointContact::isInstance(c))
        return SimTK::CircularPointContact::getAs(c).getDepth();
      if (SimTK::EllipticalPointContact::isInstance(c))
        return SimTK::EllipticalPointContact::getAs(c).getDepth();
      return 0.0;
    };
    const auto recordContact = [&](const SimTK::Contact& c, const SimTK::Vec3& force_on_2) {
      const int s2 = c.getSurface2();
      const bool robot_is_2 = m.surface_is_robot[s2];
      const int rs = robot_is_2 ? s2 : static_cast<int>(c.getSurface1());
      record(m.surface_part[rs], m.surface_leg[rs], toEigen(force_on_2) * (robot_is_2 ? 1.0 : -1.0),
             depthOf(c));
    };
    if (with_forces) {
      for (int k = 0; k < m.contact->getNumContactForces(s); ++k) {
        const SimTK::ContactForce& f = m.contact->getContactForce(s, k);
        const SimTK::Contact& c = active.getContactById(f.getContactId());
        if (!c.isEmpty()) recordContact(c, f.getForceOnSurface2()[1]);
      }
    } else {
      for (int k = 0; k < active.getNumContacts(); ++k)
        if (depthOf(active.getContact(k)) > 0.0)
          recordContact(active.getContact(k), SimTK::Vec3(0));
    }
  }
  // Box contacts through the custom force element.
  m.forEachBoxContact(s, [&](const SphereGroup& g, const detail::SphereContact& c) {
    record(g.part, g.leg, c.force, c.depth);
  });
  out.obstacle_clearance_m = m.calcClearance(s);
}

model::Inertia SimRobot::calcCompositeInertia() const {
  const Impl& m = *impl_;
  const SimTK::State& s = m.state();
  m.system.realize(s, SimTK::Stage::Position);
  const Eigen::Isometry3d X_WB = toEigen(m.mobods[0].getBodyTransform(s));
  model::Inertia out;
  out.mass = m.matter.calcSystemMass(s);
  out.com = X_WB.inverse() * toEigen(m.matter.calcSystemMassCenterLocationInGround(s));
  const SimTK::Mat33 I_G = m.matter.calcSystemCentralInertiaInGround(s).toMat33();
  Eigen::Matrix3d I;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) I(r, c) = I_G[r][c];
  out.inertia_com = X_WB.linear().transpose() * I * X_WB.linear();
  return out;
}

double SimRobot::calcMechanicalEnergy() const {
  const Impl& m = *impl_;
  const SimTK::State& s = m.state();
  m.system.realize(s, SimTK::Stage::Dynamics);
  return m.system.calcKineticEnergy(s) + m.system.calcPotentialEnergy(s);
}

IntegratorStats SimRobot::integratorStats() const {
  return {impl_->integ->getNumStepsTaken(), impl_->integ->getNumStepsAttempted(),
          impl_->integ->getNumRealizations()};
}

const SimSettings& SimRobot::settings() const {
  return impl_->settings;
}

const model::RobotModel& SimRobot::model() const {
  return impl_->model;
}

}  // namespace wj::sim
