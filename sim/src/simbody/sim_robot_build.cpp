// SimRobot's construction: the Simbody system built from the RobotModel (see sim_robot_impl.h).
#include <cmath>
#include <stdexcept>
#include <string>

#include "sim/plant.h"
#include "sim/symmetry.h"
#include "sim_robot_impl.h"

namespace wj::sim {

using detail::Part;
using detail::toTransform;
using detail::toVec3;

namespace {

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

}  // namespace

//==============================================================================================
SimRobot::Impl::Impl(const model::RobotModel& m, const SimSettings& s, SimModel k)
    : model(m),
      settings(s),
      kind(k),
      law(detail::makeContactLaw(s.contact)),
      matter(system),
      forces(system),
      rng(s.noise.seed) {
  settings.validate();
  if (kind == SimModel::Sagittal) {
    std::string why = findAsymmetry(model);
    if (why.empty()) why = findAsymmetry(settings);
    if (!why.empty())
      throw std::invalid_argument(
          "SimRobot: the sagittal model needs a mirror-symmetric robot "
          "and simulation, but " +
          why);
  }
  const ContactSettings& cs = settings.contact;
  const SimTK::ContactMaterial material(cs.stiffness_pa, cs.dissipation_s_m, cs.static_friction,
                                        cs.dynamic_friction, cs.viscous_friction_s_m);
  addGravityElement();
  const bool ellipsoid_wheels = cs.wheel_shape == WheelShape::Ellipsoid;
  if (ellipsoid_wheels) {
    tracker.emplace(system);
    contact.emplace(system, *tracker);
    contact->setTransitionVelocity(cs.transition_velocity_m_s);
  }
  ground_law = detail::makeHertzCircularLaw(material, material, cs.transition_velocity_m_s);
  addGround(material, ellipsoid_wheels);
  buildTree();
  mapJoints();
  addContactGeometry(material, ellipsoid_wheels);
  addDriveAndContactElements();
  makeDrives();
  realizeAndCache();
  classifySurfaces();
  euler_stepper_applies = detail::EulerStepper::applies(system, default_state);
  makeIntegrator();
  initializeIntegrator(default_state);
}

void SimRobot::Impl::addGround(const SimTK::ContactMaterial& material, bool ellipsoid_wheels) {
  // A half-space occupies x > 0 of its frame; turn that x to point into the ground.
  const Terrain& terrain = settings.terrain;
  if (terrain.has_ground) {
    const SimTK::Rotation R_GH(SimTK::Pi / 2 - terrain.slope_rad, SimTK::YAxis);
    ground_normal = SimTK::UnitVec3(-R_GH.x());
    if (ellipsoid_wheels)
      matter.updGround().updBody().addContactSurface(
          SimTK::Transform(R_GH),
          SimTK::ContactSurface(SimTK::ContactGeometry::HalfSpace(), material));
  }
}

void SimRobot::Impl::buildTree() {
  // A pin turns about z of its frames, so both frames are turned to put z on the URDF axis.
  const auto& links = model.links();
  const bool sagittal = kind == SimModel::Sagittal;
  mobods.resize(links.size());
  // The plant's masses (PlantSettings): every link scaled, the payload on the base.
  const PlantSettings& plant = settings.plant;
  const SimTK::Body::Rigid base_body =
      makeBody(addPointMass(scaleInertia(links[0].inertia, plant.link_mass_scale), plant.payload));
  if (sagittal) {
    // Planar moves in x and y of its F frame and turns about z: F's x, y, z on Ground's x, z,
    // -y makes the turn a nose-up pitch.
    base_X_GF = base_X_BM = SimTK::Transform(SimTK::Rotation(SimTK::Pi / 2, SimTK::XAxis));
    mobods[0] = SimTK::MobilizedBody::Planar(matter.updGround(), base_X_GF, base_body, base_X_BM);
  } else {
    mobods[0] = SimTK::MobilizedBody::Free(matter.updGround(), SimTK::Transform(), base_body,
                                           SimTK::Transform());
  }
  bodies.push_back(0);
  // Links were appended parent-before-child by the loader.
  for (std::size_t li = 1; li < links.size(); ++li) {
    const model::JointSpec& j = model.joints()[links[li].parent_joint];
    const int index = model::jointIndex(j.leg, j.kind);
    if (sagittal && !isLeftJoint(index)) continue;
    // Sagittal: the left link stands for itself and its mirror image (docs/sim.md).
    const double mass_scale = plant.link_mass_scale * (sagittal ? 2.0 : 1.0);
    const SimTK::Rotation R_JA(SimTK::UnitVec3(toVec3(j.axis)), SimTK::ZAxis);
    const SimTK::Transform X_PF = toTransform(j.X_PJ) * SimTK::Transform(R_JA);
    const SimTK::Transform X_BM(R_JA);
    const SimTK::MobilizedBody::Pin pin(
        mobods[j.parent_link], X_PF, makeBody(scaleInertia(links[li].inertia, mass_scale)), X_BM);
    mobods[li] = pin;
    pins[index] = pin;
    bodies.push_back(static_cast<int>(li));
  }
}

void SimRobot::Impl::mapJoints() {
  const bool sagittal = kind == SimModel::Sagittal;
  for (int i = 0; i < model::kNumJoints; ++i) {
    const bool mirrored = sagittal && !isLeftJoint(i);
    if (mirrored) pins[i] = pins[mirrorJoint(i)];
    joint_sign[i] = mirrored ? mirrorSign(i) : 1.0;
    drive_weight[i] = mirrored ? 0.0 : (sagittal ? 2.0 : 1.0);
  }
}

void SimRobot::Impl::addContactGeometry(const SimTK::ContactMaterial& material,
                                        bool ellipsoid_wheels) {
  // Surfaces against the ground: wheel, knee, base corners. Spheres go to GroundElement;
  // ellipsoid wheels to Simbody's tracker, in one clique so that they never collide with
  // each other.
  const SimTK::ContactCliqueId clique = SimTK::ContactSurface::createNewContactClique();
  const double r = model.wheelRadius();
  for (const model::Leg leg : model::kLegs) {
    const model::JointSpec& wheel = model.joint(leg, model::JointKind::Wheel);
    wheel_link[static_cast<int>(leg)] = wheel.child_link;
    // The loader guarantees the wheel axis is y of the wheel link.
    if (ellipsoid_wheels)
      mobods[wheel.child_link].updBody().addContactSurface(
          SimTK::Transform(), SimTK::ContactSurface(SimTK::ContactGeometry::Ellipsoid(SimTK::Vec3(
                                                        r, 0.5 * model.wheelWidth(), r)),
                                                    material)
                                  .joinClique(clique));
  }
  ground_spheres = detail::makeGroundSpheres(model, settings.contact, ellipsoid_wheels);
  groups = detail::makeBoxSphereGroups(model, settings.contact);
  if (kind == SimModel::Sagittal) detail::keepSagittal(ground_spheres, groups);
}

void SimRobot::Impl::makeDrives() {
  const PlantSettings& plant = settings.plant;
  for (int i = 0; i < model::kNumJoints; ++i) {
    envelopes[i] =
        scaleEnvelope(model.joints()[i].actuator, plant.torque_scale, plant.corner_speed_scale);
    if (envelopes[i].corner_speed_rad_s >= envelopes[i].no_load_speed_rad_s)
      throw std::invalid_argument("plant settings: corner_speed_scale puts the corner speed of " +
                                  model.joints()[i].name + " beyond its no-load speed");
  }
  pending.resize(
      static_cast<std::size_t>(std::ceil(plant.motor_latency_s / settings.control_period_s)) + 2);
}

void SimRobot::Impl::realizeAndCache() {
  default_state = system.realizeTopology();
  system.realizeModel(default_state);
  for (int i = 0; i < model::kNumJoints; ++i) {
    q_index[i] = pins[i].getFirstQIndex(default_state);
    u_index[i] = pins[i].getFirstUIndex(default_state);
  }
  link_mass.assign(mobods.size(), 0.0);
  link_com.assign(mobods.size(), SimTK::Vec3(0.0));
  for (const int b : bodies) {
    const SimTK::MassProperties& mp = mobods[b].getBodyMassProperties(default_state);
    link_mass[b] = mp.getMass();
    link_com[b] = mp.getMassCenter();
  }
}

void SimRobot::Impl::classifySurfaces() {
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
}

//==============================================================================================
void SimRobot::Impl::makeIntegrator() {
  const IntegratorSettings& is = settings.integrator;
  integ.reset();
  stepper.reset();
  if (is.kind == IntegratorKind::SemiExplicitEuler && euler_stepper_applies) {
    // Sagittal: a planar base and pins, whose qdot is their u (full: the free base's
    // quaternion, which EulerStepper::applies() refuses anyway).
    stepper =
        std::make_unique<detail::EulerStepper>(system, is.max_step_s, kind == SimModel::Sagittal);
    return;
  }
  switch (is.kind) {
    case IntegratorKind::SemiExplicitEuler:
    case IntegratorKind::SemiExplicitEulerSimbody:
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
  if (is.kind != IntegratorKind::SemiExplicitEuler &&
      is.kind != IntegratorKind::SemiExplicitEulerSimbody) {
    integ->setAccuracy(is.accuracy);
    integ->setMaximumStepSize(is.max_step_s);
  }
  // Every control instant must be a step boundary: the commands change there.
  integ->setAllowInterpolation(false);
}

void SimRobot::Impl::initializeIntegrator(const SimTK::State& s) {
  if (stepper)
    stepper->initialize(s);
  else
    integ->initialize(s);
}

}  // namespace wj::sim
