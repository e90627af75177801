// The robot in Simbody: SimRobot's interface (read, write, advance, reset, ground truth) over its
// implementation (sim_robot_impl.h; built in sim_robot_build.cpp, forces in force_elements.cpp).
// The translation units of this folder are compiled as C++17 (Simbody 3.7's headers do not
// compile as C++20 with GCC 12) and are the only place of the sim library that sees Simbody.
#include "sim/sim_robot.h"

#include <Simbody.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include "sim/symmetry.h"
#include "sim_robot_impl.h"

namespace wj::sim {

using detail::GroundContact;
using detail::GroundSphere;
using detail::Part;
using detail::SphereGroup;
using detail::toEigen;
using detail::toTransform;
using detail::toVec3;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

//==============================================================================================
void SimRobot::Impl::calcMassCenter(const SimTK::State& s, SimTK::Vec3& p_GC,
                                    SimTK::Vec3& v_GC) const {
  double mass = 0.0;
  SimTK::Vec3 com(0), com_v(0);
  for (const int b : bodies) {
    const SimTK::Transform& X_GB = mobods[b].getBodyTransform(s);
    const SimTK::SpatialVec& V_GB = mobods[b].getBodyVelocity(s);
    const SimTK::Vec3 r_G = X_GB.R() * link_com[b];  // body origin to body CoM, in G
    mass += link_mass[b];
    com += link_mass[b] * (X_GB.p() + r_G);
    com_v += link_mass[b] * (V_GB[1] + V_GB[0] % r_G);
  }
  p_GC = com / mass;
  v_GC = com_v / mass;
  if (kind == SimModel::Sagittal) {
    // A leg and its mirror image have their centre of mass at y = 0, the base too
    // (findAsymmetry()); the merged legs, built on the left, would put it at y > 0.
    p_GC[1] = 0.0;
    v_GC[1] = 0.0;
  }
}

void SimRobot::Impl::checkSymmetric(const model::JointCommands& c) const {
  const auto near = [](double a, double b) {
    return a == b || std::abs(a - b) <= 1e-9 * (1.0 + std::abs(a) + std::abs(b));
  };
  for (int i = 0; i < model::kNumJoints; ++i) {
    if (isLeftJoint(i)) continue;
    const model::JointCommand& r = c[i];
    const model::JointCommand& l = c[mirrorJoint(i)];
    const double sign = mirrorSign(i);
    if (!near(r.q_des, sign * l.q_des) || !near(r.qd_des, sign * l.qd_des) ||
        !near(r.tau_ff, sign * l.tau_ff) || !near(r.kp, l.kp) || !near(r.kd, l.kd))
      throw AsymmetryError("SimRobot (sagittal): the command of " + model.joints()[i].name +
                           " is not the mirror image of " + model.joints()[mirrorJoint(i)].name +
                           "'s");
  }
}

void SimRobot::Impl::checkSymmetric(const RobotPlacement& p) const {
  constexpr double kTol = 1e-9;
  const Eigen::Matrix3d& R = p.X_WB.linear();
  const bool planar = std::abs(p.X_WB.translation().y()) <= kTol && std::abs(R(1, 0)) <= kTol &&
                      std::abs(R(0, 1)) <= kTol && std::abs(R(1, 2)) <= kTol &&
                      std::abs(R(2, 1)) <= kTol && std::abs(p.v_WB.y()) <= kTol &&
                      std::abs(p.w_WB.x()) <= kTol && std::abs(p.w_WB.z()) <= kTol;
  if (!planar) throw AsymmetryError("SimRobot (sagittal): the base is placed out of its plane");
  for (int i = 0; i < model::kNumJoints; ++i) {
    if (isLeftJoint(i)) continue;
    const int l = mirrorJoint(i);
    if (std::abs(p.q[i] - mirrorSign(i) * p.q[l]) > kTol ||
        std::abs(p.qd[i] - mirrorSign(i) * p.qd[l]) > kTol)
      throw AsymmetryError("SimRobot (sagittal): " + model.joints()[i].name +
                           " is placed other than as the mirror image of " +
                           model.joints()[l].name);
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
SimRobot::SimRobot(const model::RobotModel& model, const SimSettings& settings, SimModel kind)
    : impl_(std::make_unique<Impl>(model, settings, kind)) {}
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
  if (m.kind == SimModel::Sagittal) m.checkSymmetric(commands);
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
    if (stepper) {
      if (stepper->getTime() < t_end - 1e-12) stepper->stepTo(t_end);
      return;
    }
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
    while (pending_count > 0 && pending[pending_head].t_apply <= time() + 1e-9) {
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
  if (m.kind == SimModel::Sagittal) m.checkSymmetric(placement);
  SimTK::State s = m.default_state;
  s.setTime(0.0);
  // The mobilizer's q and u fit its own frames: X_FM and V_FM (M moves with the base origin,
  // F stands still on Ground).
  const SimTK::Rotation& R_FG = ~m.base_X_GF.R();
  m.mobods[0].setQToFitTransform(s, ~m.base_X_GF * toTransform(placement.X_WB) * m.base_X_BM);
  m.mobods[0].setUToFitVelocity(
      s, SimTK::SpatialVec(R_FG * toVec3(placement.w_WB), R_FG * toVec3(placement.v_WB)));
  for (int i = 0; i < model::kNumJoints; ++i) {
    if (m.drive_weight[i] == 0.0) continue;  // sagittal: a right joint, its left one's mirror
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
  m.initializeIntegrator(s);
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
  if (m.kind == SimModel::Sagittal) {
    // The right wheels' contacts are the left ones' mirror images.
    for (const model::Leg leg : {model::Leg::RF, model::Leg::RH}) {
      const int r = static_cast<int>(leg);
      const WheelContact& left = out.wheels[r ^ 1];
      out.wheels[r] = left;
      out.wheels[r].force_W.y() = -left.force_W.y();
    }
  }
  out.obstacle_clearance_m = m.calcClearance(s);
}

model::Inertia SimRobot::calcCompositeInertia() const {
  const Impl& m = *impl_;
  if (m.kind == SimModel::Sagittal)
    throw std::logic_error("SimRobot::calcCompositeInertia: not available in the sagittal model");
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
  const Impl& m = *impl_;
  if (m.stepper)
    return {m.stepper->stepsTaken(), m.stepper->stepsTaken(), m.stepper->realizations()};
  return {m.integ->getNumStepsTaken(), m.integ->getNumStepsAttempted(),
          m.integ->getNumRealizations()};
}

const SimSettings& SimRobot::settings() const {
  return impl_->settings;
}

const model::RobotModel& SimRobot::model() const {
  return impl_->model;
}

SimModel SimRobot::kind() const {
  return impl_->kind;
}

}  // namespace wj::sim
