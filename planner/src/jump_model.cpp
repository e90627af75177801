#include "planner/jump_model.h"

#include "jump_model_internal.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace wj::planner {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Sagittal mass geometry of one leg (HAA at 0) from the robot model.
detail::PairGeometry pairGeometry(const model::RobotModel& robot, model::Leg leg) {
  using model::JointKind;
  const auto& g = robot.legGeometry(leg);
  detail::PairGeometry geo;
  const Eigen::Vector3d hfe = g.p_BH + g.p_HT;
  geo.hfe_b = Eigen::Vector2d(hfe.x(), hfe.z());
  // Leg link masses in the sagittal plane (HAA at 0): thigh in its frame; shank and wheel
  // together in the shank frame (the wheel's CoM is on its axle).
  const auto& thigh = robot.links()[robot.joint(leg, JointKind::HFE).child_link].inertia;
  const auto& shank = robot.links()[robot.joint(leg, JointKind::KFE).child_link].inertia;
  const auto& wheel_j = robot.joint(leg, JointKind::Wheel);
  const auto& wheel = robot.links()[wheel_j.child_link].inertia;
  geo.m_thigh = thigh.mass;
  geo.c_thigh = Eigen::Vector2d(thigh.com.x(), thigh.com.z());
  geo.m_lower = shank.mass + wheel.mass;
  const Eigen::Vector3d wheel_c = wheel_j.X_PJ * wheel.com;
  geo.c_lower = (shank.mass * Eigen::Vector2d(shank.com.x(), shank.com.z()) +
                 wheel.mass * Eigen::Vector2d(wheel_c.x(), wheel_c.z())) /
                geo.m_lower;
  const Eigen::Vector2d cs(shank.com.x(), shank.com.z()), cw(wheel_c.x(), wheel_c.z());
  geo.i_thigh = thigh.inertia_com(1, 1);
  geo.i_wheel =
      (wheel_j.X_PJ.linear() * wheel.inertia_com * wheel_j.X_PJ.linear().transpose())(1, 1);
  geo.i_lower = shank.inertia_com(1, 1) + shank.mass * (cs - geo.c_lower).squaredNorm() +
                wheel.mass * (cw - geo.c_lower).squaredNorm();
  geo.haa_lever = g.p_HT.y() + g.wheel_lateral_offset;
  return geo;
}

// The search box of u (docs/planner.md, "Decision variables"), with the take-off mode's and
// the flip's own ranges.
void setSearchBox(detail::JumpModelConstants& k) {
  const auto& s = k.settings;
  k.lower.resize(kNumDecision);
  k.upper.resize(kNumDecision);
  auto set = [&](int i, const std::array<double, 2>& b, double offset = 0.0) {
    k.lower[i] = b[0] + offset;
    k.upper[i] = b[1] + offset;
  };
  set(kMidDx, s.mid_dx_m);
  set(kMidDz, s.mid_dz_m);
  set(kMidDpitch, s.mid_dpitch_rad);
  set(kTakeoffDx, s.takeoff_dx_m);
  set(kTakeoffDz, s.takeoff_dz_m);
  set(kTakeoffDpitch, s.takeoff_dpitch_rad);
  set(kTakeoffDvx, s.takeoff_dvx_m_s);
  set(kTakeoffVz, s.takeoff_vz_m_s);
  set(kTakeoffRate, s.takeoff_pitch_rate_rad_s);
  set(kT1, s.t1_s);
  set(kT2MinusT1, s.t2_minus_t1_s);
  if (k.task.mode == TakeoffMode::Simultaneous) {
    for (int i : {kMidDx, kMidDz, kMidDpitch, kT2MinusT1}) k.lower[i] = k.upper[i] = 0.0;
  } else {
    set(kTakeoffDpitch, s.two_step_takeoff_dpitch_rad);
    set(kTakeoffRate, s.two_step_takeoff_pitch_rate_rad_s);
  }
  if (k.task.isBackflip()) {  // the flip box (planner_settings.h, docs/backflip.md)
    set(kT1, s.flip_t1_s);
    set(kT2MinusT1, s.flip_t2_minus_t1_s);
    set(kTakeoffDpitch, s.flip_takeoff_dpitch_rad);
    set(kTakeoffRate, s.flip_takeoff_pitch_rate_rad_s);
    set(kTakeoffVz, s.flip_takeoff_vz_m_s);
  }
}

}  // namespace

