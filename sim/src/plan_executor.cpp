#include "sim/plan_executor.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "sim/verifier.h"

namespace wj::sim {

namespace {

void requirePositive(double v, const char* name) {
  if (!(v > 0.0) || !std::isfinite(v))
    throw std::invalid_argument(std::string("executor settings: ") + name + " must be > 0");
}

void requireNonNegative(double v, const char* name) {
  if (!(v >= 0.0) || !std::isfinite(v))
    throw std::invalid_argument(std::string("executor settings: ") + name + " must be >= 0");
}

}  // namespace

std::string_view toString(JumpPhase phase) {
  switch (phase) {
    case JumpPhase::Takeoff:
      return "takeoff";
    case JumpPhase::Flight:
      return "flight";
    case JumpPhase::Landing:
      return "landing";
  }
  return "?";
}

void ExecutorSettings::validate() const {
  requireNonNegative(takeoff_kp, "takeoff_kp");
  requireNonNegative(takeoff_kd, "takeoff_kd");
  requireNonNegative(wheel_kd, "wheel_kd");
  requireNonNegative(flight_wheel_kd, "flight_wheel_kd");
  requireNonNegative(takeoff_wheel_kd, "takeoff_wheel_kd");
  requireNonNegative(takeoff_wheel_slip_band_m_s, "takeoff_wheel_slip_band_m_s");
  requirePositive(tyre_slip_stiffness_n_s_m, "tyre_slip_stiffness_n_s_m");
  if (!(tyre_rolling_radius_ratio >= 0.8 && tyre_rolling_radius_ratio <= 1.2))
    throw std::invalid_argument(
        "executor settings: tyre_rolling_radius_ratio must be in [0.8, 1.2]");
  requireNonNegative(takeoff_momentum_kp, "takeoff_momentum_kp");
  requireNonNegative(takeoff_momentum_kd, "takeoff_momentum_kd");
  requireNonNegative(takeoff_momentum_max_nm, "takeoff_momentum_max_nm");
  requireNonNegative(flight_kp, "flight_kp");
  requireNonNegative(flight_kd, "flight_kd");
  requirePositive(flight_blend_s, "flight_blend_s");
  requireNonNegative(landing_kp, "landing_kp");
  requireNonNegative(landing_kd, "landing_kd");
  requireNonNegative(landing_wheel_decel_m_s2, "landing_wheel_decel_m_s2");
  requirePositive(landing_duration_s, "landing_duration_s");
  requirePositive(airborne_debounce_s, "airborne_debounce_s");
  requireNonNegative(max_flight_overrun_s, "max_flight_overrun_s");
  requireNonNegative(joint_limit_margin_rad, "joint_limit_margin_rad");
  requireNonNegative(hind_pitch_kp, "hind_pitch_kp");
  requireNonNegative(hind_pitch_kd, "hind_pitch_kd");
  requireNonNegative(hind_pitch_max_nm, "hind_pitch_max_nm");
  requireNonNegative(lifted_pair_margin_rad, "lifted_pair_margin_rad");
  requireNonNegative(two_step_takeoff_kp, "two_step_takeoff_kp");
  requireNonNegative(two_step_takeoff_kd, "two_step_takeoff_kd");
  requireNonNegative(two_step_flight_kp, "two_step_flight_kp");
  requireNonNegative(two_step_flight_kd, "two_step_flight_kd");
  requireNonNegative(two_step_landing_wheel_decel_m_s2, "two_step_landing_wheel_decel_m_s2");
  if (!(touchdown_pitch_placement >= 0.0 && touchdown_pitch_placement <= 1.0))
    throw std::invalid_argument("executor settings: touchdown_pitch_placement must be in [0, 1]");
  requireNonNegative(touchdown_placement_max_rad, "touchdown_placement_max_rad");
  requireNonNegative(touchdown_placement_lead_s, "touchdown_placement_lead_s");
  requireNonNegative(touchdown_placement_band_up_rad, "touchdown_placement_band_up_rad");
  requireNonNegative(touchdown_placement_band_down_rad, "touchdown_placement_band_down_rad");
  requireNonNegative(landing_pitch_limit_rad, "landing_pitch_limit_rad");
  requireNonNegative(landing_nose_down_limit_rad, "landing_nose_down_limit_rad");
  requireNonNegative(landing_pitch_kp, "landing_pitch_kp");
  requireNonNegative(landing_pitch_kd, "landing_pitch_kd");
  requireNonNegative(landing_pitch_max_nm, "landing_pitch_max_nm");
}

std::string checkPlan(const planner::JumpPlan& plan) {
  const int n = plan.numSamples();
  if (n < 2) return "the plan has fewer than 2 dense samples";
  if (!(plan.dt > 0.0) || plan.dt > 0.002 + 1e-12)
    return "the sample period dt must lie in (0, 0.002] s";
  if (!(0.0 <= plan.t1 && plan.t1 <= plan.t2 && plan.t2 < plan.t3))
    return "the phase times must satisfy 0 <= t1 <= t2 < t3";
  for (const auto* m : {&plan.q, &plan.qd, &plan.tau})
    if (m->rows() != n || m->cols() != model::kNumJoints)
      return "q, qd and tau must be N x 16 with N = number of centroidal samples";
  if ((n - 1) * plan.dt < plan.t2 - plan.dt)
    return "the dense samples end before the take-off time t2";
  if (!plan.q.allFinite() || !plan.qd.allFinite() || !plan.tau.allFinite() ||
      !plan.q_initial.allFinite() || !plan.q_landing.allFinite())
    return "the plan contains non-finite values";
  return {};
}

namespace {

// When the plan's legs are at rest after the lift-off's braking: the first sample after t2 at
// which every leg joint that left the ground turning (0.5 rad/s or faster) has stopped or turned
// back (the tuck). From the rates, not the torques: a plan with the flight's feed-forward
// (physics.flight_feedforward) carries torques through the whole flight.
double calcBrakeEnd(const planner::JumpPlan& plan, int k2) {
  constexpr double kMoving = 0.5, kAtRest = 0.05;  // [rad/s]
  double t = plan.t2;
  for (int j = 0; j < model::kNumJoints; ++j) {
    const double w0 = plan.qd(k2, j);
    if (model::isWheel(j) || std::abs(w0) < kMoving) continue;
    for (int k = k2 + 1; k < plan.numSamples(); ++k)
      if (plan.qd(k, j) * w0 <= 0.0 || std::abs(plan.qd(k, j)) < kAtRest) {
        t = std::max(t, k * plan.dt);
        break;
      }
  }
  return t;
}

}  // namespace

PlanExecutor::PlanExecutor(const model::RobotModel& model, const planner::JumpPlan& plan,
                           const ExecutorSettings& settings, double gravity_m_s2)
    : model_(model),
      plan_(plan),
      settings_(settings),
      momentum_(model),
      q_meas_(Eigen::VectorXd::Zero(model::kNumJoints)),
      qd_meas_(Eigen::VectorXd::Zero(model::kNumJoints)) {
  settings_.validate();
  if (const std::string problem = checkPlan(plan); !problem.empty())
    throw std::invalid_argument("PlanExecutor: " + problem);
  if (settings_.landing_gravity_feedforward)
    landing_feedforward_ = calcStandingStatics(model, plan.q_landing, gravity_m_s2).tau;
  // Wheel speed after take-off: rolling at the planned horizontal CoM speed at t2, which the
  // flight conserves, so that the wheels meet the ground without slip. Holding it also keeps
  // the wheels from trading angular momentum with the body in flight.
  const int k2 =
      std::clamp(static_cast<int>(std::lround(plan.t2 / plan.dt)), 0, plan.numSamples() - 1);
  wheel_speed_ = plan.centroidal[k2].vx / model.wheelRadius();
  const int k_mid = std::clamp(static_cast<int>(std::lround(0.5 * (plan.t1 + plan.t2) / plan.dt)),
                               0, plan.numSamples() - 1);
  brake_end_t_ = calcBrakeEnd(plan, k2);
  // The plan's apex: the first sample after take-off whose CoM no longer rises.
  int k_apex = k2;
  while (k_apex < plan.numSamples() - 1 && plan.centroidal[k_apex].vz > 0.0) ++k_apex;
  t_apex_ = k_apex * plan.dt;
  hind_only_ = plan.t2 - plan.t1 > 2.0 * plan.dt;
  // The lifted front pair carries no ground force: its HAA and wheel torques are zero (its
  // HFE and KFE brake from their speeds at t1).
  for (const model::Leg leg : {model::Leg::LF, model::Leg::RF})
    for (const model::JointKind kind : {model::JointKind::HAA, model::JointKind::Wheel})
      hind_only_ = hind_only_ && plan.tau(k_mid, model::jointIndex(leg, kind)) == 0.0;
  const ExecutorSettings& e = settings_;
  takeoff_kp_ = hind_only_ ? e.two_step_takeoff_kp : e.takeoff_kp;
  takeoff_kd_ = hind_only_ ? e.two_step_takeoff_kd : e.takeoff_kd;
  takeoff_wheel_kd_ = hind_only_ ? e.wheel_kd : e.takeoff_wheel_kd;
  flight_kp_ = hind_only_ ? e.two_step_flight_kp : e.flight_kp;
  flight_kd_ = hind_only_ ? e.two_step_flight_kd : e.flight_kd;
  landing_decel_ = hind_only_ ? e.two_step_landing_wheel_decel_m_s2 : e.landing_wheel_decel_m_s2;
  // The plan's momentum, row by row, from its attitude (about y) and rates: the take-off's
  // rows, up to the one after t2 (the feedback interpolates between rows k and k + 1, t < t2).
  if (!hind_only_ && (e.takeoff_momentum_kp > 0.0 || e.takeoff_momentum_kd > 0.0)) {
    h_plan_.resize(std::min(plan.numSamples(), static_cast<int>(plan.t2 / plan.dt) + 2));
    for (int k = 0; k < static_cast<int>(h_plan_.size()); ++k) {
      const planner::PlanarState& s = plan.centroidal[k];
      const Eigen::Matrix3d R =
          Eigen::AngleAxisd(-s.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
      q_meas_ = plan.q.row(k).transpose();
      qd_meas_ = plan.qd.row(k).transpose();
      h_plan_[k] =
          -momentum_.calc(R, Eigen::Vector3d(0.0, -s.pitch_rate, 0.0), q_meas_, qd_meas_).y();
    }
  }
}

PlanExecutor::SamplePoint PlanExecutor::samplePoint(double t) const {
  const int n = plan_.numSamples();
  const double s = std::clamp(t / plan_.dt, 0.0, static_cast<double>(n - 1));
  const int k0 = std::min(static_cast<int>(s), n - 2);
  return {k0, s - k0};
}

void PlanExecutor::sample(double t, model::JointCommands& out) const {
  const auto [k0, a] = samplePoint(t);
  for (int j = 0; j < model::kNumJoints; ++j) {
    model::JointCommand& c = out[j];
    c.q_des = (1.0 - a) * plan_.q(k0, j) + a * plan_.q(k0 + 1, j);
    c.qd_des = (1.0 - a) * plan_.qd(k0, j) + a * plan_.qd(k0 + 1, j);
    c.tau_ff = (1.0 - a) * plan_.tau(k0, j) + a * plan_.tau(k0 + 1, j);
    c.kp = model::isWheel(j) ? 0.0 : takeoff_kp_;
    c.kd = model::isWheel(j) ? takeoff_wheel_kd_ : takeoff_kd_;
  }
}

void PlanExecutor::update(double t, const model::SensorData& sensors, bool any_wheel_contact,
                          model::JointCommands& out) {
  // Contact bookkeeping and phase changes.
  if (any_wheel_contact) {
    if (airborne_ && phase_ == JumpPhase::Flight && t >= brake_end_t_) {
      phase_ = JumpPhase::Landing;
      landing_start_ = t;
      placement_td_ = calcPlacementOffset(t);
    }
    last_contact_t_ = t;
    if (phase_ == JumpPhase::Takeoff) airborne_ = false;  // a hop in the push, not the flight
  } else if (t - last_contact_t_ >= settings_.airborne_debounce_s - 1e-12) {
    airborne_ = true;
  }
  if (phase_ == JumpPhase::Takeoff && t >= plan_.t2 - 1e-12) {
    phase_ = JumpPhase::Flight;
    flight_start_ = t;
    for (int j = 0; j < model::kNumJoints; ++j) {
      q_flight_start_[j] = sensors.joints[j].q;
      qd_flight_start_[j] = sensors.joints[j].qd;
    }
  }
  if (phase_ == JumpPhase::Flight && t >= plan_.t3 + settings_.max_flight_overrun_s) {
    phase_ = JumpPhase::Landing;
    landing_start_ = t;
    placement_td_ = calcPlacementOffset(t);
  }

  const Eigen::Matrix3d R_WB = sensors.imu.q_WB.toRotationMatrix();
  pitch_ = calcUnwrappedPitch(R_WB, have_pitch_ ? pitch_ : 0.0);
  if (!have_pitch_) pitch0_ = pitch_;
  have_pitch_ = true;

  switch (phase_) {
    case JumpPhase::Takeoff:
      sample(t, out);
      if (!hind_only_) applyTakeoffWheelLaw(t, sensors, out);
      if (!h_plan_.empty()) addMomentumFeedback(t, sensors, R_WB, out);
      if (hind_only_ && t >= plan_.t1) {
        addHindPitchFeedback(t, R_WB * sensors.imu.omega_B, out);
        keepLiftedPairInRange(out);
      }
      return;
    case JumpPhase::Flight: {
      // The plan's own flight references while they last (the planner moves the legs to
      // q_landing there); a plan that ends at take-off gets a quintic blend instead.
      const double plan_end = (plan_.numSamples() - 1) * plan_.dt;
      if (t <= plan_end) {
        sample(t, out);
      } else if (plan_end < flight_start_ + plan_.dt) {
        blendToLanding(t, out);
      } else {
        for (int j = 0; j < model::kNumJoints; ++j)
          out[j] = {plan_.q_landing[j], 0.0, 0.0, 0.0, 0.0};
      }
      // The plan's flight feed-forward is the legs' braking after the lift-off (and zero once
      // they are at rest): tracking the braking with the soft flight gains alone lags by
      // 0.05-0.1 rad and runs the knee into its stop.
      for (int j = 0; j < model::kNumJoints; ++j) {
        model::JointCommand& c = out[j];
        if (t > plan_end) c.tau_ff = 0.0;
        if (model::isWheel(j)) {
          c = {0.0, wheel_speed_, 0.0, settings_.flight_wheel_kd, 0.0};
        } else {
          c.kp = flight_kp_;
          c.kd = flight_kd_;
        }
      }
      addHfeOffset(calcPlacementOffset(t), out);
      return;
    }
    case JumpPhase::Landing: {
      // Wheels: from the take-off ground speed towards the hand-over speed (0 without a
      // hand-over) at landing_wheel_decel_m_s2.
      const double r = model_.wheelRadius();
      const double since = t - landing_start_;
      const double v0 = wheel_speed_ * r;
      const double v_end = handover_ ? handover_->speed_m_s : 0.0;
      const double dv = landing_decel_ * since;
      const double v = v0 > v_end ? std::max(v_end, v0 - dv) : std::min(v_end, v0 + dv);
      // Legs: q_landing, blended to the hand-over posture over the rest of the landing.
      double s = 0.0, sd = 0.0;
      if (handover_) {
        const double T = settings_.landing_duration_s - handover_->blend_start_s;
        const double u =
            T > 0.0 ? std::clamp((since - handover_->blend_start_s) / T, 0.0, 1.0) : 1.0;
        s = u * u * u * (10.0 + u * (6.0 * u - 15.0));  // quintic smoothstep
        sd = T > 0.0 && u > 0.0 && u < 1.0 ? 30.0 * u * u * (1.0 - u) * (1.0 - u) / T : 0.0;
      }
      for (int j = 0; j < model::kNumJoints; ++j) {
        model::JointCommand& c = out[j];
        if (model::isWheel(j)) {
          c = {0.0, v / r, 0.0, settings_.wheel_kd, 0.0};
        } else if (handover_) {
          const double dq = handover_->q[j] - plan_.q_landing[j];
          const double ff =
              landing_feedforward_[j] + s * (handover_->tau_gravity[j] - landing_feedforward_[j]);
          c = {plan_.q_landing[j] + s * dq, sd * dq, settings_.landing_kp, settings_.landing_kd,
               settings_.landing_gravity_feedforward ? ff : 0.0};
        } else {
          c = {plan_.q_landing[j], 0.0, settings_.landing_kp, settings_.landing_kd,
               landing_feedforward_[j]};
        }
      }
      addHfeOffset((1.0 - s) * placement_td_, out);
      addLandingPitchBrake(R_WB * sensors.imu.omega_B, sensors, out);
      return;
    }
  }
}

void PlanExecutor::applyTakeoffWheelLaw(double t, const model::SensorData& sensors,
                                        model::JointCommands& out) const {
  const ExecutorSettings& e = settings_;
  const double r = model_.wheelRadius();
  const auto [k0, a] = samplePoint(t);
  // The body's nose-up pitch rate is a rotation about -y.
  const double body_rate_y =
      -((1.0 - a) * plan_.centroidal[k0].pitch_rate + a * plan_.centroidal[k0 + 1].pitch_rate);
  const double band = e.takeoff_wheel_slip_band_m_s / r;
  for (const model::Leg leg : model::kLegs) {
    model::JointCommand& c = out[model::jointIndex(leg, model::JointKind::Wheel)];
    // The wheel's spin about +y in the world (the plan's rolling rate v_axle / r): the
    // shank's, body plus HFE and KFE, and the wheel joint's. A loaded tyre rolls on ratio x r,
    // and carries the plan's traction tau / r at a slip of that over the stiffness.
    const double spin = body_rate_y + out[model::jointIndex(leg, model::JointKind::HFE)].qd_des +
                        out[model::jointIndex(leg, model::JointKind::KFE)].qd_des + c.qd_des;
    const double slip_m_s = c.tau_ff / (r * e.tyre_slip_stiffness_n_s_m);
    c.qd_des += (1.0 / e.tyre_rolling_radius_ratio - 1.0) * spin + slip_m_s / r;
    // No feedback inside the band: the reference moves with the measured rate up to its edge.
    const double qd = sensors.joints[model::jointIndex(leg, model::JointKind::Wheel)].qd;
    c.qd_des = std::clamp(qd, c.qd_des - band, c.qd_des + band);
  }
}

void PlanExecutor::addMomentumFeedback(double t, const model::SensorData& sensors,
                                       const Eigen::Matrix3d& R_WB, model::JointCommands& out) {
  const ExecutorSettings& e = settings_;
  // The measured nose-up momentum: about the body's -y axis (the world's -y for the plan's
  // attitude, which turns about y only), so a heading or roll leaves it the pitch's.
  for (int j = 0; j < model::kNumJoints; ++j) {
    q_meas_[j] = sensors.joints[j].q;
    qd_meas_[j] = sensors.joints[j].qd;
  }
  const Eigen::Vector3d H = momentum_.calc(R_WB, R_WB * sensors.imu.omega_B, q_meas_, qd_meas_);
  const double h = -H.dot(R_WB.col(1));
  const auto [k0, a] = samplePoint(t);
  const double error = (1.0 - a) * h_plan_[k0] + a * h_plan_[k0 + 1] - h;
  const double error_rate =
      h_error_t_ >= 0.0 && t > h_error_t_ ? (error - h_error_) / (t - h_error_t_) : 0.0;
  h_error_ = error;
  h_error_t_ = t;
  const double moment =
      std::clamp(e.takeoff_momentum_kp * error + e.takeoff_momentum_kd * error_rate,
                 -e.takeoff_momentum_max_nm, e.takeoff_momentum_max_nm);
  // The axles in the world, relative to the base, and the lever between the pairs along the
  // heading (the body's x in the horizontal plane).
  const std::vector<Eigen::Isometry3d>& X = momentum_.linkPoses();
  const auto axle = [&](model::Leg leg) -> Eigen::Vector3d {
    return X[model_.joint(leg, model::JointKind::Wheel).child_link].translation();
  };
  Eigen::Vector3d heading = R_WB.col(0);
  heading.z() = 0.0;
  if (!(heading.norm() > 0.1)) return;
  heading.normalize();
  const double lever = 0.5 * heading.dot(R_WB * (axle(model::Leg::LF) + axle(model::Leg::RF) -
                                                 axle(model::Leg::LH) - axle(model::Leg::RH)));
  if (!(lever > 0.05)) return;
  // Per wheel: df up on the front pair, df down on the hind (M = 2 df x lever). Each
  // leg's joints give the wheel's share as tau = -J^T F, J its axle's Jacobian (a vertical
  // force under the axle has no moment about it), a revolute joint's column a x (p - o).
  const double df = moment / (2.0 * lever);
  for (const model::Leg leg : model::kLegs) {
    const Eigen::Vector3d F_B =
        R_WB.transpose() * Eigen::Vector3d(0.0, 0.0, model::isFront(leg) ? df : -df);
    const Eigen::Vector3d p = axle(leg);
    for (const model::JointKind kind :
         {model::JointKind::HAA, model::JointKind::HFE, model::JointKind::KFE}) {
      const model::JointSpec& spec = model_.joint(leg, kind);
      const Eigen::Isometry3d& X_j = X[spec.child_link];
      const Eigen::Vector3d column = (X_j.linear() * spec.axis).cross(p - X_j.translation());
      out[model::jointIndex(leg, kind)].tau_ff -= column.dot(F_B);
    }
  }
}

void PlanExecutor::addHindPitchFeedback(double t, const Eigen::Vector3d& omega_W,
                                        model::JointCommands& out) const {
  const int n = plan_.numSamples();
  const int k = std::clamp(static_cast<int>(std::lround(t / plan_.dt)), 0, n - 1);
  const planner::PlanarState& ref = plan_.centroidal[k];
  const double e = ref.pitch - (pitch_ - pitch0_);
  const double e_rate = ref.pitch_rate - (-omega_W.y());
  const double max = settings_.hind_pitch_max_nm;
  const double dtau =
      std::clamp(settings_.hind_pitch_kp * e + settings_.hind_pitch_kd * e_rate, -max, max);
  for (const model::Leg leg : {model::Leg::LH, model::Leg::RH})
    out[model::jointIndex(leg, model::JointKind::Wheel)].tau_ff += dtau;
}

double PlanExecutor::calcPlacementOffset(double t) const {
  if (settings_.touchdown_pitch_placement == 0.0) return 0.0;
  // The plan's pitch is relative to the pitch at the start of the take-off; its dense
  // references reach touchdown (t3), and the plan's touchdown pitch holds after it.
  const int n = plan_.numSamples();
  const int k = std::clamp(static_cast<int>(std::lround(t / plan_.dt)), 0, n - 1);
  const double raw = (pitch_ - pitch0_) - plan_.centroidal[k].pitch;
  const double up = settings_.touchdown_placement_band_up_rad;
  const double down = settings_.touchdown_placement_band_down_rad;
  const double error = raw > up ? raw - up : raw < -down ? raw + down : 0.0;
  const double max = settings_.touchdown_placement_max_rad;
  // The ramp starts at the plan's apex and ends touchdown_placement_lead_s before the plan's
  // touchdown, or at the touchdown when the apex comes later than that (a platform: 35 ms
  // between them); before the apex the offset is zero.
  double ramp_end = plan_.t3 - settings_.touchdown_placement_lead_s;
  if (ramp_end <= t_apex_) ramp_end = plan_.t3;
  const double w = ramp_end > t_apex_ ? std::clamp((t - t_apex_) / (ramp_end - t_apex_), 0.0, 1.0)
                                      : (t >= t_apex_ ? 1.0 : 0.0);
  return w * std::clamp(settings_.touchdown_pitch_placement * error, -max, max);
}

void PlanExecutor::addLandingPitchBrake(const Eigen::Vector3d& omega_W,
                                        const model::SensorData& sensors,
                                        model::JointCommands& out) const {
  const ExecutorSettings& e = settings_;
  if (e.landing_pitch_kp == 0.0 && e.landing_pitch_kd == 0.0) return;
  // The absolute nose-up pitch, folded: after a backflip the running pitch is a turn more.
  const double pitch = foldAngle(pitch_);
  const double rate = -omega_W.y();  // nose-up positive
  // One guard, two sides: beyond the limit of its side (a wheelie nose-up, a stoppie
  // nose-down) every wheel turns the body back, braking against a wheelie (it pitches the
  // body nose-down) and driving against a stoppie, never the other way.
  const double side = pitch > 0.0 ? 1.0 : -1.0;
  const double beyond =
      side * pitch - (side > 0.0 ? e.landing_pitch_limit_rad : e.landing_nose_down_limit_rad);
  if (beyond <= 0.0) return;
  const double dtau =
      -side * std::clamp(e.landing_pitch_kp * beyond + e.landing_pitch_kd * side * rate, 0.0,
                         e.landing_pitch_max_nm);
  // The wheels' speed law must not undo it on the pair the body tips over (the front pair in a
  // stoppie, the hind pair in a wheelie): a wheel spinning faster than its decelerating
  // reference brakes, which tips a stoppie further (platform campaign, seed 23: the guard's
  // 8 Nm against 10 Nm of the speed law's braking, and the robot went over its front wheels).
  // There the reference is held on the guard's side of the wheel's own rate. The other pair is
  // in the air or nearly: its speed law keeps it from spinning up to its no-load speed.
  for (const model::Leg leg : model::kLegs) {
    const int j = model::jointIndex(leg, model::JointKind::Wheel);
    model::JointCommand& c = out[j];
    c.tau_ff += dtau;
    const bool pivot = side < 0.0 ? model::isFront(leg) : !model::isFront(leg);
    if (!pivot) continue;
    const double qd = sensors.joints[j].qd;
    c.qd_des = side < 0.0 ? std::max(c.qd_des, qd) : std::min(c.qd_des, qd);
  }
}

void PlanExecutor::keepLiftedPairInRange(model::JointCommands& out) const {
  const double margin = settings_.lifted_pair_margin_rad;
  for (const model::Leg leg : {model::Leg::LF, model::Leg::RF})
    for (const model::JointKind kind : {model::JointKind::HFE, model::JointKind::KFE}) {
      const int j = model::jointIndex(leg, kind);
      const model::JointSpec& spec = model_.joints()[j];
      out[j].q_des = std::clamp(out[j].q_des, spec.lower_rad + margin, spec.upper_rad - margin);
    }
}

void PlanExecutor::addHfeOffset(double offset, model::JointCommands& out) const {
  if (offset == 0.0) return;
  // A nose-up body swings its legs forward in the world; a positive HFE swings them back
  // (models/wheeljump.urdf), so the nose-up error is added.
  const double margin = settings_.joint_limit_margin_rad;
  for (int leg = 0; leg < model::kNumLegs; ++leg) {
    const int j = model::jointIndex(static_cast<model::Leg>(leg), model::JointKind::HFE);
    const model::JointSpec& spec = model_.joints()[j];
    out[j].q_des =
        std::clamp(out[j].q_des + offset, spec.lower_rad + margin, spec.upper_rad - margin);
  }
}

void PlanExecutor::blendToLanding(double t, model::JointCommands& out) const {
  // Quintic from the measured position and speed at take-off to q_landing at rest, zero
  // acceleration at both ends: q = q0 + v0 T u + b3 u^3 + b4 u^4 + b5 u^5, u = t / T. It
  // overshoots when the legs still move fast, so it is kept inside the joint range.
  const double T = settings_.flight_blend_s;
  const double u = std::clamp((t - flight_start_) / T, 0.0, 1.0);
  for (int j = 0; j < model::kNumJoints; ++j) {
    const double v0 = qd_flight_start_[j];
    const double D = plan_.q_landing[j] - q_flight_start_[j] - v0 * T;
    const double V = -v0 * T;
    const double b3 = 10.0 * D - 4.0 * V, b4 = 7.0 * V - 15.0 * D, b5 = 6.0 * D - 3.0 * V;
    const double q = q_flight_start_[j] + v0 * T * u + u * u * u * (b3 + u * (b4 + u * b5));
    const double qd = v0 + u * u * (3.0 * b3 + u * (4.0 * b4 + u * 5.0 * b5)) / T;
    const model::JointSpec& spec = model_.joints()[j];
    const double margin = settings_.joint_limit_margin_rad;
    out[j].q_des =
        spec.continuous ? q : std::clamp(q, spec.lower_rad + margin, spec.upper_rad - margin);
    out[j].qd_des = u < 1.0 ? qd : 0.0;
  }
}

bool PlanExecutor::finished(double t) const {
  return phase_ == JumpPhase::Landing && t >= landing_start_ + settings_.landing_duration_s - 1e-12;
}

}  // namespace wj::sim
