#include "can/sim_via_can.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace wj::can {
namespace {

using model::kJointsPerLeg;
using model::kNumJoints;
using model::kNumLegs;

// d wrapped into [-span/2, span/2).
double wrapSymmetric(double d, double span) {
  double w = std::fmod(d + 0.5 * span, span);
  if (w < 0.0) w += span;
  return w - 0.5 * span;
}

}  // namespace

SimViaCan::SimViaCan(const model::RobotModel& model, const sim::SimSettings& sim_settings,
                     const CanRobotSettings& can_settings, std::size_t queue_capacity)
    : can_settings_(can_settings), sim_(model, sim_settings) {
  can_settings_.validateAgainst(model);
  if (std::abs(can_settings_.control_period_s - sim_.controlPeriod()) > 1e-12)
    throw std::invalid_argument("SimViaCan: CanRobotSettings.control_period_s (" +
                                std::to_string(can_settings_.control_period_s) +
                                " s) must equal the simulation's (" +
                                std::to_string(sim_.controlPeriod()) + " s)");
  for (int leg = 0; leg < kNumLegs; ++leg) buses_[leg].emplace(queue_capacity);
  for (int j = 0; j < kNumJoints; ++j) {
    continuous_[j] = model.joints()[j].continuous;
    MitMotorConfig config;
    config.can_id = can_settings_.motors[j].can_id;
    config.host_can_id = can_settings_.host_can_id;
    config.limits = can_settings_.limitsOf(j);
    config.wrap_position = continuous_[j];
    motors_[j].emplace(buses_[j / kJointsPerLeg]->motorSide(), config);
  }
  // The constructor left the robot standing still at the origin; power the CAN side up there.
  buildCanSide();
}

void SimViaCan::buildCanSide() {
  for (auto& bus : buses_) bus->clear();
  for (auto& motor : motors_) motor->reset();
  std::array<CanBus*, kNumLegs> robot_sides{};
  for (int leg = 0; leg < kNumLegs; ++leg) robot_sides[leg] = &buses_[leg]->robotSide();
  can_robot_.emplace(sim_.model(), can_settings_, robot_sides, imu_);
  unhandled_frames_ = 0;
  applied_ = model::JointCommands{};
  sim_.read(measured_);
  can_robot_->enable();
  serviceMotors();
  respondAll();
}

void SimViaCan::reset(const sim::RobotPlacement& placement) {
  sim_.reset(placement);
  buildCanSide();
}

void SimViaCan::serviceMotors() {
  for (int leg = 0; leg < kNumLegs; ++leg) {
    CanBus& motor_side = buses_[leg]->motorSide();
    CanFrame frame;
    while (motor_side.receive(frame)) {
      bool handled = false;
      for (int k = 0; k < kJointsPerLeg && !handled; ++k)
        handled = motors_[leg * kJointsPerLeg + k]->handle(frame);
      if (!handled) ++unhandled_frames_;
    }
  }
}

void SimViaCan::respondAll() {
  for (int j = 0; j < kNumJoints; ++j) {
    const MotorMapEntry& m = can_settings_.motors[j];
    const model::JointMeasurement& jm = measured_.joints[j];
    motors_[j]->respond(
        {m.direction * (jm.q - m.offset_rad), m.direction * jm.qd, m.direction * jm.tau});
  }
}

void SimViaCan::read(model::SensorData& out) {
  can_robot_->read(out);
  out.t = sim_.time();
}

void SimViaCan::write(const model::JointCommands& commands) {
  can_robot_->write(commands);
  serviceMotors();
  for (int j = 0; j < kNumJoints; ++j) {
    const MotorMapEntry& m = can_settings_.motors[j];
    const MitCommand c = motors_[j]->physicalCommand();
    double p_des = c.p_des;
    if (continuous_[j]) {
      // The drive reads its angle wrapped: its target is the one nearest its present angle.
      const MitLimits& l = can_settings_.limitsOf(j);
      const double p_now = m.direction * (measured_.joints[j].q - m.offset_rad);
      p_des = p_now + wrapSymmetric(c.p_des - p_now, l.p_max - l.p_min);
    }
    applied_[j] = {m.offset_rad + m.direction * p_des, m.direction * c.v_des, c.kp, c.kd,
                   m.direction * c.t_ff};
  }
  sim_.write(applied_);
}

void SimViaCan::advance() {
  sim_.advance();
  sim_.read(measured_);
  respondAll();
}

}  // namespace wj::can
