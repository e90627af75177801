#include "can/can_bus.h"

#include <fcntl.h>
#include <libsocketcan.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace wj::can {
namespace {

std::string errnoText(int err) {
  return std::strerror(err);
}

const char* kBringUp =
    "bring it up with `ip link set <name> type can bitrate 1000000 && ip link set <name> up`, "
    "or for tests `ip link add dev vcan0 type vcan && ip link set vcan0 up` (see docs/can.md)";

std::size_t roundUpToPowerOfTwo(std::size_t n) {
  std::size_t p = 1;
  while (p < n) p <<= 1;
  return p;
}

}  // namespace

// SocketCanBus ---------------------------------------------------------------------------------

SocketCanBus::SocketCanBus(const std::string& interface_name) : name_(interface_name) {
  if (name_.empty() || name_.size() >= IFNAMSIZ)
    throw CanError("CAN interface name '" + name_ + "' is invalid: it must have 1 to " +
                   std::to_string(IFNAMSIZ - 1) + " characters");
  fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) {
    const int err = errno;
    if (err == EAFNOSUPPORT)
      throw CanError(
          "SocketCAN is not available: the kernel has no PF_CAN support (socket: " +
          errnoText(err) +
          "); load the can and can_raw modules (modprobe can can_raw) or use the in-process "
          "bus (robot_client --backend sim --via-can)");
    if (err == EPROTONOSUPPORT)
      throw CanError(
          "SocketCAN raw sockets are not available: the kernel has PF_CAN but no "
          "CAN_RAW protocol (socket: " +
          errnoText(err) + "); load the can_raw module (modprobe can_raw)");
    throw CanError("cannot open a CAN raw socket for '" + name_ + "' (socket: " + errnoText(err) +
                   ")");
  }
  const auto fail = [this](const std::string& what) {
    ::close(fd_);
    fd_ = -1;
    throw CanError(what);
  };
  const unsigned int index = ::if_nametoindex(name_.c_str());
  if (index == 0) {
    const int err = errno;
    fail("CAN interface '" + name_ + "' does not exist (if_nametoindex: " + errnoText(err) + "); " +
         kBringUp);
  }
  const can_err_mask_t err_mask = CAN_ERR_MASK;
  if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask)) != 0)
    fail("cannot enable error frames on '" + name_ +
         "' (setsockopt CAN_RAW_ERR_FILTER: " + errnoText(errno) + ")");
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(index);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    const int err = errno;
    fail("cannot bind the CAN socket to '" + name_ + "' (bind: " + errnoText(err) +
         "); is it a CAN interface, and is it up? " + kBringUp);
  }
}

SocketCanBus::~SocketCanBus() {
  if (fd_ >= 0) ::close(fd_);
}

bool SocketCanBus::send(const CanFrame& frame) {
  if (frame.isError() || frame.id > kMaxStandardId || frame.dlc > kMaxDataLength) {
    ++stats_.dropped;
    return false;
  }
  can_frame cf{};
  cf.can_id = frame.id | (frame.isRtr() ? CAN_RTR_FLAG : 0u);
  cf.len = frame.dlc;
  std::memcpy(cf.data, frame.data.data(), kMaxDataLength);
  const ssize_t n = ::write(fd_, &cf, sizeof(cf));
  if (n != static_cast<ssize_t>(sizeof(cf))) {
    ++stats_.dropped;  // EAGAIN / ENOBUFS: the transmit queue is full; or the bus is down
    return false;
  }
  ++stats_.sent;
  return true;
}

bool SocketCanBus::receive(CanFrame& out) {
  for (;;) {
    can_frame cf{};
    const ssize_t n = ::read(fd_, &cf, sizeof(cf));
    if (n != static_cast<ssize_t>(sizeof(cf))) return false;  // EAGAIN: nothing waiting
    if ((cf.can_id & CAN_EFF_FLAG) != 0 && (cf.can_id & CAN_ERR_FLAG) == 0)
      continue;  // 29-bit frames are not part of this protocol
    out = CanFrame{};
    out.dlc = cf.len > kMaxDataLength ? static_cast<std::uint8_t>(kMaxDataLength) : cf.len;
    std::memcpy(out.data.data(), cf.data, kMaxDataLength);
    if ((cf.can_id & CAN_ERR_FLAG) != 0) {
      out.id = cf.can_id & CAN_ERR_MASK;
      out.flags = CanFrame::kFlagError;
      ++stats_.error_frames;
    } else {
      out.id = cf.can_id & CAN_SFF_MASK;
      out.flags = (cf.can_id & CAN_RTR_FLAG) != 0 ? CanFrame::kFlagRtr : 0;
    }
    ++stats_.received;
    return true;
  }
}