JumpModel::JumpModel(const model::RobotModel& robot, const PlannerSettings& settings,
                     const JumpTask& task, const InitialState& initial,
                     const LiftOffCorrection& correction) {
  k_.robot = robot;
  k_.settings = settings;
  k_.task = task;
  k_.init_input = initial;
  k_.liftoff_correction = correction;
  k_.settings.validate();
  k_.task.validate();
  k_.init_input.validate(k_.robot);
  k_.liftoff_correction.validate();
  using model::JointKind;
  using model::Leg;
  const auto& lg = k_.robot.legGeometry(Leg::LF);
  k_.leg = PlanarLeg{lg.thigh_length, k_.robot.legGeometry(Leg::LF).shank_length};
  k_.wheel_radius = k_.robot.wheelRadius();
  k_.mass = k_.robot.totalMass();
  k_.env_haa = k_.robot.joint(Leg::LF, JointKind::HAA).actuator;
  k_.env_hfe = k_.robot.joint(Leg::LF, JointKind::HFE).actuator;
  k_.env_kfe = k_.robot.joint(Leg::LF, JointKind::KFE).actuator;
  k_.env_wheel = k_.robot.joint(Leg::LF, JointKind::Wheel).actuator;
  k_.tyre_rolling_excess = 1.0 / k_.settings.tyre_rolling_radius_ratio - 1.0;
  k_.tyre_slip_torque = k_.wheel_radius * k_.wheel_radius * k_.settings.tyre_slip_stiffness_n_s_m;
  k_.tyre_hertz = 4.0 / 3.0 * k_.settings.tyre_contact_modulus_pa * std::sqrt(k_.wheel_radius);
  for (auto* env : {&k_.env_haa, &k_.env_hfe, &k_.env_kfe, &k_.env_wheel}) {
    env->peak_torque_nm *= k_.settings.actuator_torque_scale;
    // The paper's drives: the peak torque at every speed up to the no-load speed.
    if (k_.settings.actuator_model == ActuatorModel::ConstantTorque)
      env->corner_speed_rad_s = env->no_load_speed_rad_s;
  }
  k_.lim_hfe = {k_.robot.joint(Leg::LF, JointKind::HFE).lower_rad,
                k_.robot.joint(Leg::LF, JointKind::HFE).upper_rad};
  k_.lim_kfe = {k_.robot.joint(Leg::LF, JointKind::KFE).lower_rad,
                k_.robot.joint(Leg::LF, JointKind::KFE).upper_rad};

  // Composite inertia in the take-off posture (held constant: docs/planner.md, S-3).
  const Eigen::VectorXd q0 = k_.init_input.q;
  const model::Inertia inertia = k_.robot.calcCompositeInertia(q0);
  k_.inertia = inertia.inertia_com(1, 1);
  const Eigen::Vector2d com_b(inertia.com.x(), inertia.com.z());

  k_.box_half = Eigen::Vector2d(k_.robot.baseBoxSize().x() / 2, k_.robot.baseBoxSize().z() / 2);
  const auto X = k_.robot.calcLinkPoses(q0);
  k_.hind = pairGeometry(k_.robot, Leg::LH);
  k_.front = pairGeometry(k_.robot, Leg::LF);
  for (int pair = 0; pair < 2; ++pair) {
    const detail::PairGeometry& g = pair == 0 ? k_.hind : k_.front;
    detail::JumpModelConstants::LegInertia& li = k_.leg_inertia[pair];
    li.i_knee = g.i_lower + g.m_lower * g.c_lower.squaredNorm();
    li.i_hip = g.i_thigh + g.m_thigh * g.c_thigh.squaredNorm() + li.i_knee +
               g.m_lower * k_.leg.l1 * k_.leg.l1;
    li.m_l1_c = g.m_lower * k_.leg.l1 * g.c_lower.norm();
  }
  // The parts that do not move with the sagittal joints: the base and the hip (HAA) links.
  k_.mass_fixed = 0.0;
  k_.moment_fixed.setZero();
  for (std::size_t i = 0; i < k_.robot.links().size(); ++i) {
    const auto& link = k_.robot.links()[i];
    const bool fixed =
        link.parent_joint < 0 || k_.robot.joints()[link.parent_joint].kind == JointKind::HAA;
    if (!fixed) continue;
    const Eigen::Vector3d p = X[i] * link.inertia.com;
    k_.mass_fixed += link.inertia.mass;
    k_.moment_fixed += link.inertia.mass * Eigen::Vector2d(p.x(), p.z());
  }
  {
    const Eigen::Vector2d c_fixed = k_.moment_fixed / k_.mass_fixed;
    k_.i_fixed = 0.0;
    for (std::size_t i = 0; i < k_.robot.links().size(); ++i) {
      const auto& link = k_.robot.links()[i];
      if (link.parent_joint >= 0 && k_.robot.joints()[link.parent_joint].kind != JointKind::HAA)
        continue;
      const Eigen::Vector3d p = X[i] * link.inertia.com;
      const Eigen::Matrix3d Ib =
          X[i].linear() * link.inertia.inertia_com * X[i].linear().transpose();
      k_.i_fixed +=
          Ib(1, 1) + link.inertia.mass * (Eigen::Vector2d(p.x(), p.z()) - c_fixed).squaredNorm();
    }
  }
  k_.c0 = comInBase(Eigen::Vector2d(q0[model::jointIndex(Leg::LH, JointKind::HFE)],
                                    q0[model::jointIndex(Leg::LH, JointKind::KFE)]),
                    Eigen::Vector2d(q0[model::jointIndex(Leg::LF, JointKind::HFE)],
                                    q0[model::jointIndex(Leg::LF, JointKind::KFE)]));
  auto axle_rel_com = [&](Leg leg) {
    const Eigen::Vector3d p = X[k_.robot.joint(leg, JointKind::Wheel).child_link].translation();
    return detail::rot(k_.init_input.pitch, Eigen::Vector2d(p.x(), p.z()) - com_b);
  };
  const Eigen::Vector2d a_h = axle_rel_com(Leg::LH), a_f = axle_rel_com(Leg::LF);
  k_.d_hind = a_h.x();
  k_.d_front = a_f.x();
  if (!(k_.d_front - k_.d_hind > 0.05))
    throw std::invalid_argument("initial.q: the front wheels must be ahead of the hind wheels");
  k_.initial.x = 0.0;
  // The axles sit r above the ground, less the tyres' sink under the robot's weight.
  k_.initial.z = k_.wheel_radius -
                 detail::tyreSink(k_.tyre_hertz, 0.25 * k_.mass * k_.settings.gravity).x -
                 0.5 * (a_h.y() + a_f.y());
  k_.initial.pitch = k_.init_input.pitch;
  k_.initial.vx = k_.init_input.v0;
  k_.initial.vz = 0.0;
  k_.initial.pitch_rate = k_.init_input.pitch_rate;
  k_.q_landing = Eigen::Vector2d(k_.settings.landing_hfe_rad, k_.settings.landing_kfe_rad);
  Eigen::VectorXd q_land = q0;
  for (const Leg leg : model::kLegs) {
    q_land[model::jointIndex(leg, JointKind::HFE)] = k_.q_landing[0];
    q_land[model::jointIndex(leg, JointKind::KFE)] = k_.q_landing[1];
  }
  k_.z_land = standingComHeight(k_.robot, q_land);
  k_.c_land = comInBase(k_.q_landing, k_.q_landing);
  k_.landing_surface =
      k_.task.target.event == TargetEvent::Touchdown ? k_.task.target.height - k_.z_land : 0.0;
  for (const detail::PairGeometry* g : {&k_.hind, &k_.front})
    k_.touchdown_reach =
        std::max(k_.touchdown_reach,
                 (g->hfe_b + k_.leg.forward(k_.q_landing) - k_.c_land).norm() + k_.wheel_radius);
  k_.extend_start = k_.task.obstacle && !k_.task.landsOnObstacle()
                        ? k_.settings.wall_extend_start_fraction
                        : k_.settings.extend_start_fraction;
  if (k_.task.obstacle && k_.task.obstacle->x_min <= k_.d_front + k_.wheel_radius)
    throw std::invalid_argument("task.obstacle.x_min must be ahead of the front wheels (> " +
                                std::to_string(k_.d_front + k_.wheel_radius) +
                                " m in the jump frame), got " +
                                std::to_string(k_.task.obstacle->x_min));

  setSearchBox(k_);
  const auto& s = k_.settings;
  if (k_.settings.stance_momentum) {
    // E(0): the initial state and posture, the same for every candidate.
    detail::Solved S;
    const PlanarState& s0 = k_.initial;
    S.t1 = S.t2 = 1.0;
    S.X1 = {s0.x};
    S.Z1 = {s0.z};
    S.P1 = {s0.pitch};
    S.VX1 = {s0.vx};
    S.VZ1 = {s0.vz};
    S.W1 = {s0.pitch_rate};
    detail::Sample smp;
    detail::contactSample(k_, S, 0.0, smp, /*phase2=*/false, k_.c0, /*converge=*/true);
    k_.e0 = detail::stanceMomentumExcess(k_, smp);
  }
  k_.per_contact_sample = 2 * 15 + 1 + (k_.task.obstacle ? 1 : 0);
  k_.per_flight_sample = 1 + (k_.task.obstacle ? 1 : 0);
  k_.num_contact_samples =
      s.samples_phase1 + (k_.task.mode == TakeoffMode::TwoStep ? s.samples_phase2 : 0);
  k_.num_constraint_samples = k_.per_contact_sample * k_.num_contact_samples +
                              k_.per_flight_sample * s.samples_flight + (k_.task.obstacle ? 1 : 0) +
                              detail::kFlightBrakeRows;
}

