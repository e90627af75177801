#include "estimator/state_estimator.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace wj::estimation {
namespace {

using model::JointKind;
using model::kJointsPerLeg;
using model::kNumLegs;

bool allFinite(const Eigen::Vector3d& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

}  // namespace

const char* toString(Divergence reason) {
  switch (reason) {
    case Divergence::None:
      return "none";
    case Divergence::NonFiniteInput:
      return "non_finite_input";
    case Divergence::NonFiniteState:
      return "non_finite_state";
    case Divergence::CovarianceBlowUp:
      return "covariance_blow_up";
    case Divergence::InnovationsRejected:
      return "innovations_rejected";
    case Divergence::SpeedLimit:
      return "speed_limit";
  }
  return "unknown";
}

StateEstimator::StateEstimator(const model::RobotModel& model, const EstimatorSettings& settings)
    : settings_(settings),
      wheel_radius_(model.wheelRadius()),
      ground_height_m_(settings.ground_height_m) {
  settings_.validate();
  for (const model::Leg leg : model::kLegs) {
    LegChain& chain = legs_[static_cast<int>(leg)];
    int parent_link = 0;  // the base
    for (int k = 0; k < kJointsPerLeg; ++k) {
      const model::JointSpec& j = model.joint(leg, model::kJointKinds[k]);
      if (j.parent_link != parent_link)
        throw std::invalid_argument("StateEstimator: joint " + j.name +
                                    " does not continue the leg chain base-HAA-HFE-KFE-WHEEL");
      chain.X_PJ[k] = j.X_PJ;
      chain.axis[k] = j.axis.normalized();
      parent_link = j.child_link;
    }
  }
  reset(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
}

void StateEstimator::reset(const Eigen::Vector3d& p_WB, const Eigen::Vector3d& v_WB) {
  x_.head<3>() = p_WB;
  x_.tail<3>() = v_WB;
  P_.setZero();
  P_.diagonal().head<3>().setConstant(settings_.initial_position_std_m *
                                      settings_.initial_position_std_m);
  P_.diagonal().tail<3>().setConstant(settings_.initial_velocity_std_m_s *
                                      settings_.initial_velocity_std_m_s);
  divergence_ = Divergence::None;
  consecutive_rejections_ = 0;
  rejected_ = 0;
  state_.p_WB = p_WB;
  state_.v_WB = v_WB;
  state_.covariance_diagonal = P_.diagonal();
  state_.velocity_used.fill(false);
}

void StateEstimator::calcWheelKinematics(model::Leg leg, const model::JointMeasurements& joints,
                                         Eigen::Vector3d& p_BW, Eigen::Vector3d& v_BW_rel,
                                         Eigen::Vector3d& axis_B,
                                         Eigen::Vector3d& omega_rel_B) const {
  const LegChain& chain = legs_[static_cast<int>(leg)];
  const int first = model::jointIndex(leg, JointKind::HAA);
  // Forward pass: joint origins and axes in B for the three leg joints, then the wheel frame.
  std::array<Eigen::Vector3d, 3> origin;
  std::array<Eigen::Vector3d, 3> axis;
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  for (int k = 0; k < 3; ++k) {
    X = X * chain.X_PJ[k];
    origin[k] = X.translation();
    axis[k] = X.linear() * chain.axis[k];
    X.linear() = X.linear() * Eigen::AngleAxisd(joints[first + k].q, chain.axis[k]).matrix();
  }
  X = X * chain.X_PJ[3];
  p_BW = X.translation();
  axis_B = X.linear() * chain.axis[3];
  v_BW_rel.setZero();
  omega_rel_B.setZero();
  for (int k = 0; k < 3; ++k) {
    const double qd = joints[first + k].qd;
    v_BW_rel += axis[k].cross(p_BW - origin[k]) * qd;  // J q̇, column k = a_k x (p - o_k)
    omega_rel_B += axis[k] * qd;
  }
  omega_rel_B += axis_B * joints[first + 3].qd;  // wheel spin
}

void StateEstimator::predict(const Eigen::Matrix3d& R_WB, const Eigen::Vector3d& accel_B,
                             double dt) {
  const Eigen::Vector3d a_W = R_WB * accel_B - Eigen::Vector3d(0.0, 0.0, settings_.gravity_m_s2);
  x_.head<3>() += x_.tail<3>() * dt + 0.5 * a_W * dt * dt;
  x_.tail<3>() += a_W * dt;
  // P = F P F^T + Q with F = [I dt I; 0 I], written out by blocks.
  const Eigen::Matrix3d Ppp = P_.topLeftCorner<3, 3>();
  const Eigen::Matrix3d Ppv = P_.topRightCorner<3, 3>();
  const Eigen::Matrix3d Pvv = P_.bottomRightCorner<3, 3>();
  const double qp = settings_.position_noise_density * settings_.position_noise_density * dt;
  const double qv = settings_.accel_noise_density * settings_.accel_noise_density * dt;
  P_.topLeftCorner<3, 3>() = Ppp + dt * (Ppv + Ppv.transpose()) + dt * dt * Pvv;
  P_.topRightCorner<3, 3>() = Ppv + dt * Pvv;
  P_.bottomLeftCorner<3, 3>() = P_.topRightCorner<3, 3>().transpose();
  P_.diagonal().head<3>().array() += qp;
  P_.diagonal().tail<3>().array() += qv;
}

bool StateEstimator::correctVelocity(const Eigen::Vector3d& v_meas) {
  // z = v + noise: H = [0 I].
  const double r = settings_.wheel_velocity_std_m_s * settings_.wheel_velocity_std_m_s;
  const Eigen::Vector3d innovation = v_meas - x_.tail<3>();
  const Eigen::Matrix3d S = P_.bottomRightCorner<3, 3>() + r * Eigen::Matrix3d::Identity();
  const Eigen::LLT<Eigen::Matrix3d> llt(S);
  if (llt.info() != Eigen::Success) return false;
  const double d2 = innovation.dot(llt.solve(innovation));
  if (!(d2 <= settings_.velocity_gate_chi2)) return false;
  const Eigen::Matrix<double, 6, 3> PHt = P_.rightCols<3>();
  const Eigen::Matrix<double, 6, 3> K = llt.solve(PHt.transpose()).transpose();
  x_ += K * innovation;
  // Joseph form: P = (I - K H) P (I - K H)^T + K R K^T, symmetric and positive by construction.
  Matrix6 IKH = Matrix6::Identity();
  IKH.rightCols<3>() -= K;
  P_ = IKH * P_ * IKH.transpose() + r * K * K.transpose();
  return true;
}

void StateEstimator::correctHeight(double z_meas) {
  // z = p_z + noise: H = e_3.
  const double r = settings_.wheel_height_std_m * settings_.wheel_height_std_m;
  const double innovation = z_meas - x_(2);
  const double S = P_(2, 2) + r;
  if (!(innovation * innovation <= settings_.height_gate_chi2 * S)) return;
  const Vector6 K = P_.col(2) / S;
  x_ += K * innovation;
  Matrix6 IKH = Matrix6::Identity();
  IKH.col(2) -= K;
  P_ = IKH * P_ * IKH.transpose() + r * K * K.transpose();
}

double StateEstimator::correctPositionX(double x_meas, double std_m) {
  if (diverged() || !std::isfinite(x_meas) || !(std_m > 0.0)) return 0.0;
  // z = p_x + noise: H = e_1.
  const double r = std_m * std_m;
  const double innovation = x_meas - x_(0);
  const double S = P_(0, 0) + r;
  const Vector6 K = P_.col(0) / S;
  x_ += K * innovation;
  Matrix6 IKH = Matrix6::Identity();
  IKH.col(0) -= K;
  P_ = IKH * P_ * IKH.transpose() + r * K * K.transpose();
  checkHealth();
  state_.p_WB = x_.head<3>();
  state_.v_WB = x_.tail<3>();
  state_.covariance_diagonal = P_.diagonal();
  return innovation;
}

void StateEstimator::checkHealth() {
  if (!x_.allFinite() || !P_.allFinite()) {
    divergence_ = Divergence::NonFiniteState;
  } else if (P_.diagonal().tail<3>().maxCoeff() >
             settings_.max_velocity_std_m_s * settings_.max_velocity_std_m_s) {
    divergence_ = Divergence::CovarianceBlowUp;
  } else if (x_.tail<3>().norm() > settings_.max_speed_m_s) {
    divergence_ = Divergence::SpeedLimit;
  } else if (consecutive_rejections_ >= settings_.max_consecutive_rejections) {
    divergence_ = Divergence::InnovationsRejected;
  }
}

void StateEstimator::update(const model::SensorData& sensors,
                            const std::array<bool, kNumLegs>& wheel_contact, double dt) {
  const model::ImuReading& imu = sensors.imu;
  state_.t = sensors.t;
  state_.velocity_used.fill(false);
  bool finite = std::isfinite(dt) && imu.q_WB.coeffs().allFinite() && allFinite(imu.omega_B) &&
                allFinite(imu.accel_B) && imu.q_WB.coeffs().squaredNorm() > 0.25;
  for (int leg = 0; leg < kNumLegs && finite; ++leg) {
    if (!wheel_contact[leg]) continue;
    for (int k = 0; k < kJointsPerLeg; ++k) {
      const model::JointMeasurement& m = sensors.joints[leg * kJointsPerLeg + k];
      finite = finite && std::isfinite(m.q) && std::isfinite(m.qd);
    }
  }
  if (!finite && divergence_ == Divergence::None) divergence_ = Divergence::NonFiniteInput;
  if (finite) {
    state_.q_WB = imu.q_WB.normalized();
    state_.omega_B = imu.omega_B;
    state_.omega_W = state_.q_WB * imu.omega_B;
  }
  if (diverged()) return;

  const Eigen::Matrix3d R_WB = state_.q_WB.toRotationMatrix();
  if (dt > 0.0) predict(R_WB, imu.accel_B, dt);

  // Ground normal in B (flat ground: +z of W).
  const Eigen::Vector3d n_B = R_WB.transpose().col(2);
  int in_contact = 0, accepted = 0;
  for (const model::Leg leg : model::kLegs) {
    const int l = static_cast<int>(leg);
    if (!wheel_contact[l]) continue;
    ++in_contact;
    Eigen::Vector3d p_BW, v_rel_B, axis_B, omega_rel_B;
    calcWheelKinematics(leg, sensors.joints, p_BW, v_rel_B, axis_B, omega_rel_B);
    // Contact point: the lowest point of the wheel rim, from the centre along the ground
    // normal projected into the wheel plane (for an upright wheel: straight down).
    Eigen::Vector3d down = -(n_B - n_B.dot(axis_B) * axis_B);
    const double norm = down.norm();
    if (norm < 0.2) continue;  // wheel lying nearly flat: no rolling contact to measure
    const Eigen::Vector3d rho_B = wheel_radius_ / norm * down;
    // The material point of the wheel at the contact does not move (rolling without slip):
    //   R^T v_WB + omega_B x p_BW + J qd + (omega_B + omega_rel) x rho = 0.
    const Eigen::Vector3d omega_wheel_B = imu.omega_B + omega_rel_B;
    const Eigen::Vector3d v_meas =
        -(R_WB * (imu.omega_B.cross(p_BW) + v_rel_B + omega_wheel_B.cross(rho_B)));
    state_.wheel_velocity_W[l] = v_meas;
    if (correctVelocity(v_meas)) {
      state_.velocity_used[l] = true;
      ++accepted;
    } else {
      ++rejected_;
    }
    // The contact point lies on the ground: p_z + (R (p_BW + rho))_z = ground height.
    correctHeight(ground_height_m_ - R_WB.row(2).dot(p_BW + rho_B));
  }
  if (in_contact > 0 && accepted == 0)
    ++consecutive_rejections_;
  else if (accepted > 0)
    consecutive_rejections_ = 0;
  checkHealth();

  state_.p_WB = x_.head<3>();
  state_.v_WB = x_.tail<3>();
  state_.covariance_diagonal = P_.diagonal();
}

}  // namespace wj::estimation
