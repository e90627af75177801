#include "can/can_robot.h"

#include <cmath>
#include <stdexcept>

namespace wj::can {
namespace {

using model::kJointsPerLeg;
using model::kNumJoints;
using model::kNumLegs;

// x wrapped into [lo, hi).
double wrapInto(double x, double lo, double hi) {
  const double span = hi - lo;
  double w = std::fmod(x - lo, span);
  if (w < 0.0) w += span;
  return lo + w;
}

// d wrapped into [-span/2, span/2).
double wrapSymmetric(double d, double span) {
  return wrapInto(d, -0.5 * span, 0.5 * span);
}

}  // namespace

CanRobot::CanRobot(const model::RobotModel& model, const CanRobotSettings& settings,
                   const std::array<CanBus*, kNumLegs>& buses, ImuSource& imu)
    : settings_(settings), buses_(buses), imu_(&imu) {
  settings_.validateAgainst(model);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    if (buses_[leg] == nullptr)
      throw std::invalid_argument("CanRobot: the bus of leg " +
                                  std::string(model::toString(model::kLegs[leg])) + " is null");
    joint_of_id_[leg].fill(-1);
  }
  for (int j = 0; j < kNumJoints; ++j) {
    continuous_[j] = model.joints()[j].continuous;
    joint_of_id_[j / kJointsPerLeg][settings_.motors[j].can_id] = static_cast<std::int8_t>(j);
  }
}

void CanRobot::handleFrame(int leg, const CanFrame& frame) {
  BusFault& bus = faults_.buses[leg];
  if (frame.isError()) {
    ++bus.error_frames;
    bus.last_error_class = frame.id;
    for (int k = 0; k < kJointsPerLeg; ++k)
      faults_.joints[leg * kJointsPerLeg + k].error_frame = true;
    return;
  }
  if (frame.id != settings_.host_can_id || frame.dlc < 1) {
    ++bus.unknown_frames;
    return;
  }
  const int j = joint_of_id_[leg][frame.data[0]];
  if (j < 0) {
    ++bus.unknown_frames;
    return;
  }
  MitReply reply;
  const MitLimits& limits = settings_.limitsOf(j);
  if (decodeReply(limits, frame, reply) != MitDecodeStatus::Ok) {
    ++faults_.joints[j].malformed_replies;
    return;
  }
  double p = reply.state.p;
  if (continuous_[j]) {
    // The motor reports its angle wrapped into [p_min, p_max): accumulate the turns.
    if (have_position_[j])
      unwrapped_p_[j] += wrapSymmetric(p - last_raw_p_[j], limits.p_max - limits.p_min);
    else
      unwrapped_p_[j] = p;
    last_raw_p_[j] = p;
    p = unwrapped_p_[j];
  } else {
    last_raw_p_[j] = p;
  }
  have_position_[j] = true;
  const MotorMapEntry& m = settings_.motors[j];
  joints_[j].q = m.direction * p + m.offset_rad;
  joints_[j].qd = m.direction * reply.state.v;
  joints_[j].tau = m.direction * reply.state.t;
  answered_[j] = true;
}

void CanRobot::read(model::SensorData& out) {
  ++reads_;
  answered_.fill(false);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    CanFrame frame;
    while (buses_[leg]->receive(frame)) handleFrame(leg, frame);
  }
  const double period = settings_.control_period_s;
  for (int j = 0; j < kNumJoints; ++j) {
    JointFault& f = faults_.joints[j];
    if (answered_[j]) {
      f.missing_replies = 0;
      last_reply_read_[j] = reads_;
      ever_answered_[j] = true;
    } else if (awaiting_[j]) {
      ++f.missing_replies;
      if (f.missing_replies >= settings_.reply_timeout_periods) f.reply_timeout = true;
    }
    awaiting_[j] = false;
    f.last_reply_age_s = ever_answered_[j]
                             ? static_cast<double>(reads_ - last_reply_read_[j]) * period
                             : std::numeric_limits<double>::infinity();
  }
  imu_->read(imu_reading_);
  out.t = static_cast<double>(periods_) * period;
  out.joints = joints_;
  out.imu = imu_reading_;
}

void CanRobot::write(const model::JointCommands& commands) {
  if (!enabled_) return;
  for (int j = 0; j < kNumJoints; ++j) {
    const model::JointCommand& c = commands[j];
    const MotorMapEntry& m = settings_.motors[j];
    const MitLimits& limits = settings_.limitsOf(j);
    MitCommand mc;
    mc.p_des = m.direction * (c.q_des - m.offset_rad);
    mc.v_des = m.direction * c.qd_des;
    mc.kp = c.kp;
    mc.kd = c.kd;
    mc.t_ff = m.direction * c.tau_ff;
    if (continuous_[j] && std::isfinite(mc.p_des)) {
      // Target relative to the motor's wrapped reading, so that p_des - p is the same error.
      const double rel = have_position_[j] ? mc.p_des - unwrapped_p_[j] : 0.0;
      const double base = have_position_[j] ? last_raw_p_[j] : mc.p_des;
      mc.p_des = wrapInto(base + rel, limits.p_min, limits.p_max);
    }
    CanFrame frame;
    clamps_[j] = encodeCommand(limits, m.can_id, mc, frame);
    // A refused frame counts as unanswered, so a bus that refuses everything raises a fault.
    if (!buses_[j / kJointsPerLeg]->send(frame)) ++faults_.buses[j / kJointsPerLeg].send_failures;
    awaiting_[j] = true;
  }
}

void CanRobot::advance() {
  ++periods_;
}

bool CanRobot::sendToAll(MitSpecial special) {
  bool ok = true;
  for (int j = 0; j < kNumJoints; ++j) {
    const int leg = j / kJointsPerLeg;
    if (!buses_[leg]->send(makeSpecialFrame(settings_.motors[j].can_id, special))) {
      ++faults_.buses[leg].send_failures;
      ok = false;
    }
    // Motors in motor mode answer enter and zero; exit and disabled motors do not.
    if (enabled_ && special != MitSpecial::ExitMotorMode) awaiting_[j] = true;
  }
  return ok;
}

bool CanRobot::enable() {
  enabled_ = true;
  return sendToAll(MitSpecial::EnterMotorMode);
}

bool CanRobot::disable() {
  enabled_ = false;
  const bool ok = sendToAll(MitSpecial::ExitMotorMode);
  awaiting_.fill(false);
  return ok;
}

bool CanRobot::zero() {
  // The reported positions jump to the new zero: restart the unwrapping of continuous joints.
  have_position_.fill(false);
  return sendToAll(MitSpecial::ZeroPosition);
}

void CanRobot::clearFaults() {
  faults_ = MotorFaults{};
  for (int j = 0; j < kNumJoints; ++j)
    if (ever_answered_[j])
      faults_.joints[j].last_reply_age_s =
          static_cast<double>(reads_ - last_reply_read_[j]) * settings_.control_period_s;
}

std::array<std::unique_ptr<SocketCanBus>, kNumLegs> openSocketCanBuses(
    const CanRobotSettings& settings) {
  std::array<std::unique_ptr<SocketCanBus>, kNumLegs> buses;
  for (int leg = 0; leg < kNumLegs; ++leg)
    buses[leg] = std::make_unique<SocketCanBus>(settings.interfaces[leg]);
  return buses;
}

}  // namespace wj::can
