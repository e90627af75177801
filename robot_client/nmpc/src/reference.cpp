#include "nmpc/reference.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "nmpc/rotation.h"

namespace wj::nmpc {

namespace {

// Integral of the speed from t_start_s to t (negative before t_start_s).
double cumulativeDistance(const SpeedCommand& c, double t) {
  const double dv = c.v_target_m_s - c.v_start_m_s;
  const double ramp = std::abs(dv) / c.acceleration_m_s2;
  const double a = dv >= 0.0 ? c.acceleration_m_s2 : -c.acceleration_m_s2;
  if (t <= c.t_start_s) return c.v_start_m_s * (t - c.t_start_s);
  const double tau = std::min(t - c.t_start_s, ramp);
  double s = c.v_start_m_s * tau + 0.5 * a * tau * tau;
  if (t - c.t_start_s > ramp) s += c.v_target_m_s * (t - c.t_start_s - ramp);
  return s;
}

}  // namespace

double SpeedCommand::speedAt(double t) const {
  if (t <= t_start_s) return v_start_m_s;
  const double dv = v_target_m_s - v_start_m_s;
  const double change = acceleration_m_s2 * (t - t_start_s);
  return std::abs(dv) <= change ? v_target_m_s : v_start_m_s + std::copysign(change, dv);
}

double SpeedCommand::distance(double t0, double t1) const {
  return cumulativeDistance(*this, t1) - cumulativeDistance(*this, t0);
}

void ReferenceSettings::validate() const {
  if (!(base_height_m > 0.0)) throw std::invalid_argument("ReferenceSettings.base_height_m > 0");
  if (samples < 2) throw std::invalid_argument("ReferenceSettings.samples must be >= 2");
}

ReferenceGenerator::ReferenceGenerator(const CentroidalModel& model,
                                       const ReferenceSettings& settings)
    : model_(model), settings_(settings) {
  settings_.validate();
}

Eigen::Vector3d ReferenceGenerator::calcTerrainAlignedEuler(const TerrainPlane& terrain,
                                                            double yaw_rad) {
  const Eigen::Vector3d& n = terrain.normal;
  const Eigen::Vector3d heading(std::cos(yaw_rad), std::sin(yaw_rad), 0.0);
  Eigen::Matrix3d R;
  R.col(0) = (heading - heading.dot(n) * n).normalized();
  R.col(2) = n;
  R.col(1) = n.cross(R.col(0));
  return calcEulerAngles(R, yaw_rad);
}

void ReferenceGenerator::update(double t0, const State& x0, const SpeedCommand& command,
                                const TerrainPlane& terrain, double horizon_s,
                                ReferenceTrajectory& out) const {
  const int n = settings_.samples;
  out.times.resize(static_cast<std::size_t>(n));
  out.states.resize(static_cast<std::size_t>(n));
  const double yaw0 = x0[state_index::kTheta + 2];
  const Eigen::Vector3d theta = calcTerrainAlignedEuler(terrain, command.yaw_rad);
  const Eigen::Matrix3d R_ref = calcRotation(theta);
  const Eigen::Vector3d direction = R_ref.col(0);
  const Eigen::Vector3d& normal = terrain.normal;
  // Base origin now, moved along the normal onto the reference height.
  const Eigen::Vector3d p_base =
      x0.segment<3>(state_index::kPos) -
      calcRotation(x0.segment<3>(state_index::kTheta)) * model_.comOffset();
  const Eigen::Vector3d p_start = p_base - normal.dot(p_base - terrain.point) * normal +
                                  settings_.base_height_m * normal + R_ref * model_.comOffset();
  for (int i = 0; i < n; ++i) {
    const double t = t0 + horizon_s * i / (n - 1);
    State& x = out.states[i];
    x.setZero();
    x.segment<3>(state_index::kTheta) = theta;
    x[state_index::kTheta + 2] +=
        2.0 * std::numbers::pi * std::round((yaw0 - theta.z()) / (2.0 * std::numbers::pi));
    x.segment<3>(state_index::kPos) = p_start + command.distance(t0, t) * direction;
    x.segment<3>(state_index::kVel) = command.speedAt(t) * direction;
    x.segment<kNumLegJoints>(state_index::kJoints) = model_.nominalJoints();
    out.times[i] = t;
  }
}

}  // namespace wj::nmpc
