#include "nmpc/whole_body_controller.h"

#include <stdexcept>

namespace wj::nmpc {

void WholeBodySettings::validate() const {
  if (!(leg_kp >= 0.0 && leg_kd >= 0.0))
    throw std::invalid_argument("WholeBodySettings: leg_kp and leg_kd must be >= 0");
  if (!(wheel_kd >= 0.0 && swing_wheel_kd >= 0.0 && wheel_slip_kd >= 0.0))
    throw std::invalid_argument("WholeBodySettings: wheel gains must be >= 0");
  if (!(max_feedback_force_n >= 0.0))
    throw std::invalid_argument("WholeBodySettings.max_feedback_force_n must be >= 0");
}

WholeBodyController::WholeBodyController(const model::RobotModel& robot,
                                         const CentroidalModel& model,
                                         const WholeBodySettings& settings)
    : model_(model), inverse_dynamics_(robot), settings_(settings) {
  settings_.validate();
}

void WholeBodyController::calcCommands(double t, const Policy& policy, const State& x,
                                       const model::SensorData& sensors,
                                       const ContactFlags& contact, const Eigen::Vector3d& n,
                                       model::JointCommands& out, WholeBodyOutput& diag) const {
  policy.calcState(t, diag.x_des);
  Input& u = diag.u;
  policy.calcFeedforward(t, u);
  if (settings_.policy_feedback) {
    Input u_fb;
    policy.calcInput(t, x, u_fb);
    Input du = u_fb - u;
    for (int leg = 0; leg < kNumLegs; ++leg) {
      auto df = du.segment<3>(input_index::force(leg));
      const double norm = df.norm();
      if (norm > settings_.max_feedback_force_n) df *= settings_.max_feedback_force_n / norm;
    }
    u += du;
  }
  for (int leg = 0; leg < kNumLegs; ++leg)
    if (!contact[leg]) u.segment<3>(input_index::force(leg)).setZero();

  // Measured joints, and the input with the measured leg joint velocities.
  RobotJointVector q, qd;
  for (int j = 0; j < model::kNumJoints; ++j) {
    q[j] = sensors.joints[j].q;
    qd[j] = sensors.joints[j].qd;
  }
  Input u_meas = u;
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int j = 0; j < kLegDofs; ++j)
      u_meas[input_index::jointVel(leg) + j] = qd[robotJointIndex(leg, j)];

  ModelData data, data_des;
  model_.updateData(x, data);
  model_.updateData(diag.x_des, data_des);
  const Eigen::Matrix3d& R = data.R;
  const Eigen::Matrix3d Rt = R.transpose();

  // Paper Eq. 9 by RNEA: planned base acceleration (the centroidal model at the measured state
  // under the planned input), measured velocities, planned contact forces.
  diag.tau_ff.setZero();
  if (settings_.inverse_dynamics) {
    State xdot;
    model_.calcFlowMap(x, u, n, data, xdot);
    const Eigen::Vector3d w = x.segment<3>(state_index::kOmega);
    const Eigen::Vector3d wd = xdot.segment<3>(state_index::kOmega);
    const Eigen::Vector3d rc = R * model_.comOffset();
    BaseMotion base;
    base.omega_B = Rt * w;
    base.v_B = Rt * (x.segment<3>(state_index::kVel) - w.cross(rc));
    base.omegadot_B = Rt * wd;
    base.a_B = Rt * (xdot.segment<3>(state_index::kVel) - wd.cross(rc) - w.cross(w.cross(rc)));
    std::array<WheelForce, kNumLegs> forces{};
    for (int leg = 0; leg < kNumLegs; ++leg) {
      forces[leg].f_B = Rt * u.segment<3>(input_index::force(leg));
      forces[leg].p_B = data.legs[leg].p_B - model_.wheelRadius() * (Rt * n);
    }
    InverseDynamicsResult id;
    inverse_dynamics_.calc(Rt * model_.gravity(), base, q, qd, RobotJointVector::Zero(), forces,
                           id);
    diag.tau_ff = id.tau;
  }

  for (int leg = 0; leg < kNumLegs; ++leg) {
    for (int j = 0; j < kLegDofs; ++j) {
      const int r = robotJointIndex(leg, j);
      model::JointCommand& c = out[r];
      c.q_des = diag.x_des[state_index::joints(leg) + j];
      c.qd_des = u[input_index::jointVel(leg) + j];
      c.kp = settings_.leg_kp;
      c.kd = settings_.leg_kd;
      c.tau_ff = diag.tau_ff[r];
    }
    // Wheel: rolling direction t = a x n (a the spin axis in W), speed of the wheel centre.
    const Eigen::Vector3d axis = model_.calcWheelAxis(leg, data);
    Eigen::Vector3d tangent = axis.cross(n);
    const double tn = tangent.norm();
    if (tn > 1e-6) tangent /= tn;
    const double v_t = tangent.dot(model_.calcWheelVelocity(leg, x, u_meas, data));
    // Spin of the shank about the wheel axis: the wheel joint speed that rolls at speed v is
    // v / r minus it.
    const Eigen::Vector3d qd_leg = u_meas.segment<kLegDofs>(input_index::jointVel(leg));
    const double shank_spin =
        axis.dot(x.segment<3>(state_index::kOmega) + R * (data.legs[leg].joint_axes_B * qd_leg));
    const double r = model_.wheelRadius();
    const int iw = robotJointIndex(leg, 3);
    model::JointCommand& c = out[iw];
    c = model::JointCommand{};
    if (contact[leg]) {
      const double v_des = tangent.dot(model_.calcWheelVelocity(leg, diag.x_des, u, data_des));
      const double f_t = tangent.dot(u.segment<3>(input_index::force(leg)));
      const double slip = v_t / r - shank_spin - qd[iw];
      c.tau_ff = settings_.wheel_kd * (v_des - v_t) + f_t * r + settings_.wheel_slip_kd * slip;
    } else {
      c.qd_des = tangent.dot(x.segment<3>(state_index::kVel)) / r - shank_spin;
      c.kd = settings_.swing_wheel_kd;
    }
  }
}

}  // namespace wj::nmpc
