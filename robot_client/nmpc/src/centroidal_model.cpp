#include "nmpc/centroidal_model.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "nmpc/rotation.h"

namespace wj::nmpc {

namespace {

Eigen::Vector3d segment3(const State& x, int i) {
  return x.segment<3>(i);
}

}  // namespace

void CentroidalModelSettings::validate() const {
  if (!(nominal_base_height_m > 0.0))
    throw std::invalid_argument("CentroidalModelSettings.nominal_base_height_m must be > 0");
  if (!(gravity_m_s2 >= 0.0))
    throw std::invalid_argument("CentroidalModelSettings.gravity_m_s2 must be >= 0");
}

CentroidalModel::CentroidalModel(const model::RobotModel& robot,
                                 const CentroidalModelSettings& settings)
    : settings_(settings) {
  settings_.validate();
  wheel_radius_ = robot.wheelRadius();
  for (int leg = 0; leg < kNumLegs; ++leg) {
    geometry_[leg] = robot.legGeometry(static_cast<model::Leg>(leg));
    for (int j = 0; j <= kLegDofs; ++j) {
      const model::JointSpec& spec = robot.joints()[robotJointIndex(leg, j)];
      chains_[leg].X_PJ[j] = spec.X_PJ;
      chains_[leg].axis[j] = spec.axis;
      if (j < kLegDofs) {
        q_lower_[kLegDofs * leg + j] = spec.lower_rad;
        q_upper_[kLegDofs * leg + j] = spec.upper_rad;
        qd_max_[kLegDofs * leg + j] = spec.actuator.no_load_speed_rad_s;
      }
    }
  }
  q_nominal_ = calcStandingJoints(settings_.nominal_base_height_m);
  Eigen::VectorXd q16 = Eigen::VectorXd::Zero(model::kNumJoints);
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int j = 0; j < kLegDofs; ++j)
      q16[robotJointIndex(leg, j)] = q_nominal_[kLegDofs * leg + j];
  const model::Inertia composite = robot.calcCompositeInertia(q16);
  mass_ = composite.mass;
  c_B_ = composite.com;
  inertia_ = composite.inertia_com;
  inertia_inv_ = inertia_.inverse();
}

bool CentroidalModel::calcLegJoints(int leg, double base_height_m, double x_offset_m,
                                    Eigen::Vector3d& q) const {
  const model::LegGeometry& g = geometry_[leg];
  const double l1 = g.thigh_length, l2 = g.shank_length;
  // Wheel centre relative to the HFE axis in the sagittal plane; with HFE angle q1 and KFE
  // angle q2 it is -(l1 sin q1 + l2 sin(q1 + q2), l1 cos q1 + l2 cos(q1 + q2)).
  const double px = x_offset_m;
  const double pz = -(base_height_m - wheel_radius_) - (g.p_BH.z() + g.p_HT.z());
  const double c2 = (px * px + pz * pz - l1 * l1 - l2 * l2) / (2.0 * l1 * l2);
  if (c2 < -1.0 || c2 > 1.0) return false;
  const double q2 = -std::acos(c2);  // knee backward
  const double q1 = std::atan2(-px, -pz) - std::atan2(l2 * std::sin(q2), l1 + l2 * std::cos(q2));
  const Eigen::Vector3d candidate(0.0, q1, q2);
  for (int j = 0; j < kLegDofs; ++j) {
    const int i = kLegDofs * leg + j;
    if (candidate[j] < q_lower_[i] || candidate[j] > q_upper_[i]) return false;
  }
  q = candidate;
  return true;
}

LegJointVector CentroidalModel::calcStandingJoints(double base_height_m, double x_offset_m) const {
  LegJointVector q = LegJointVector::Zero();
  for (int leg = 0; leg < kNumLegs; ++leg) {
    Eigen::Vector3d ql;
    if (!calcLegJoints(leg, base_height_m, x_offset_m, ql))
      throw std::invalid_argument("calcStandingJoints: base height " +
                                  std::to_string(base_height_m) + " m is out of reach");
    q.segment<kLegDofs>(kLegDofs * leg) = ql;
  }
  return q;
}

void CentroidalModel::calcLegKinematics(int leg, const Eigen::Vector3d& q_leg,
                                        LegKinematics& out) const {
  const Chain& c = chains_[leg];
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  std::array<Eigen::Vector3d, kLegDofs> z, o;
  for (int j = 0; j < kLegDofs; ++j) {
    p += R * c.X_PJ[j].translation();
    R = R * c.X_PJ[j].linear();
    o[j] = p;
    z[j] = R * c.axis[j];
    R = R * Eigen::AngleAxisd(q_leg[j], c.axis[j]).matrix();
  }
  p += R * c.X_PJ[kLegDofs].translation();
  R = R * c.X_PJ[kLegDofs].linear();
  out.p_B = p;
  out.axis_B = R * c.axis[kLegDofs];
  for (int j = 0; j < kLegDofs; ++j) {
    out.J.col(j) = z[j].cross(p - o[j]);
    out.joint_axes_B.col(j) = z[j];
  }
  // dJ_j/dq_k = z_k x J_j for k <= j (joint k moves joint j's axis and origin with the foot),
  // and z_j x J_k for k > j (only the foot moves).
  for (int k = 0; k < kLegDofs; ++k) {
    for (int j = 0; j < kLegDofs; ++j)
      out.dJ[k].col(j) = k <= j ? z[k].cross(out.J.col(j)) : z[j].cross(out.J.col(k));
    out.d_axis.col(k) = z[k].cross(out.axis_B);
  }
}

