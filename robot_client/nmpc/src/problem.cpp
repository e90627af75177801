#include "nmpc/problem.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace wj::nmpc {

namespace {

void requireNonNegative(const std::array<double, 3>& w, const char* name) {
  for (const double v : w)
    if (!(v >= 0.0)) throw std::invalid_argument(std::string("ProblemSettings.") + name + " < 0");
}

void requireBarrier(const BarrierSettings& b, const char* name) {
  if (!(b.mu > 0.0) || !(b.delta > 0.0))
    throw std::invalid_argument(std::string("ProblemSettings.") + name +
                                ": mu and delta must be > 0");
}

// Swing spline of `leg` at t: lift-off and touchdown heights blended by the quintic
// smoothstep sigma(s) = 10 s^3 - 15 s^4 + 6 s^5, plus the bump H 64 s^3 (1 - s)^3 (paper
// Eq. 7 is its derivative along the normal). Zero in contact.
void calcSwingTarget(const Targets& targets, int leg, double t, double& height, double& velocity) {
  height = velocity = 0.0;
  double t0 = 0.0, t1 = 0.0;
  if (!targets.gait.calcSwingInterval(leg, t, t0, t1)) return;
  double h0 = 0.0, h1 = 0.0;
  for (int i = 0; i < targets.num_swings[leg]; ++i) {
    const SwingHeights& sw = targets.swings[leg][i];
    if (std::abs(sw.t_liftoff - t0) < 1e-9 && std::abs(sw.t_touchdown - t1) < 1e-9) {
      h0 = sw.h_liftoff;
      h1 = sw.h_touchdown;
    }
  }
  const double T = t1 - t0, s = (t - t0) / T, H = targets.gait.settings().swing_height_m;
  const double sigma = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
  const double dsigma = 30.0 * s * s * (1.0 - s) * (1.0 - s);
  height = (1.0 - sigma) * h0 + sigma * h1 + H * 64.0 * std::pow(s * (1.0 - s), 3);
  velocity = (dsigma * (h1 - h0) + H * 192.0 * s * s * (1.0 - s) * (1.0 - s) * (1.0 - 2.0 * s)) / T;
}

}  // namespace

double calcTerrainHeight(const std::vector<TerrainBox>& boxes, double x, double y) {
  double h = 0.0;
  for (const TerrainBox& b : boxes)
    if (x >= b.x_min && x <= b.x_max && y >= b.y_min && y <= b.y_max) h = std::max(h, b.height);
  return h;
}

TerrainPlane TerrainPlane::flat(double height_m) {
  TerrainPlane p;
  p.point.z() = height_m;
  return p;
}

TerrainPlane TerrainPlane::slope(double slope_rad) {
  TerrainPlane p;
  p.normal = Eigen::Vector3d(-std::sin(slope_rad), 0.0, std::cos(slope_rad));
  return p;
}

double TerrainPlane::heightAt(double x, double y) const {
  // n . (p - point) = 0 solved for z.
  return point.z() - (normal.x() * (x - point.x()) + normal.y() * (y - point.y())) / normal.z();
}

State ReferenceTrajectory::interpolate(double t) const {
  if (times.empty()) return State::Zero();
  if (t <= times.front()) return states.front();
  if (t >= times.back()) return states.back();
  const auto it = std::upper_bound(times.begin(), times.end(), t);
  const std::size_t i = static_cast<std::size_t>(it - times.begin());
  const double a = (t - times[i - 1]) / (times[i] - times[i - 1]);
  return (1.0 - a) * states[i - 1] + a * states[i];
}

