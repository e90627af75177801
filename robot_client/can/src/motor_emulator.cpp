#include "can/motor_emulator.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace wj::can {
namespace {

// x wrapped into [lo, hi).
double wrapInto(double x, double lo, double hi) {
  const double span = hi - lo;
  double w = std::fmod(x - lo, span);
  if (w < 0.0) w += span;
  return lo + w;
}

}  // namespace

void MitMotorConfig::validate() const {
  if (can_id < 1 || can_id > 0xFF)
    throw std::invalid_argument("MitMotorConfig.can_id must lie in [1, 255], got " +
                                std::to_string(can_id));
  if (host_can_id > kMaxStandardId || host_can_id == can_id)
    throw std::invalid_argument(
        "MitMotorConfig.host_can_id must lie in [0, 2047] and differ "
        "from can_id, got " +
        std::to_string(host_can_id));
  limits.validate();
}

MitMotorEmulator::MitMotorEmulator(CanBus& bus, const MitMotorConfig& config)
    : bus_(&bus), config_(config) {
  config_.validate();
}

void MitMotorEmulator::reset() {
  enabled_ = false;
  silent_ = false;
  reply_owed_ = false;
  zero_offset_ = 0.0;
  last_physical_p_ = 0.0;
  command_ = MitCommand{};
  counters_ = Counters{};
}

bool MitMotorEmulator::handle(const CanFrame& frame) {
  if (!frame.isData() || frame.id != config_.can_id) return false;
  if (const auto special = parseSpecialFrame(frame)) {
    ++counters_.specials;
    switch (*special) {
      case MitSpecial::EnterMotorMode:
        enabled_ = true;
        reply_owed_ = true;
        break;
      case MitSpecial::ExitMotorMode:
        enabled_ = false;
        reply_owed_ = false;
        command_ = MitCommand{};
        break;
      case MitSpecial::ZeroPosition:
        zero_offset_ = last_physical_p_;
        reply_owed_ = enabled_;
        break;
    }
    return true;
  }
  MitCommand decoded;
  if (decodeCommand(config_.limits, frame, decoded) != MitDecodeStatus::Ok) {
    ++counters_.malformed;
    return true;
  }
  ++counters_.commands;
  if (enabled_) {  // a drive outside motor mode ignores commands
    command_ = decoded;
    reply_owed_ = true;
  }
  return true;
}

bool MitMotorEmulator::respond(const MitState& physical) {
  last_physical_p_ = physical.p;
  if (!reply_owed_ || !enabled_ || silent_) {
    reply_owed_ = false;
    return false;
  }
  reply_owed_ = false;
  MitState reported = physical;
  reported.p = physical.p - zero_offset_;
  if (config_.wrap_position)
    reported.p = wrapInto(reported.p, config_.limits.p_min, config_.limits.p_max);
  CanFrame frame;
  encodeReply(config_.limits, config_.host_can_id, static_cast<std::uint8_t>(config_.can_id),
              reported, frame);
  if (!bus_->send(frame)) return false;
  ++counters_.replies;
  return true;
}

MitCommand MitMotorEmulator::physicalCommand() const {
  if (!enabled_) return MitCommand{};
  MitCommand c = command_;
  c.p_des += zero_offset_;
  return c;
}

bool MitMotorEmulator::sendErrorFrame(std::uint32_t error_class) {
  return bus_->send(makeErrorFrame(error_class));
}

}  // namespace wj::can