void CentroidalModel::updateData(const State& x, ModelData& data) const {
  const Eigen::Vector3d theta = segment3(x, state_index::kTheta);
  data.R = calcRotation(theta);
  data.dR = calcRotationDerivatives(theta);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    calcLegKinematics(leg, x.segment<kLegDofs>(state_index::joints(leg)), data.legs[leg]);
    data.s_B[leg] = data.legs[leg].p_B - c_B_;
  }
}

void CentroidalModel::calcFlowMap(const State& x, const Input& u, const Eigen::Vector3d& n,
                                  const ModelData& data, State& xdot) const {
  const Eigen::Vector3d theta = segment3(x, state_index::kTheta);
  const Eigen::Vector3d w = segment3(x, state_index::kOmega);
  const Eigen::Matrix3d& R = data.R;
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const Eigen::Vector3d f = u.segment<3>(input_index::force(leg));
    const Eigen::Vector3d lever = R * data.s_B[leg] - wheel_radius_ * n;  // CoM to contact
    force += f;
    torque += lever.cross(f);
  }
  const Eigen::Vector3d w_B = R.transpose() * w;
  const Eigen::Vector3d y = R.transpose() * torque - w_B.cross(inertia_ * w_B);
  xdot.segment<3>(state_index::kTheta) = calcEulerRates(theta, w);
  xdot.segment<3>(state_index::kPos) = x.segment<3>(state_index::kVel);
  xdot.segment<3>(state_index::kOmega) = R * (inertia_inv_ * y);  // Euler's equation in B
  xdot.segment<3>(state_index::kVel) = force / mass_ + gravity();
  xdot.segment<kNumLegJoints>(state_index::kJoints) =
      u.segment<kNumLegJoints>(input_index::kJointVel);
}

void CentroidalModel::calcFlowMapJacobians(const State& x, const Input& u, const Eigen::Vector3d& n,
                                           const ModelData& data, State& xdot, StateMatrix& A,
                                           StateInputMatrix& B) const {
  using namespace state_index;
  const Eigen::Vector3d theta = segment3(x, kTheta);
  const Eigen::Vector3d w = segment3(x, kOmega);
  const Eigen::Matrix3d& R = data.R;
  A.setZero();
  B.setZero();

  Eigen::Vector3d force = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();
  std::array<Eigen::Vector3d, 3> dtorque_dtheta{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                                                Eigen::Vector3d::Zero()};
  Eigen::Matrix<double, 3, kNumLegJoints> dtorque_dq;
  std::array<Eigen::Matrix3d, kNumLegs> lever_skew;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const Eigen::Vector3d f = u.segment<3>(input_index::force(leg));
    const Eigen::Vector3d lever = R * data.s_B[leg] - wheel_radius_ * n;
    force += f;
    torque += lever.cross(f);
    for (int k = 0; k < 3; ++k) dtorque_dtheta[k] += (data.dR[k] * data.s_B[leg]).cross(f);
    const Eigen::Matrix3d RJ = R * data.legs[leg].J;
    for (int j = 0; j < kLegDofs; ++j) dtorque_dq.col(kLegDofs * leg + j) = RJ.col(j).cross(f);
    lever_skew[leg] = skew(lever);
  }

  const Eigen::Vector3d w_B = R.transpose() * w;
  const Eigen::Vector3d Iw = inertia_ * w_B;
  const Eigen::Vector3d y = R.transpose() * torque - w_B.cross(Iw);
  const Eigen::Matrix3d RAi = R * inertia_inv_;
  const Eigen::Matrix3d M = RAi * R.transpose();  // inverse inertia in W

  // Euler angle rates.
  Eigen::Matrix3d d_theta, d_omega;
  calcEulerRatesJacobians(theta, w, d_theta, d_omega);
  xdot.segment<3>(kTheta) = calcEulerRates(theta, w);
  A.block<3, 3>(kTheta, kTheta) = d_theta;
  A.block<3, 3>(kTheta, kOmega) = d_omega;

  // Position.
  xdot.segment<3>(kPos) = x.segment<3>(kVel);
  A.block<3, 3>(kPos, kVel).setIdentity();

  // Angular velocity: omegadot = R I^-1 (R^T tau - w_B x I w_B).
  xdot.segment<3>(kOmega) = RAi * y;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d dw_B = data.dR[k].transpose() * w;
    const Eigen::Vector3d dy = data.dR[k].transpose() * torque + R.transpose() * dtorque_dtheta[k] -
                               dw_B.cross(Iw) - w_B.cross(inertia_ * dw_B);
    A.block<3, 1>(kOmega, kTheta + k) = data.dR[k] * (inertia_inv_ * y) + RAi * dy;
  }
  A.block<3, 3>(kOmega, kOmega) = RAi * (skew(Iw) - skew(w_B) * inertia_) * R.transpose();
  A.block<3, kNumLegJoints>(kOmega, kJoints) = M * dtorque_dq;
  for (int leg = 0; leg < kNumLegs; ++leg)
    B.block<3, 3>(kOmega, input_index::force(leg)) = M * lever_skew[leg];

  // Linear velocity.
  xdot.segment<3>(kVel) = force / mass_ + gravity();
  for (int leg = 0; leg < kNumLegs; ++leg)
    B.block<3, 3>(kVel, input_index::force(leg)) = Eigen::Matrix3d::Identity() / mass_;

  // Joints.
  xdot.segment<kNumLegJoints>(kJoints) = u.segment<kNumLegJoints>(input_index::kJointVel);
  B.block<kNumLegJoints, kNumLegJoints>(kJoints, input_index::kJointVel).setIdentity();
}