void ProblemSettings::validate() const {
  requireNonNegative(weight_orientation, "weight_orientation");
  requireNonNegative(weight_position, "weight_position");
  requireNonNegative(weight_angular_velocity, "weight_angular_velocity");
  requireNonNegative(weight_velocity, "weight_velocity");
  requireNonNegative(weight_joint_position, "weight_joint_position");
  for (const double w : weight_joint_velocity)
    if (!(w > 0.0))
      throw std::invalid_argument("ProblemSettings.weight_joint_velocity must be > 0");
  if (!(weight_force > 0.0))
    throw std::invalid_argument("ProblemSettings.weight_force must be > 0");
  if (!(terminal_weight_scale >= 0.0))
    throw std::invalid_argument("ProblemSettings.terminal_weight_scale must be >= 0");
  if (!(friction_coefficient > 0.0))
    throw std::invalid_argument("ProblemSettings.friction_coefficient must be > 0");
  if (!(friction_regularization_n2 > 0.0))
    throw std::invalid_argument("ProblemSettings.friction_regularization_n2 must be > 0");
  requireBarrier(friction_barrier, "friction_barrier");
  requireBarrier(joint_limit_barrier, "joint_limit_barrier");
  requireBarrier(joint_speed_barrier, "joint_speed_barrier");
  if (!(joint_speed_fraction > 0.0 && joint_speed_fraction <= 1.0))
    throw std::invalid_argument("ProblemSettings.joint_speed_fraction must be in (0, 1]");
  if (!(swing_position_gain >= 0.0))
    throw std::invalid_argument("ProblemSettings.swing_position_gain must be >= 0");
}

CentroidalOcp::CentroidalOcp(CentroidalModel model, const ProblemSettings& settings)
    : model_(std::move(model)), settings_(settings) {
  settings_.validate();
  for (int i = 0; i < 3; ++i) {
    q_diag_[state_index::kTheta + i] = settings_.weight_orientation[i];
    q_diag_[state_index::kPos + i] = settings_.weight_position[i];
    q_diag_[state_index::kOmega + i] = settings_.weight_angular_velocity[i];
    q_diag_[state_index::kVel + i] = settings_.weight_velocity[i];
  }
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int j = 0; j < kLegDofs; ++j) {
      q_diag_[state_index::joints(leg) + j] = settings_.weight_joint_position[j];
      r_diag_[input_index::jointVel(leg) + j] = settings_.weight_joint_velocity[j];
    }
  r_diag_.head<3 * kNumLegs>().setConstant(settings_.weight_force);
}

NodeTargets CentroidalOcp::calcNodeTargets(const Targets& targets, double t) const {
  NodeTargets node;
  node.t = t;
  node.contact = targets.gait.contactFlags(t);
  node.normal = targets.terrain.normal;
  node.terrain_point = targets.terrain.point;
  node.x_ref = targets.reference.interpolate(t);
  // Footholds off the hip: the swinging leg's joint reference blends to the foothold posture.
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int i = 0; i < targets.num_swings[leg]; ++i) {
      const SwingHeights& sw = targets.swings[leg][i];
      if (!sw.has_foothold || t < sw.t_liftoff || t >= sw.t_release) continue;
      const double s = std::clamp((t - sw.t_liftoff) / (sw.t_touchdown - sw.t_liftoff), 0.0, 1.0);
      const double sigma = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
      auto q = node.x_ref.segment<kLegDofs>(state_index::joints(leg));
      q = (1.0 - sigma) * q + sigma * sw.q_foothold;
    }
  int stance = 0;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    calcSwingTarget(targets, leg, t, node.swing_height[leg], node.swing_normal_velocity[leg]);
    stance += node.contact[leg] ? 1 : 0;
  }
  node.u_ref.setZero();
  if (stance > 0) {
    const Eigen::Vector3d f = -model_.mass() * model_.gravity() / stance;
    for (int leg = 0; leg < kNumLegs; ++leg)
      if (node.contact[leg]) node.u_ref.segment<3>(input_index::force(leg)) = f;
  }
  return node;
}

int CentroidalOcp::numEqualities(const ContactFlags& contact) {
  int m = 0;
  for (const bool c : contact) m += c ? 2 : 4;
  return m;
}

double CentroidalOcp::calcSwingHeightError(const NodeTargets& node, int leg, const State& x,
                                           const ModelData& data) const {
  const Eigen::Vector3d p = model_.calcWheelCenter(leg, x, data);
  return model_.wheelRadius() + node.swing_height[leg] - node.normal.dot(p - node.terrain_point);
}

double CentroidalOcp::calcFrictionMargin(const Eigen::Vector3d& f, const Eigen::Vector3d& n) const {
  const double fn = n.dot(f);
  const Eigen::Vector3d ft = f - fn * n;
  return settings_.friction_coefficient * fn -
         std::sqrt(ft.squaredNorm() + settings_.friction_regularization_n2);
}

