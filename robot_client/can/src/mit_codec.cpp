#include "can/mit_codec.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace wj::can {
namespace {

void checkRange(const char* name, double lo, double hi, bool non_negative) {
  const std::string n(name);
  if (!std::isfinite(lo) || !std::isfinite(hi))
    throw std::invalid_argument("MitLimits." + n + "_min/" + n + "_max must be finite, got [" +
                                std::to_string(lo) + ", " + std::to_string(hi) + "]");
  if (!(lo < hi))
    throw std::invalid_argument("MitLimits." + n + "_min must be < " + n + "_max, got [" +
                                std::to_string(lo) + ", " + std::to_string(hi) + "]");
  if (non_negative && lo < 0.0)
    throw std::invalid_argument("MitLimits." + n + "_min must be >= 0 (a gain), got " +
                                std::to_string(lo));
}

double step(double lo, double hi, int bits) {
  return (hi - lo) / static_cast<double>((1u << bits) - 1u);
}

// Clamps x into [lo, hi], recording in `clamped` whether it had to (bit `bit`). A non-finite
// x becomes `fallback` (already in range) and sets kClampNonFinite.
double clampField(double x, double lo, double hi, double fallback, std::uint8_t bit,
                  std::uint8_t& clamped) {
  if (!std::isfinite(x)) {
    clamped |= kClampNonFinite | bit;
    return fallback;
  }
  if (x < lo || x > hi) clamped |= bit;
  return std::clamp(x, lo, hi);
}

// The in-range value nearest to 0.
double nearestToZero(double lo, double hi) {
  return std::clamp(0.0, lo, hi);
}

bool isSpecialPrefix(const CanFrame& f) {
  for (int i = 0; i < kMitCommandLength - 1; ++i)
    if (f.data[i] != 0xFF) return false;
  return true;
}

}  // namespace

void MitLimits::validate() const {
  checkRange("p", p_min, p_max, false);
  checkRange("v", v_min, v_max, false);
  checkRange("kp", kp_min, kp_max, true);
  checkRange("kd", kd_min, kd_max, true);
  checkRange("t", t_min, t_max, false);
}

MitSteps mitSteps(const MitLimits& l) {
  return {step(l.p_min, l.p_max, kMitPositionBits), step(l.v_min, l.v_max, kMitVelocityBits),
          step(l.kp_min, l.kp_max, kMitGainBits), step(l.kd_min, l.kd_max, kMitGainBits),
          step(l.t_min, l.t_max, kMitTorqueBits)};
}

const char* toString(MitDecodeStatus status) {
  switch (status) {
    case MitDecodeStatus::Ok:
      return "ok";
    case MitDecodeStatus::ErrorFrame:
      return "error frame";
    case MitDecodeStatus::RemoteFrame:
      return "remote frame";
    case MitDecodeStatus::WrongLength:
      return "wrong length";
    case MitDecodeStatus::SpecialFrame:
      return "special frame";
  }
  return "unknown";
}

std::uint32_t mitQuantize(double x, double lo, double hi, int bits) {
  const double max_code = static_cast<double>((1u << bits) - 1u);
  const double c = std::clamp(x, lo, hi);
  const double code = std::round((c - lo) / (hi - lo) * max_code);
  return static_cast<std::uint32_t>(std::clamp(code, 0.0, max_code));
}

double mitDequantize(std::uint32_t code, double lo, double hi, int bits) {
  const double max_code = static_cast<double>((1u << bits) - 1u);
  return lo + static_cast<double>(code) * (hi - lo) / max_code;
}

std::uint8_t encodeCommand(const MitLimits& l, std::uint32_t can_id, const MitCommand& c,
                           CanFrame& out) {
  std::uint8_t clamped = 0;
  const double p = clampField(c.p_des, l.p_min, l.p_max, nearestToZero(l.p_min, l.p_max),
                              kClampPosition, clamped);
  const double v = clampField(c.v_des, l.v_min, l.v_max, nearestToZero(l.v_min, l.v_max),
                              kClampVelocity, clamped);
  const double kp = clampField(c.kp, l.kp_min, l.kp_max, l.kp_min, kClampKp, clamped);
  const double kd = clampField(c.kd, l.kd_min, l.kd_max, l.kd_min, kClampKd, clamped);
  const double t =
      clampField(c.t_ff, l.t_min, l.t_max, nearestToZero(l.t_min, l.t_max), kClampTorque, clamped);
  std::uint32_t p_code = mitQuantize(p, l.p_min, l.p_max, kMitPositionBits);
  const std::uint32_t v_code = mitQuantize(v, l.v_min, l.v_max, kMitVelocityBits);
  const std::uint32_t kp_code = mitQuantize(kp, l.kp_min, l.kp_max, kMitGainBits);
  const std::uint32_t kd_code = mitQuantize(kd, l.kd_min, l.kd_max, kMitGainBits);
  const std::uint32_t t_code = mitQuantize(t, l.t_min, l.t_max, kMitTorqueBits);
  // All fields at their top code but torque in FFC..FFE would read as a special command: move
  // the position one step down (the protocol reserves that pattern).
  if (p_code == 0xFFFF && v_code == 0xFFF && kp_code == 0xFFF && kd_code == 0xFFF &&
      t_code >= 0xFFC && t_code <= 0xFFE)
    p_code -= 1;

  out = CanFrame{};
  out.id = can_id;
  out.dlc = kMitCommandLength;
  out.data[0] = static_cast<std::uint8_t>(p_code >> 8);
  out.data[1] = static_cast<std::uint8_t>(p_code & 0xFF);
  out.data[2] = static_cast<std::uint8_t>(v_code >> 4);
  out.data[3] = static_cast<std::uint8_t>(((v_code & 0xF) << 4) | (kp_code >> 8));
  out.data[4] = static_cast<std::uint8_t>(kp_code & 0xFF);
  out.data[5] = static_cast<std::uint8_t>(kd_code >> 4);
  out.data[6] = static_cast<std::uint8_t>(((kd_code & 0xF) << 4) | (t_code >> 8));
  out.data[7] = static_cast<std::uint8_t>(t_code & 0xFF);
  return clamped;
}