JumpModel::SampleOrigin JumpModel::constraintSampleOrigin(int i) const {
  if (i < 0 || i >= k_.num_constraint_samples)
    throw std::out_of_range("JumpModel::constraintSampleOrigin: " + std::to_string(i) +
                            " not in [0, " + std::to_string(k_.num_constraint_samples) + ")");
  const int contact = k_.per_contact_sample * k_.num_contact_samples;
  if (i < contact) return {i % k_.per_contact_sample, i / k_.per_contact_sample};
  const int j = i - contact;
  const int flight = k_.per_flight_sample * k_.settings.samples_flight;
  if (j < flight)
    return {k_.per_contact_sample + j % k_.per_flight_sample, j / k_.per_flight_sample};
  const int brake = j - flight - (k_.task.obstacle ? 1 : 0);
  if (brake < 0) return {k_.per_contact_sample + k_.per_flight_sample, 0};  // landing beyond
  // The legs' braking after the lift-off: a channel per joint (sweepFlight).
  return {k_.per_contact_sample + k_.per_flight_sample + 1 + brake, 0};
}

Eigen::Vector2d JumpModel::comInBase(const Eigen::Vector2d& q_hind,
                                     const Eigen::Vector2d& q_front) const {
  return detail::comOffset(k_, detail::poseOf(q_hind), detail::poseOf(q_front));
}

double unloadingTailWeight(double t2, double control_dt, double unload_s) {
  if (!(unload_s > 0.0)) return 0.0;
  // The executor switches at its first instant k control_dt at or after t2 (PlanExecutor),
  // but the row there is the push's if it is t2 itself: its flight references start at the
  // first instant after t2.
  const double hold = (std::floor((t2 + 1e-12) / control_dt) + 1.0) * control_dt - t2;
  return hold + 0.5 * unload_s;
}

double JumpModel::standingComHeight(const model::RobotModel& robot, const Eigen::VectorXd& q) {
  const model::Inertia inertia = robot.calcCompositeInertia(q);
  const auto X = robot.calcLinkPoses(q);
  double lowest = kInf;
  for (const model::Leg leg : model::kLegs)
    lowest =
        std::min(lowest, X[robot.joint(leg, model::JointKind::Wheel).child_link].translation().z() -
                             inertia.com.z());
  return robot.wheelRadius() - lowest;
}

}  // namespace wj::planner