double CentroidalOcp::calcStageCost(const NodeTargets& node, const State& x, const Input& u) const {
  const State dx = x - node.x_ref;
  const Input du = u - node.u_ref;
  double l = 0.5 * dx.dot(q_diag_.cwiseProduct(dx)) + 0.5 * du.dot(r_diag_.cwiseProduct(du));
  for (int leg = 0; leg < kNumLegs; ++leg)
    if (node.contact[leg])
      l +=
          evalRelaxedBarrier(settings_.friction_barrier,
                             calcFrictionMargin(u.segment<3>(input_index::force(leg)), node.normal))
              .value;
  const LegJointVector& lo = model_.jointLower();
  const LegJointVector& hi = model_.jointUpper();
  const LegJointVector& qd_max = model_.jointSpeedLimit();
  for (int j = 0; j < kNumLegJoints; ++j) {
    const double q = x[state_index::kJoints + j], qd = u[input_index::kJointVel + j];
    const double qd_lim = settings_.joint_speed_fraction * qd_max[j];
    l += evalRelaxedBarrier(settings_.joint_limit_barrier, q - lo[j]).value +
         evalRelaxedBarrier(settings_.joint_limit_barrier, hi[j] - q).value +
         evalRelaxedBarrier(settings_.joint_speed_barrier, qd_lim - qd).value +
         evalRelaxedBarrier(settings_.joint_speed_barrier, qd_lim + qd).value;
  }
  return l;
}

void CentroidalOcp::calcStageCostQuadratic(const NodeTargets& node, const State& x, const Input& u,
                                           CostQuadratic& out) const {
  const State dx = x - node.x_ref;
  const Input du = u - node.u_ref;
  out.value = 0.5 * dx.dot(q_diag_.cwiseProduct(dx)) + 0.5 * du.dot(r_diag_.cwiseProduct(du));
  out.dx = q_diag_.cwiseProduct(dx);
  out.du = r_diag_.cwiseProduct(du);
  out.dxx = q_diag_.asDiagonal();
  out.duu = r_diag_.asDiagonal();
  out.duu_block_diagonal = true;
  // Friction cones: h = mu n.f - sqrt(|P f|^2 + eps), P = I - n n^T.
  const Eigen::Vector3d& n = node.normal;
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - n * n.transpose();
  for (int leg = 0; leg < kNumLegs; ++leg) {
    if (!node.contact[leg]) continue;
    const int i = input_index::force(leg);
    const Eigen::Vector3d f = u.segment<3>(i);
    const Eigen::Vector3d ft = P * f;
    const double S = std::sqrt(ft.squaredNorm() + settings_.friction_regularization_n2);
    const double h = settings_.friction_coefficient * n.dot(f) - S;
    const Eigen::Vector3d dh = settings_.friction_coefficient * n - ft / S;
    const Eigen::Matrix3d d2h = -(P / S - ft * ft.transpose() / (S * S * S));
    const BarrierValue b = evalRelaxedBarrier(settings_.friction_barrier, h);
    out.value += b.value;
    out.du.segment<3>(i) += b.d1 * dh;
    out.duu.block<3, 3>(i, i) += b.d2 * dh * dh.transpose() + b.d1 * d2h;
  }
  // Joint position and speed limits (linear constraints).
  const LegJointVector& lo = model_.jointLower();
  const LegJointVector& hi = model_.jointUpper();
  const LegJointVector& qd_max = model_.jointSpeedLimit();
  for (int j = 0; j < kNumLegJoints; ++j) {
    const int ix = state_index::kJoints + j, iu = input_index::kJointVel + j;
    const double q = x[ix], qd = u[iu];
    const double qd_lim = settings_.joint_speed_fraction * qd_max[j];
    const BarrierValue bl = evalRelaxedBarrier(settings_.joint_limit_barrier, q - lo[j]);
    const BarrierValue bh = evalRelaxedBarrier(settings_.joint_limit_barrier, hi[j] - q);
    const BarrierValue sl = evalRelaxedBarrier(settings_.joint_speed_barrier, qd_lim + qd);
    const BarrierValue sh = evalRelaxedBarrier(settings_.joint_speed_barrier, qd_lim - qd);
    out.value += bl.value + bh.value + sl.value + sh.value;
    out.dx[ix] += bl.d1 - bh.d1;
    out.dxx(ix, ix) += bl.d2 + bh.d2;
    out.du[iu] += sl.d1 - sh.d1;
    out.duu(iu, iu) += sl.d2 + sh.d2;
  }
}