std::string SocketCanBus::controllerState() const {
  int state = -1;
  if (::can_get_state(name_.c_str(), &state) != 0) return "unknown";
  switch (state) {
    case CAN_STATE_ERROR_ACTIVE:
      return "error-active";
    case CAN_STATE_ERROR_WARNING:
      return "error-warning";
    case CAN_STATE_ERROR_PASSIVE:
      return "error-passive";
    case CAN_STATE_BUS_OFF:
      return "bus-off";
    case CAN_STATE_STOPPED:
      return "stopped";
    case CAN_STATE_SLEEPING:
      return "sleeping";
    default:
      return "unknown";
  }
}

// InProcessCanBus ------------------------------------------------------------------------------

InProcessCanBus::Queue::Queue(std::size_t capacity)
    : slots_(std::make_unique<CanFrame[]>(capacity)), mask_(capacity - 1) {}

bool InProcessCanBus::Queue::push(const CanFrame& frame) {
  const std::size_t tail = tail_.load(std::memory_order_relaxed);
  const std::size_t head = head_.load(std::memory_order_acquire);
  if (tail - head > mask_) return false;  // full
  slots_[tail & mask_] = frame;
  tail_.store(tail + 1, std::memory_order_release);
  return true;
}

bool InProcessCanBus::Queue::pop(CanFrame& out) {
  const std::size_t head = head_.load(std::memory_order_relaxed);
  const std::size_t tail = tail_.load(std::memory_order_acquire);
  if (head == tail) return false;  // empty
  out = slots_[head & mask_];
  head_.store(head + 1, std::memory_order_release);
  return true;
}

std::size_t InProcessCanBus::Queue::size() const {
  return tail_.load(std::memory_order_acquire) - head_.load(std::memory_order_acquire);
}

void InProcessCanBus::Queue::clear() {
  head_.store(tail_.load(std::memory_order_relaxed), std::memory_order_relaxed);
}

bool InProcessCanBus::Endpoint::send(const CanFrame& frame) {
  if (frame.dlc > kMaxDataLength || !out_.push(frame)) {
    countDrop();
    return false;
  }
  sent_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

bool InProcessCanBus::Endpoint::receive(CanFrame& out) {
  if (!in_.pop(out)) return false;
  received_.fetch_add(1, std::memory_order_relaxed);
  if (out.isError()) error_frames_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

CanBusStats InProcessCanBus::Endpoint::stats() const {
  return {sent_.load(std::memory_order_relaxed), received_.load(std::memory_order_relaxed),
          dropped_.load(std::memory_order_relaxed), error_frames_.load(std::memory_order_relaxed)};
}

InProcessCanBus::InProcessCanBus(std::size_t capacity)
    : capacity_(capacity == 0 ? throw std::invalid_argument(
                                    "InProcessCanBus capacity must be >= 1 frame, got 0")
                              : roundUpToPowerOfTwo(capacity)),
      to_motor_(capacity_),
      to_robot_(capacity_),
      robot_(to_motor_, to_robot_),
      motor_(to_robot_, to_motor_) {}

CanBus& InProcessCanBus::endpoint(BusSide side) {
  return side == BusSide::Robot ? static_cast<CanBus&>(robot_) : static_cast<CanBus&>(motor_);
}

bool InProcessCanBus::injectErrorFrame(BusSide to, std::uint32_t error_class) {
  Queue& q = to == BusSide::Robot ? to_robot_ : to_motor_;
  return q.push(makeErrorFrame(error_class));
}

std::size_t InProcessCanBus::pending(BusSide side) const {
  return side == BusSide::Robot ? to_robot_.size() : to_motor_.size();
}

void InProcessCanBus::clear() {
  to_motor_.clear();
  to_robot_.clear();
}

}  // namespace wj::can
