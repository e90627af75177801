// CAN buses: the SocketCAN error messages on this machine, a vcan0 round trip where such an
// interface exists, and the in-process bus (order, capacity, drops, error frames, two threads).
#include <gtest/gtest.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>

#include "can/can_bus.h"
#include "can/mit_codec.h"
#include "error_of.h"

namespace wj::can {
namespace {

// errno of socket(PF_CAN, SOCK_RAW, CAN_RAW), 0 if it works.
int pfCanErrno() {
  const int fd = ::socket(PF_CAN, SOCK_RAW, 1 /* CAN_RAW */);
  if (fd < 0) return errno;
  ::close(fd);
  return 0;
}

std::string openError(const std::string& name) {
  return test::errorOf<CanError>([&] { SocketCanBus bus(name); });
}

TEST(SocketCanBus, ErrorMessageSaysWhatIsMissing) {
  const int err = pfCanErrno();
  if (err == EAFNOSUPPORT) {
    // This machine: the kernel has no PF_CAN.
    const std::string msg = openError("can0");
    EXPECT_THAT(msg, test::HasSubstr("SocketCAN is not available")) << msg;
    EXPECT_THAT(msg, test::HasSubstr("the kernel has no PF_CAN support")) << msg;
    EXPECT_THAT(msg, test::HasSubstr("Address family not supported by protocol")) << msg;
    EXPECT_THAT(msg, test::HasSubstr("load the can and can_raw modules")) << msg;
    EXPECT_THAT(msg, test::HasSubstr("in-process bus")) << msg;
  } else {
    ASSERT_EQ(err, 0) << "socket(PF_CAN) failed otherwise: " << std::strerror(err);
    const std::string msg = openError("wjnosuchcan9");
    EXPECT_THAT(msg, test::HasSubstr("CAN interface 'wjnosuchcan9' does not exist")) << msg;
    EXPECT_THAT(msg, test::HasSubstr("ip link")) << msg;
  }
}

TEST(SocketCanBus, InvalidInterfaceNameIsRefusedFirst) {
  EXPECT_THAT(openError(""), test::HasSubstr("is invalid"));
  EXPECT_THAT(openError("a_name_much_too_long_for_linux"), test::HasSubstr("1 to 15 characters"));
}

TEST(SocketCanBus, RoundTripOnVcan0) {
  const int err = pfCanErrno();
  if (err != 0)
    GTEST_SKIP() << "no SocketCAN on this machine (socket(PF_CAN): " << std::strerror(err)
                 << "); see docs/can.md to set up vcan0";
  if (::if_nametoindex("vcan0") == 0)
    GTEST_SKIP() << "no vcan0 interface (ip link add dev vcan0 type vcan && ip link set vcan0 "
                    "up)";
  SocketCanBus a("vcan0");
  SocketCanBus b("vcan0");
  EXPECT_EQ(a.interfaceName(), "vcan0");
  CanFrame drain;
  while (b.receive(drain)) {
  }
  CanFrame sent;
  encodeCommand(MitLimits{}, 0x12, {1.0, -2.0, 50.0, 1.0, 3.0}, sent);
  ASSERT_TRUE(a.send(sent));
  ASSERT_TRUE(a.send(makeSpecialFrame(0x12, MitSpecial::EnterMotorMode)));
  CanFrame got;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
  bool received = false;
  while (!(received = b.receive(got)) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  ASSERT_TRUE(received);
  EXPECT_EQ(got.id, sent.id);
  EXPECT_EQ(got.dlc, sent.dlc);
  EXPECT_EQ(got.data, sent.data);
  EXPECT_FALSE(got.isError());
  while (!b.receive(got) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  EXPECT_EQ(parseSpecialFrame(got), MitSpecial::EnterMotorMode);
  EXPECT_FALSE(a.receive(got)) << "a socket does not receive its own frames";
  EXPECT_FALSE(a.send(makeErrorFrame(0x40))) << "error frames cannot be sent";
  CanFrame big = sent;
  big.id = 0x800;
  EXPECT_FALSE(a.send(big)) << "11-bit identifiers only";
  EXPECT_EQ(a.stats().sent, 2u);
  EXPECT_EQ(a.stats().dropped, 2u);
  EXPECT_EQ(a.controllerState(), a.controllerState());  // a query that does not throw
}

// In-process bus ------------------------------------------------------------------------------

CanFrame numbered(std::uint32_t k) {
  CanFrame f;
  f.id = k & kMaxStandardId;
  f.dlc = 8;
  for (int i = 0; i < 4; ++i) f.data[i] = static_cast<std::uint8_t>(k >> (8 * i));
  return f;
}

std::uint32_t numberOf(const CanFrame& f) {
  std::uint32_t k = 0;
  for (int i = 0; i < 4; ++i) k |= std::uint32_t{f.data[i]} << (8 * i);
  return k;
}

TEST(InProcessCanBus, DeliversInOrderInBothDirections) {
  InProcessCanBus bus(64);
  for (std::uint32_t k = 0; k < 50; ++k) {
    ASSERT_TRUE(bus.robotSide().send(numbered(k)));
    ASSERT_TRUE(bus.motorSide().send(numbered(1000 + k)));
  }
  EXPECT_EQ(bus.pending(BusSide::Motor), 50u);
  EXPECT_EQ(bus.pending(BusSide::Robot), 50u);
  CanFrame f;
  for (std::uint32_t k = 0; k < 50; ++k) {
    ASSERT_TRUE(bus.motorSide().receive(f));
    EXPECT_EQ(numberOf(f), k);
    ASSERT_TRUE(bus.robotSide().receive(f));
    EXPECT_EQ(numberOf(f), 1000 + k);
  }
  EXPECT_FALSE(bus.motorSide().receive(f));
  EXPECT_FALSE(bus.robotSide().receive(f));
  EXPECT_EQ(bus.robotSide().stats().sent, 50u);
  EXPECT_EQ(bus.robotSide().stats().received, 50u);
}

TEST(InProcessCanBus, FullQueueDropsAndCounts) {
  InProcessCanBus bus(5);
  EXPECT_EQ(bus.capacity(), 8u);  // rounded up to a power of two
  int accepted = 0;
  for (std::uint32_t k = 0; k < 11; ++k) accepted += bus.robotSide().send(numbered(k)) ? 1 : 0;
  EXPECT_EQ(accepted, 8);
  EXPECT_EQ(bus.robotSide().stats().dropped, 3u);
  EXPECT_EQ(bus.robotSide().stats().sent, 8u);
  CanFrame f;
  for (std::uint32_t k = 0; k < 8; ++k) {
    ASSERT_TRUE(bus.motorSide().receive(f));
    EXPECT_EQ(numberOf(f), k);  // the oldest survive, the newest were dropped
  }
  // Wrap-around after draining.
  for (std::uint32_t k = 0; k < 8; ++k) ASSERT_TRUE(bus.robotSide().send(numbered(100 + k)));
  for (std::uint32_t k = 0; k < 8; ++k) {
    ASSERT_TRUE(bus.motorSide().receive(f));
    EXPECT_EQ(numberOf(f), 100 + k);
  }
  bus.robotSide().send(numbered(1));
  bus.clear();
  EXPECT_EQ(bus.pending(BusSide::Motor), 0u);
  EXPECT_THROW(InProcessCanBus(0), std::invalid_argument);
}

TEST(InProcessCanBus, InjectedErrorFramesArriveAsErrors) {
  InProcessCanBus bus(4);
  ASSERT_TRUE(bus.robotSide().send(numbered(1)));
  ASSERT_TRUE(bus.injectErrorFrame(BusSide::Motor, 0x40));
  CanFrame f;
  ASSERT_TRUE(bus.motorSide().receive(f));
  EXPECT_FALSE(f.isError());
  ASSERT_TRUE(bus.motorSide().receive(f));
  EXPECT_TRUE(f.isError());
  EXPECT_EQ(f.id, 0x40u);
  EXPECT_EQ(bus.motorSide().stats().error_frames, 1u);
  EXPECT_EQ(bus.robotSide().stats().error_frames, 0u);
}

TEST(InProcessCanBus, TwoThreadsTransferEveryFrameInOrder) {
  InProcessCanBus bus(16);
  constexpr std::uint32_t kFrames = 200000;
  std::thread producer([&] {
    for (std::uint32_t k = 0; k < kFrames;) {
      if (bus.robotSide().send(numbered(k)))
        ++k;
      else
        std::this_thread::yield();
    }
  });
  std::uint32_t expected = 0;
  bool in_order = true;
  CanFrame f;
  while (expected < kFrames) {
    if (!bus.motorSide().receive(f)) {
      std::this_thread::yield();
      continue;
    }
    if (numberOf(f) != expected || f.id != (expected & kMaxStandardId)) in_order = false;
    ++expected;
  }
  producer.join();
  EXPECT_TRUE(in_order);
  EXPECT_EQ(bus.motorSide().stats().received, kFrames);
  EXPECT_EQ(bus.robotSide().stats().sent, kFrames);
}

}  // namespace
}  // namespace wj::can