double CentroidalOcp::calcTerminalCost(const NodeTargets& node, const State& x) const {
  const State dx = x - node.x_ref;
  return 0.5 * settings_.terminal_weight_scale * dx.dot(q_diag_.cwiseProduct(dx));
}

void CentroidalOcp::calcTerminalCostQuadratic(const NodeTargets& node, const State& x,
                                              CostQuadratic& out) const {
  const State dx = x - node.x_ref;
  const double s = settings_.terminal_weight_scale;
  out.value = 0.5 * s * dx.dot(q_diag_.cwiseProduct(dx));
  out.dx = s * q_diag_.cwiseProduct(dx);
  out.dxx = (s * q_diag_).asDiagonal();
  out.du.setZero();
  out.duu.setZero();
}

void CentroidalOcp::calcEqualities(const NodeTargets& node, const State& x, const Input& u,
                                   const ModelData& data, EqVector& g) const {
  g.resize(numEqualities(node.contact));
  const Eigen::Vector3d& n = node.normal;
  int row = 0;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const Eigen::Vector3d v = model_.calcWheelVelocity(leg, x, u, data);
    if (node.contact[leg]) {
      // Rolling without slip: no velocity along the normal nor the binormal (the wheel axis
      // projected on the ground; unnormalised, it keeps the constraint smooth).
      const Eigen::Vector3d a = model_.calcWheelAxis(leg, data);
      const Eigen::Vector3d b = a - a.dot(n) * n;
      g[row++] = n.dot(v);
      g[row++] = b.dot(v);
    } else {
      g.segment<3>(row) = u.segment<3>(input_index::force(leg));
      row += 3;
      g[row++] = n.dot(v) - node.swing_normal_velocity[leg] -
                 settings_.swing_position_gain * calcSwingHeightError(node, leg, x, data);
    }
  }
}

void CentroidalOcp::calcEqualitiesLinear(const NodeTargets& node, const State& x, const Input& u,
                                         const ModelData& data, EqualityLinearization& out) const {
  const int m = numEqualities(node.contact);
  out.g.resize(m);
  out.C.setZero(m, kStateDim);
  out.D.setZero(m, kInputDim);
  const Eigen::Vector3d& n = node.normal;
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - n * n.transpose();
  WheelVelocity wv;
  int row = 0;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    model_.calcWheelVelocityJacobians(leg, x, u, data, wv);
    const int iqd = input_index::jointVel(leg);
    if (node.contact[leg]) {
      const Eigen::Vector3d a = model_.calcWheelAxis(leg, data);
      const Eigen::Vector3d b = P * a;
      out.g[row] = n.dot(wv.v);
      out.C.row(row) = n.transpose() * wv.dx;
      out.D.block<1, 3>(row, iqd) = n.transpose() * wv.dqd;
      ++row;
      out.g[row] = b.dot(wv.v);
      out.C.row(row) =
          b.transpose() * wv.dx + wv.v.transpose() * P * model_.calcWheelAxisJacobian(leg, data);
      out.D.block<1, 3>(row, iqd) = b.transpose() * wv.dqd;
      ++row;
    } else {
      out.g.segment<3>(row) = u.segment<3>(input_index::force(leg));
      out.D.block<3, 3>(row, input_index::force(leg)).setIdentity();
      row += 3;
      out.g[row] = n.dot(wv.v) - node.swing_normal_velocity[leg] -
                   settings_.swing_position_gain * calcSwingHeightError(node, leg, x, data);
      // d(height error)/dx = -n' d(p_wheel)/dx; p_wheel = p + R s(q).
      Eigen::Matrix<double, 1, kStateDim> dp = Eigen::Matrix<double, 1, kStateDim>::Zero();
      dp.segment<3>(state_index::kPos) = n.transpose();
      for (int i = 0; i < 3; ++i) dp[state_index::kTheta + i] = n.dot(data.dR[i] * data.s_B[leg]);
      dp.segment<kLegDofs>(state_index::joints(leg)) = n.transpose() * data.R * data.legs[leg].J;
      out.C.row(row) = n.transpose() * wv.dx + settings_.swing_position_gain * dp;
      out.D.block<1, 3>(row, iqd) = n.transpose() * wv.dqd;
      ++row;
    }
  }
}

}  // namespace wj::nmpc
