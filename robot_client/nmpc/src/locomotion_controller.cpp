#include "nmpc/locomotion_controller.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "nmpc/rotation.h"

namespace wj::nmpc {

void PostureIntegralSettings::validate() const {
  const auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("posture_integral.") + what);
  };
  require(gain_n_per_m_s >= 0.0 && gain_n_per_m_s <= 1e5, "gain_n_per_m_s must be in [0, 1e5]");
  require(max_force_n >= 0.0 && max_force_n <= 200.0, "max_force_n must be in [0, 200]");
  require(band_m > 0.0 && band_m <= 0.2, "band_m must be in (0, 0.2]");
  require(max_step_s > 0.0 && max_step_s <= 1.0, "max_step_s must be in (0, 1]");
}

LocomotionController::LocomotionController(const model::RobotModel& robot,
                                           const LocomotionSettings& settings)
    : settings_(settings),
      solver_(settings.sqp,
              CentroidalOcp(CentroidalModel(robot, settings.model), settings.problem)),
      reference_(solver_.problem().model(), settings.reference),
      whole_body_(robot, solver_.problem().model(), settings.whole_body),
      targets_{GaitSchedule(settings.gait, Gait::Roll), TerrainPlane{}, ReferenceTrajectory{}},
      exchange_(solver_.numIntervals()),
      policy_(solver_.numIntervals()) {
  settings_.posture_integral.validate();
  const CentroidalModel& m = model();
  for (int leg = 0; leg < kNumLegs; ++leg) {
    LegKinematics k;
    m.calcLegKinematics(leg, m.nominalJoints().segment<kLegDofs>(kLegDofs * leg), k);
    nominal_wheel_xy_[leg] = k.p_B.head<2>();
    nominal_wheel_z_[leg] = k.p_B.z();
  }
}

double LocomotionController::calcFootprintHeight(const Eigen::Vector3d& p) const {
  // Highest box under the wheel's extent along the heading (it rests on the highest point).
  const Eigen::Vector3d heading(std::cos(command_.yaw_rad), std::sin(command_.yaw_rad), 0.0);
  const double r = model().wheelRadius();
  double h = 0.0;
  for (int i = -2; i <= 2; ++i) {
    const Eigen::Vector3d q = p + 0.5 * i * r * heading;
    h = std::max(h, calcTerrainHeight(boxes_, q.x(), q.y()));
  }
  return h;
}

double LocomotionController::calcFootholdShift(const Eigen::Vector3d& p,
                                               double stance_travel) const {
  // Boxes are steps across the heading (edges at x_min along +x, the direction of travel).
  const double r = model().wheelRadius();
  const double margin = settings_.foothold_edge_margin_m;
  const double max_shift = settings_.max_foothold_offset_m;
  for (const TerrainBox& b : boxes_) {
    if (p.y() < b.y_min || p.y() > b.y_max) continue;
    // Wheel centres to avoid: on the edge, or short of it by less than a stance's roll.
    const double lo = b.x_min - r - stance_travel - margin, hi = b.x_min + margin;
    if (p.x() <= lo || p.x() >= hi) continue;
    const double forward = hi - p.x(), backward = lo - p.x();
    if (forward <= max_shift && forward <= -backward) return forward;
    if (-backward <= max_shift) return backward;
    return max_shift;  // neither fits: land as far onto the box as the leg allows
  }
  return 0.0;
}