MitDecodeStatus decodeCommand(const MitLimits& l, const CanFrame& f, MitCommand& out) {
  if (f.isError()) return MitDecodeStatus::ErrorFrame;
  if (f.isRtr()) return MitDecodeStatus::RemoteFrame;
  if (f.dlc != kMitCommandLength) return MitDecodeStatus::WrongLength;
  if (parseSpecialFrame(f)) return MitDecodeStatus::SpecialFrame;
  const auto& d = f.data;
  const std::uint32_t p_code = (std::uint32_t{d[0]} << 8) | d[1];
  const std::uint32_t v_code = (std::uint32_t{d[2]} << 4) | (d[3] >> 4);
  const std::uint32_t kp_code = (std::uint32_t{d[3] & 0xFu} << 8) | d[4];
  const std::uint32_t kd_code = (std::uint32_t{d[5]} << 4) | (d[6] >> 4);
  const std::uint32_t t_code = (std::uint32_t{d[6] & 0xFu} << 8) | d[7];
  out.p_des = mitDequantize(p_code, l.p_min, l.p_max, kMitPositionBits);
  out.v_des = mitDequantize(v_code, l.v_min, l.v_max, kMitVelocityBits);
  out.kp = mitDequantize(kp_code, l.kp_min, l.kp_max, kMitGainBits);
  out.kd = mitDequantize(kd_code, l.kd_min, l.kd_max, kMitGainBits);
  out.t_ff = mitDequantize(t_code, l.t_min, l.t_max, kMitTorqueBits);
  return MitDecodeStatus::Ok;
}

std::uint8_t encodeReply(const MitLimits& l, std::uint32_t host_can_id, std::uint8_t motor_id,
                         const MitState& s, CanFrame& out) {
  std::uint8_t clamped = 0;
  const double p =
      clampField(s.p, l.p_min, l.p_max, nearestToZero(l.p_min, l.p_max), kClampPosition, clamped);
  const double v =
      clampField(s.v, l.v_min, l.v_max, nearestToZero(l.v_min, l.v_max), kClampVelocity, clamped);
  const double t =
      clampField(s.t, l.t_min, l.t_max, nearestToZero(l.t_min, l.t_max), kClampTorque, clamped);
  const std::uint32_t p_code = mitQuantize(p, l.p_min, l.p_max, kMitPositionBits);
  const std::uint32_t v_code = mitQuantize(v, l.v_min, l.v_max, kMitVelocityBits);
  const std::uint32_t t_code = mitQuantize(t, l.t_min, l.t_max, kMitTorqueBits);
  out = CanFrame{};
  out.id = host_can_id;
  out.dlc = kMitReplyLength;
  out.data[0] = motor_id;
  out.data[1] = static_cast<std::uint8_t>(p_code >> 8);
  out.data[2] = static_cast<std::uint8_t>(p_code & 0xFF);
  out.data[3] = static_cast<std::uint8_t>(v_code >> 4);
  out.data[4] = static_cast<std::uint8_t>(((v_code & 0xF) << 4) | (t_code >> 8));
  out.data[5] = static_cast<std::uint8_t>(t_code & 0xFF);
  return clamped;
}

MitDecodeStatus decodeReply(const MitLimits& l, const CanFrame& f, MitReply& out) {
  if (f.isError()) return MitDecodeStatus::ErrorFrame;
  if (f.isRtr()) return MitDecodeStatus::RemoteFrame;
  if (f.dlc != kMitReplyLength) return MitDecodeStatus::WrongLength;
  const auto& d = f.data;
  const std::uint32_t p_code = (std::uint32_t{d[1]} << 8) | d[2];
  const std::uint32_t v_code = (std::uint32_t{d[3]} << 4) | (d[4] >> 4);
  const std::uint32_t t_code = (std::uint32_t{d[4] & 0xFu} << 8) | d[5];
  out.motor_id = d[0];
  out.state.p = mitDequantize(p_code, l.p_min, l.p_max, kMitPositionBits);
  out.state.v = mitDequantize(v_code, l.v_min, l.v_max, kMitVelocityBits);
  out.state.t = mitDequantize(t_code, l.t_min, l.t_max, kMitTorqueBits);
  return MitDecodeStatus::Ok;
}

CanFrame makeSpecialFrame(std::uint32_t can_id, MitSpecial special) {
  CanFrame f;
  f.id = can_id;
  f.dlc = kMitCommandLength;
  f.data.fill(0xFF);
  f.data[7] = static_cast<std::uint8_t>(special);
  return f;
}

std::optional<MitSpecial> parseSpecialFrame(const CanFrame& f) {
  if (!f.isData() || f.dlc != kMitCommandLength || !isSpecialPrefix(f)) return std::nullopt;
  switch (f.data[7]) {
    case static_cast<std::uint8_t>(MitSpecial::EnterMotorMode):
      return MitSpecial::EnterMotorMode;
    case static_cast<std::uint8_t>(MitSpecial::ExitMotorMode):
      return MitSpecial::ExitMotorMode;
    case static_cast<std::uint8_t>(MitSpecial::ZeroPosition):
      return MitSpecial::ZeroPosition;
    default:
      return std::nullopt;
  }
}

}  // namespace wj::can
