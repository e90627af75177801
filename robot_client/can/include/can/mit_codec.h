#pragma once
/// @file The MIT-mode ("mini cheetah") protocol of 9:1 quasi-direct-drive joint motors:
/// 8-byte command, 6-byte reply, enter/exit motor mode and zero position. Both directions are
/// here: the robot encodes commands and decodes replies, the motor (or its emulator) does the
/// reverse. Real-time safe: no allocation, no exceptions in encode/decode. See docs/can.md.

#include <cstdint>
#include <optional>

#include "can/can_frame.h"

namespace wj::can {

/// Ranges the motor firmware maps its fixed-point fields onto (output side of the gearbox).
/// Robot and motor must agree on them. Defaults suit this robot's 42 Nm / 40 rad/s drives.
struct MitLimits {
  double p_min = -12.5;   ///< position range [rad]
  double p_max = 12.5;    ///< [rad]
  double v_min = -45.0;   ///< velocity range [rad/s]
  double v_max = 45.0;    ///< [rad/s]
  double kp_min = 0.0;    ///< position gain range [Nm/rad]
  double kp_max = 500.0;  ///< [Nm/rad]
  double kd_min = 0.0;    ///< velocity gain range [Nm s/rad]
  double kd_max = 5.0;    ///< [Nm s/rad]
  double t_min = -48.0;   ///< torque range [Nm]
  double t_max = 48.0;    ///< [Nm]

  /// Throws std::invalid_argument naming the field unless every bound is finite, every range
  /// non-empty (min < max) and the gain ranges start at or above 0.
  void validate() const;
};

/// Bit widths of the protocol's fields.
inline constexpr int kMitPositionBits = 16;
inline constexpr int kMitVelocityBits = 12;
inline constexpr int kMitGainBits = 12;
inline constexpr int kMitTorqueBits = 12;
/// Payload length of a command and of a special frame [bytes].
inline constexpr int kMitCommandLength = 8;
/// Payload length of a reply [bytes].
inline constexpr int kMitReplyLength = 6;

/// Quantization step of every field: (max - min) / (2^bits - 1). Encoding rounds to the
/// nearest code, so a decoded in-range value is within half a step of the original.
struct MitSteps {
  double p = 0.0;   ///< [rad]
  double v = 0.0;   ///< [rad/s]
  double kp = 0.0;  ///< [Nm/rad]
  double kd = 0.0;  ///< [Nm s/rad]
  double t = 0.0;   ///< [Nm]
};
/// The steps of `limits`.
MitSteps mitSteps(const MitLimits& limits);

/// Command of one motor in its own frame (output side): the motor applies
/// t = kp (p_des - p) + kd (v_des - v) + t_ff.
struct MitCommand {
  double p_des = 0.0;  ///< [rad]
  double v_des = 0.0;  ///< [rad/s]
  double kp = 0.0;     ///< [Nm/rad]
  double kd = 0.0;     ///< [Nm s/rad]
  double t_ff = 0.0;   ///< [Nm]
};

/// State a motor reports, in its own frame (output side).
struct MitState {
  double p = 0.0;  ///< position [rad]
  double v = 0.0;  ///< velocity [rad/s]
  double t = 0.0;  ///< torque [Nm]
};

/// A decoded reply: which motor and its state.
struct MitReply {
  std::uint8_t motor_id = 0;  ///< first payload byte: the CAN id of the motor that answers
  MitState state;
};

/// Fields that encoding clamped into range (bit mask; 0 = nothing clamped).
enum MitClampBits : std::uint8_t {
  kClampPosition = 0x01,
  kClampVelocity = 0x02,
  kClampKp = 0x04,
  kClampKd = 0x08,
  kClampTorque = 0x10,
  /// A value was NaN or infinite: it was replaced by the in-range value nearest to 0 (for the
  /// gains: their minimum), i.e. no torque from that term.
  kClampNonFinite = 0x80,
};

/// Special commands of the protocol: 8 bytes FF FF FF FF FF FF FF xx.
enum class MitSpecial : std::uint8_t {
  EnterMotorMode = 0xFC,  ///< enable the drive (it answers with its state from then on)
  ExitMotorMode = 0xFD,   ///< disable the drive (no torque, no answers)
  ZeroPosition = 0xFE,    ///< make the present position the new zero
};

/// Why a frame was not decoded.
enum class MitDecodeStatus : std::uint8_t {
  Ok,
  ErrorFrame,    ///< an error frame, not a message
  RemoteFrame,   ///< an RTR frame
  WrongLength,   ///< dlc differs from the protocol's length for this message
  SpecialFrame,  ///< a special command where a motor command was expected
};

/// "ok", "error frame", "remote frame", "wrong length", "special frame".
const char* toString(MitDecodeStatus status);

/// Encodes `command` for the motor with CAN id `can_id` into `out` (dlc 8), packed as
/// p[15:8] p[7:0] v[11:4] v[3:0]|kp[11:8] kp[7:0] kd[11:4] kd[3:0]|t[11:8] t[7:0].
/// Out-of-range values are clamped; returns the MitClampBits of what was clamped.
std::uint8_t encodeCommand(const MitLimits& limits, std::uint32_t can_id, const MitCommand& command,
                           CanFrame& out);
/// Decodes a command frame (the motor's side) into `out`, quantized as transmitted.
MitDecodeStatus decodeCommand(const MitLimits& limits, const CanFrame& frame, MitCommand& out);

/// Encodes the reply of motor `motor_id` to the host id `host_can_id` (dlc 6):
/// id p[15:8] p[7:0] v[11:4] v[3:0]|t[11:8] t[7:0]. Returns the MitClampBits of the clamped
/// fields (kClampPosition, kClampVelocity, kClampTorque, kClampNonFinite).
std::uint8_t encodeReply(const MitLimits& limits, std::uint32_t host_can_id, std::uint8_t motor_id,
                         const MitState& state, CanFrame& out);
/// Decodes a reply frame (the robot's side) into `out`.
MitDecodeStatus decodeReply(const MitLimits& limits, const CanFrame& frame, MitReply& out);

/// The special command `special` for the motor with CAN id `can_id`.
CanFrame makeSpecialFrame(std::uint32_t can_id, MitSpecial special);
/// The special command carried by `frame`, or nothing if it is not one (an ordinary command
/// may not use FF FF FF FF FF FF FF FC..FE: its torque field would be all ones and kd too,
/// which is the protocol's reserved pattern).
std::optional<MitSpecial> parseSpecialFrame(const CanFrame& frame);

/// `x` clamped to [lo, hi] and mapped to the nearest of 2^bits codes (0 .. 2^bits - 1).
std::uint32_t mitQuantize(double x, double lo, double hi, int bits);
/// The value of code `code` of a `bits`-wide field over [lo, hi].
double mitDequantize(std::uint32_t code, double lo, double hi, int bits);

}  // namespace wj::can