void LocomotionController::updateTerrain(double t, const State& x) {
  const CentroidalModel& m = model();
  ModelData data;
  m.updateData(x, data);
  const Eigen::Vector3d& n = terrain_.normal;
  const ContactFlags contact = targets_.gait.contactFlags(t);
  targets_.terrain = terrain_;
  std::array<Eigen::Vector3d, kNumLegs> bottom;
  for (int leg = 0; leg < kNumLegs; ++leg)
    bottom[leg] = m.calcWheelCenter(leg, x, data) - m.wheelRadius() * n;
  if (!boxes_.empty()) {
    // Known terrain: the plane sits at the mean box height under the wheels.
    double mean = 0.0;
    for (int leg = 0; leg < kNumLegs; ++leg)
      mean += calcTerrainHeight(boxes_, bottom[leg].x(), bottom[leg].y()) / kNumLegs;
    targets_.terrain.point += mean * n;
  } else if (settings_.estimate_terrain_height) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int count = 0;
    for (int leg = 0; leg < kNumLegs; ++leg)
      if (contact[leg]) {
        sum += bottom[leg];
        ++count;
      }
    if (count > 0) targets_.terrain.point = sum / count;
  }
  // Swing heights above this cycle's plane: box tops where the wheel lifts off and where it
  // will land (under its hip at touchdown, the nominal posture); zero without boxes.
  const double offset = n.dot(terrain_.point - targets_.terrain.point);
  const double horizon = settings_.sqp.horizon_s;
  const Eigen::Vector3d heading(std::cos(command_.yaw_rad), std::sin(command_.yaw_rad), 0.0);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    targets_.num_swings[leg] = 0;
    if (boxes_.empty()) continue;
    if (contact[leg]) last_stance_height_[leg] = calcFootprintHeight(bottom[leg]);
    // A foothold of the last swing stays in the joint reference until the next lift-off.
    const SwingHeights& held = held_swing_[leg];
    if (held.has_foothold && t >= held.t_touchdown && t < held.t_release)
      targets_.swings[leg][targets_.num_swings[leg]++] = held;
    const double dt = solver_.dt();
    double last_t0 = -1e300;
    for (double tk = t; tk <= t + horizon && targets_.num_swings[leg] < kMaxSwingsPerLeg;
         tk += dt) {
      double t0 = 0.0, t1 = 0.0;
      if (!targets_.gait.calcSwingInterval(leg, tk, t0, t1) || t0 == last_t0) continue;
      last_t0 = t0;
      SwingHeights& sw = targets_.swings[leg][targets_.num_swings[leg]++];
      sw.t_liftoff = t0;
      sw.t_touchdown = t1;
      sw.has_foothold = false;
      if (t0 <= t) {
        sw.h_liftoff = last_stance_height_[leg] + offset;
      } else {
        const Eigen::Vector3d p = bottom[leg] + command_.distance(t, t0) * heading;
        sw.h_liftoff = calcFootprintHeight(p) + offset;
      }
      const State x_ref = targets_.reference.interpolate(t1);
      const Eigen::Matrix3d R = calcRotation(x_ref.segment<3>(state_index::kTheta));
      const Eigen::Vector3d hip =
          x_ref.segment<3>(state_index::kPos) +
          R * (Eigen::Vector3d(nominal_wheel_xy_[leg].x(), nominal_wheel_xy_[leg].y(), 0.0) -
               m.comOffset());
      // The next lift-off ends the stance that follows this touchdown.
      double next0 = t1, next1 = t1;
      sw.t_release = t1 + 2.0 * (t1 - t0);
      for (double tn = t1; tn < t1 + 4.0 * (t1 - t0); tn += dt)
        if (targets_.gait.calcSwingInterval(leg, tn, next0, next1)) {
          sw.t_release = next0;
          break;
        }
      const double shift = settings_.adapt_footholds
                               ? calcFootholdShift(hip, command_.distance(t1, sw.t_release))
                               : 0.0;
      const Eigen::Vector3d landing = hip + shift * heading;
      sw.h_touchdown = calcFootprintHeight(landing) + offset;
      if (shift != 0.0) {
        // Joints that put the wheel `shift` ahead of the HFE axis (where the nominal posture
        // has it) with the base at its reference height above the landing surface.
        const Eigen::Vector3d base = x_ref.segment<3>(state_index::kPos) - R * m.comOffset();
        const double surface =
            terrain_.heightAt(landing.x(), landing.y()) + calcFootprintHeight(landing);
        sw.has_foothold = m.calcLegJoints(leg, base.z() - surface, shift, sw.q_foothold);
      }
      if (t0 <= t && t < t1) held_swing_[leg] = sw;
    }
  }
}

