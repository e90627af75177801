#pragma once
/// @file A classic CAN 2.0A frame as the stack handles it: fixed size, no allocation.

#include <array>
#include <cstdint>

namespace wj::can {

/// Largest standard (11-bit) identifier.
inline constexpr std::uint32_t kMaxStandardId = 0x7FF;
/// Largest payload of a classic CAN frame [bytes].
inline constexpr int kMaxDataLength = 8;

/// One classic CAN frame. For an error frame (isError()) `id` holds the error class bits of
/// the Linux SocketCAN error frame (linux/can/error.h, CAN_ERR_* without CAN_ERR_FLAG) and
/// `data` the error details; otherwise `id` is the 11-bit identifier.
struct CanFrame {
  /// Remote transmission request: no payload, `dlc` is the requested length.
  static constexpr std::uint8_t kFlagRtr = 0x1;
  /// Error frame reported by the CAN controller (bus-off, error passive, lost arbitration...).
  static constexpr std::uint8_t kFlagError = 0x2;

  std::uint32_t id = 0;    ///< 11-bit identifier, or error class (kFlagError)
  std::uint8_t dlc = 0;    ///< payload length 0..8 [bytes]
  std::uint8_t flags = 0;  ///< kFlagRtr | kFlagError
  std::array<std::uint8_t, kMaxDataLength> data{};  ///< payload; bytes past dlc are unused

  /// True for an error frame.
  constexpr bool isError() const { return (flags & kFlagError) != 0; }
  /// True for a remote transmission request.
  constexpr bool isRtr() const { return (flags & kFlagRtr) != 0; }
  /// True for an ordinary data frame (neither error nor RTR).
  constexpr bool isData() const { return flags == 0; }
};

/// An error frame of error class `error_class` (CAN_ERR_* bits, e.g. 0x40 = bus off).
constexpr CanFrame makeErrorFrame(std::uint32_t error_class) {
  CanFrame f;
  f.id = error_class;
  f.dlc = kMaxDataLength;
  f.flags = CanFrame::kFlagError;
  return f;
}

}  // namespace wj::can
