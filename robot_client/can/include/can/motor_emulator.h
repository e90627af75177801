#pragma once
/// @file Emulation of one MIT-mode motor on the motor side of a CAN bus: what the firmware
/// does with the frames it receives and what it answers. For tests and the simulated robot
/// behind real frames (SimViaCan). Real-time safe: no allocation, lock or log.

#include <cstdint>

#include "can/can_bus.h"
#include "can/mit_codec.h"

namespace wj::can {

/// Identity and ranges of one emulated motor.
struct MitMotorConfig {
  std::uint32_t can_id = 1;       ///< the motor's identifier (1..255: the reply carries it)
  std::uint32_t host_can_id = 0;  ///< identifier the replies are sent with
  MitLimits limits;               ///< must equal the robot side's ranges
  /// Report positions wrapped into [p_min, p_max) (continuous joints such as wheels, whose
  /// multi-turn angle leaves the range); otherwise positions saturate at the range ends.
  bool wrap_position = false;

  /// Throws std::invalid_argument naming the field when out of range.
  void validate() const;
};

/// One MIT-mode motor: decodes the commands addressed to it (with the protocol's
/// quantization), handles enter/exit motor mode and zero position, and answers each command
/// received while enabled with a 6-byte reply of the state it is given.
///
/// Timing: handle() records that an answer is owed and respond() sends it with the state
/// the caller passes, so that a simulator can answer with the state at the end of the control
/// period (a real drive answers within ~0.1 ms of the command).
class MitMotorEmulator {
 public:
  /// A disabled motor with zero offset that answers on `bus` (not owned; must outlive it).
  /// Throws std::invalid_argument if `config` is out of range.
  MitMotorEmulator(CanBus& bus, const MitMotorConfig& config);

  /// Handles `frame` if it is addressed to this motor (returns false otherwise): a special
  /// command changes the mode or the zero; an ordinary command is decoded and becomes the
  /// motor's command while enabled. Malformed frames to this id are counted and ignored.
  bool handle(const CanFrame& frame);
  /// Sends the owed answer (if any, and if enabled and not silent) with `physical` = the
  /// state in the drive's physical frame; the reply carries it minus the zero offset.
  /// Returns true if a reply was sent.
  bool respond(const MitState& physical);

  /// Back to the power-on state: disabled, zero offset 0, nothing owed, not silent, counters 0.
  void reset();

  /// True after enter motor mode, until exit motor mode.
  bool enabled() const { return enabled_; }
  /// The command the drive applies, in its physical frame (zero offset added back): the
  /// last decoded command while enabled, all zero (no torque) while disabled.
  MitCommand physicalCommand() const;
  /// The last decoded command as transmitted (relative to the zero).
  const MitCommand& lastCommand() const { return command_; }
  /// Physical position that reads as zero [rad].
  double zeroOffset() const { return zero_offset_; }

  // Fault injection ---------------------------------------------------------------------------
  /// A silent motor receives but never answers (a dead drive or a broken wire).
  void setSilent(bool silent) { silent_ = silent; }
  /// Sends an error frame of class `error_class` on the bus, as the controller reports a bus
  /// error. False if the bus could not take it.
  bool sendErrorFrame(std::uint32_t error_class);

  /// Counters: commands decoded, special frames, malformed frames, replies sent.
  struct Counters {
    std::uint64_t commands = 0;
    std::uint64_t specials = 0;
    std::uint64_t malformed = 0;
    std::uint64_t replies = 0;
  };
  const Counters& counters() const { return counters_; }
  const MitMotorConfig& config() const { return config_; }

 private:
  CanBus* bus_;
  MitMotorConfig config_;
  bool enabled_ = false;
  bool silent_ = false;
  bool reply_owed_ = false;
  double zero_offset_ = 0.0;
  double last_physical_p_ = 0.0;  ///< last position given to respond(), for zeroing
  MitCommand command_;
  Counters counters_;
};

}  // namespace wj::can
