#pragma once
/// @file CAN buses: the abstract non-blocking bus, a Linux SocketCAN raw socket, and an
/// in-process bus (lock-free queues) that connects the robot side to motor emulators.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

#include "can/can_frame.h"

namespace wj::can {

/// Failure to open or configure a CAN bus. The message says what is missing and what to do.
class CanError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Traffic counters of one bus endpoint (since construction).
struct CanBusStats {
  std::uint64_t sent = 0;          ///< frames handed to the bus
  std::uint64_t received = 0;      ///< frames taken from the bus (error frames included)
  std::uint64_t dropped = 0;       ///< frames send() could not queue (full queue / buffer)
  std::uint64_t error_frames = 0;  ///< error frames received
};

/// One endpoint of a CAN bus. send() and receive() never block, allocate, lock or log, so
/// they may be called from the real-time loop. One thread uses one endpoint.
class CanBus {
 public:
  virtual ~CanBus() = default;
  CanBus(const CanBus&) = delete;
  CanBus& operator=(const CanBus&) = delete;

  /// Queues `frame` for transmission; false if it could not be queued now (counted as
  /// dropped) or the bus cannot carry it (error frames cannot be sent).
  virtual bool send(const CanFrame& frame) = 0;
  /// Takes the oldest received frame into `out`; false if none is waiting.
  virtual bool receive(CanFrame& out) = 0;
  /// Counters of this endpoint.
  virtual CanBusStats stats() const = 0;

 protected:
  CanBus() = default;
};

/// A raw SocketCAN socket (PF_CAN, SOCK_RAW, CAN_RAW) bound to one interface, non-blocking,
/// with every error class enabled (CAN_RAW_ERR_FILTER), so that bus errors arrive as error
/// frames. Frames the socket itself sent are not looped back to it.
class SocketCanBus final : public CanBus {
 public:
  /// Opens the socket on `interface_name` (e.g. "can0", "vcan0"). Throws CanError when the
  /// kernel has no PF_CAN support (this machine), when the interface does not exist, or when
  /// the socket cannot be configured; the message names the cause and the remedy.
  explicit SocketCanBus(const std::string& interface_name);
  ~SocketCanBus() override;

  bool send(const CanFrame& frame) override;
  bool receive(CanFrame& out) override;
  CanBusStats stats() const override { return stats_; }

  /// Name of the interface the socket is bound to.
  const std::string& interfaceName() const { return name_; }
  /// State of the CAN controller from libsocketcan ("error-active", "error-warning",
  /// "error-passive", "bus-off", "stopped", "sleeping"; "unknown" for virtual interfaces that
  /// do not report one). Not real-time safe (netlink query).
  std::string controllerState() const;

 private:
  std::string name_;
  int fd_ = -1;
  CanBusStats stats_;
};

/// Which end of an InProcessCanBus.
enum class BusSide : std::uint8_t {
  Robot,  ///< the controller's end (CanRobot)
  Motor,  ///< the motors' end (MitMotorEmulator)
};

/// An in-process CAN bus between two endpoints: what one side sends, the other receives, in
/// order. Each direction is a fixed-capacity lock-free single-producer single-consumer queue;
/// nothing is allocated after construction; a frame sent into a full queue is dropped and
/// counted. One thread may send on a side while another receives on the other side.
class InProcessCanBus {
 public:
  /// A bus whose queues hold `capacity` frames per direction (>= 1; rounded up to a power of
  /// two). Throws std::invalid_argument for capacity 0.
  explicit InProcessCanBus(std::size_t capacity = 256);
  InProcessCanBus(const InProcessCanBus&) = delete;
  InProcessCanBus& operator=(const InProcessCanBus&) = delete;

  /// The endpoint of `side` (lives as long as the bus).
  CanBus& endpoint(BusSide side);
  /// The robot's endpoint.
  CanBus& robotSide() { return endpoint(BusSide::Robot); }
  /// The motors' endpoint.
  CanBus& motorSide() { return endpoint(BusSide::Motor); }

  /// Makes the endpoint on `to` receive an error frame of class `error_class`, as a CAN
  /// controller reports a bus error. Must be called from the thread that sends on the other
  /// side (it produces into the same queue). False if the queue is full.
  bool injectErrorFrame(BusSide to, std::uint32_t error_class);
  /// Frames queue capacity per direction.
  std::size_t capacity() const { return capacity_; }
  /// Frames waiting to be received by `side`.
  std::size_t pending(BusSide side) const;
  /// Empties both queues. Not thread-safe: only while no endpoint is in use.
  void clear();

 private:
  class Queue {
   public:
    explicit Queue(std::size_t capacity);
    bool push(const CanFrame& frame);
    bool pop(CanFrame& out);
    std::size_t size() const;
    void clear();

   private:
    std::unique_ptr<CanFrame[]> slots_;
    std::size_t mask_;
    alignas(64) std::atomic<std::size_t> head_{0};  ///< next slot to read (consumer)
    alignas(64) std::atomic<std::size_t> tail_{0};  ///< next slot to write (producer)
  };
  class Endpoint final : public CanBus {
   public:
    Endpoint(Queue& out, Queue& in) : out_(out), in_(in) {}
    bool send(const CanFrame& frame) override;
    bool receive(CanFrame& out) override;
    CanBusStats stats() const override;
    void countDrop() { dropped_.fetch_add(1, std::memory_order_relaxed); }

   private:
    Queue& out_;
    Queue& in_;
    // Atomics so that stats() may be read from another thread.
    std::atomic<std::uint64_t> sent_{0}, received_{0}, dropped_{0}, error_frames_{0};
  };

  std::size_t capacity_;
  Queue to_motor_;
  Queue to_robot_;
  Endpoint robot_;
  Endpoint motor_;
};

}  // namespace wj::can