Eigen::Vector3d CentroidalModel::calcWheelVelocity(int leg, const State& x, const Input& u,
                                                   const ModelData& data) const {
  const Eigen::Vector3d w = segment3(x, state_index::kOmega);
  const Eigen::Vector3d qd = u.segment<kLegDofs>(input_index::jointVel(leg));
  return segment3(x, state_index::kVel) + w.cross(data.R * data.s_B[leg]) +
         data.R * (data.legs[leg].J * qd);
}

void CentroidalModel::calcWheelVelocityJacobians(int leg, const State& x, const Input& u,
                                                 const ModelData& data, WheelVelocity& out) const {
  using namespace state_index;
  const Eigen::Vector3d w = segment3(x, kOmega);
  const Eigen::Vector3d qd = u.segment<kLegDofs>(input_index::jointVel(leg));
  const LegKinematics& k = data.legs[leg];
  const Eigen::Vector3d Rs = data.R * data.s_B[leg];
  const Eigen::Vector3d Jqd = k.J * qd;
  out.v = segment3(x, kVel) + w.cross(Rs) + data.R * Jqd;
  out.dx.setZero();
  for (int i = 0; i < 3; ++i)
    out.dx.col(kTheta + i) = w.cross(data.dR[i] * data.s_B[leg]) + data.dR[i] * Jqd;
  out.dx.block<3, 3>(0, kOmega) = -skew(Rs);
  out.dx.block<3, 3>(0, kVel).setIdentity();
  for (int j = 0; j < kLegDofs; ++j)
    out.dx.col(joints(leg) + j) = w.cross(data.R * k.J.col(j)) + data.R * (k.dJ[j] * qd);
  out.dqd = data.R * k.J;
}

Eigen::Vector3d CentroidalModel::calcWheelCenter(int leg, const State& x,
                                                 const ModelData& data) const {
  return segment3(x, state_index::kPos) + data.R * data.s_B[leg];
}

Eigen::Vector3d CentroidalModel::calcWheelAxis(int leg, const ModelData& data) const {
  return data.R * data.legs[leg].axis_B;
}

Eigen::Matrix<double, 3, kStateDim> CentroidalModel::calcWheelAxisJacobian(
    int leg, const ModelData& data) const {
  Eigen::Matrix<double, 3, kStateDim> d = Eigen::Matrix<double, 3, kStateDim>::Zero();
  for (int i = 0; i < 3; ++i) d.col(state_index::kTheta + i) = data.dR[i] * data.legs[leg].axis_B;
  d.block<3, kLegDofs>(0, state_index::joints(leg)) = data.R * data.legs[leg].d_axis;
  return d;
}

State CentroidalModel::calcStateFromBase(const Eigen::Isometry3d& X_WB, const Eigen::Vector3d& v_WB,
                                         const Eigen::Vector3d& w_WB,
                                         const Eigen::Matrix<double, model::kNumJoints, 1>& q,
                                         double yaw_near) const {
  State x;
  const Eigen::Matrix3d R = X_WB.linear();
  const Eigen::Vector3d Rc = R * c_B_;
  x.segment<3>(state_index::kTheta) = calcEulerAngles(R, yaw_near);
  x.segment<3>(state_index::kPos) = X_WB.translation() + Rc;
  x.segment<3>(state_index::kOmega) = w_WB;
  x.segment<3>(state_index::kVel) = v_WB + w_WB.cross(Rc);
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int j = 0; j < kLegDofs; ++j) x[state_index::joints(leg) + j] = q[robotJointIndex(leg, j)];
  return x;
}

Eigen::Isometry3d CentroidalModel::calcBasePose(const State& x) const {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = calcRotation(segment3(x, state_index::kTheta));
  X.translation() = segment3(x, state_index::kPos) - X.linear() * c_B_;
  return X;
}

Eigen::Vector3d CentroidalModel::calcBaseVelocity(const State& x) const {
  const Eigen::Matrix3d R = calcRotation(segment3(x, state_index::kTheta));
  return segment3(x, state_index::kVel) - segment3(x, state_index::kOmega).cross(R * c_B_);
}

}  // namespace wj::nmpc