SqpStatus LocomotionController::updateMpc(double t, const State& x) {
  updateTerrain(t, x);
  reference_.update(t, x, command_, targets_.terrain, settings_.sqp.horizon_s, targets_.reference);
  // The touchdown heights need the reference: plan the swings once more with it.
  if (!boxes_.empty()) updateTerrain(t, x);
  const SqpStatus status = solver_.solve(t, x, targets_);
  exchange_.publish(solver_.policy());
  return status;
}

void LocomotionController::calcCommands(double t, const State& x, const model::SensorData& sensors,
                                        model::JointCommands& out) {
  exchange_.fetch(policy_);
  const ContactFlags contact = policy_.calcContact(t);
  whole_body_.calcCommands(t, policy_, x, sensors, contact, policy_.normal(), out, last_output_);
  addPostureIntegral(t, x, contact, sensors, out);
}

namespace {

// The measured HAA, HFE and KFE of `leg`.
Eigen::Vector3d measuredLegJoints(const model::SensorData& sensors, int leg) {
  Eigen::Vector3d q;
  for (int j = 0; j < kLegDofs; ++j) q[j] = sensors.joints[robotJointIndex(leg, j)].q;
  return q;
}

// The ground's extra push `f_B` (in B) on the wheel of `leg`: its joints' torques -J^T f.
void addWheelForce(int leg, const LegKinematics& k, const Eigen::Vector3d& f_B,
                   model::JointCommands& out) {
  const Eigen::Vector3d tau = -k.J.transpose() * f_B;
  for (int j = 0; j < kLegDofs; ++j) out[robotJointIndex(leg, j)].tau_ff += tau[j];
}

Eigen::Vector3d upInBase(const State& x) {
  return calcRotation(x.segment<3>(state_index::kTheta)).transpose() * Eigen::Vector3d::UnitZ();
}

}  // namespace

void LocomotionController::addPostureIntegral(double t, const State& x, const ContactFlags& contact,
                                              const model::SensorData& sensors,
                                              model::JointCommands& out) {
  const PostureIntegralSettings& s = settings_.posture_integral;
  if (s.gain_n_per_m_s == 0.0) return;
  const double dt = t - posture_t_;
  posture_t_ = t;
  const bool integrate = dt > 0.0 && dt <= s.max_step_s &&
                         std::all_of(contact.begin(), contact.end(), [](bool c) { return c; });
  const Eigen::Vector3d up_B = upInBase(x);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    if (!contact[leg]) continue;
    LegKinematics k;
    model().calcLegKinematics(leg, measuredLegJoints(sensors, leg), k);
    // Compression: the wheel higher under the base than in the nominal posture.
    const double e = k.p_B.z() - nominal_wheel_z_[leg];
    double& f = posture_integral_[leg];
    if (integrate && std::abs(e) <= s.band_m)
      f = std::clamp(f + s.gain_n_per_m_s * dt * e, -s.max_force_n, s.max_force_n);
    if (f != 0.0) addWheelForce(leg, k, f * up_B, out);
  }
}

void LocomotionController::addLegSupport(const State& x, const model::SensorData& sensors,
                                         const ContactFlags& legs, double scale,
                                         model::JointCommands& out) const {
  const Eigen::Vector3d up_B = upInBase(x);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    if (!legs[leg] || posture_integral_[leg] == 0.0) continue;
    LegKinematics k;
    model().calcLegKinematics(leg, measuredLegJoints(sensors, leg), k);
    addWheelForce(leg, k, scale * posture_integral_[leg] * up_B, out);
  }
}

}  // namespace wj::nmpc
