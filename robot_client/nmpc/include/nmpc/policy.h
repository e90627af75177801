#pragma once
/// @file The time-indexed policy that the NMPC publishes to the control loop:
///   u(t, x) = u_ff(t) + K(t) (x - x_ref(t)),
/// on the solver's uniform time grid: x_ref interpolated linearly between nodes, u_ff and K held
/// over each interval (the transcription holds the input over the interval too). The policy
/// also carries the planned contact of every interval and the ground normal, so that the loop
/// needs nothing else from the MPC. Fixed capacity: copyFrom() and every query are
/// allocation-free, so a real-time loop can own a preallocated Policy and refresh it from the
/// MPC's through a PolicyExchange.

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <cstdint>
#include <vector>

#include "nmpc/types.h"

namespace wj::nmpc {

/// See the file comment.
class Policy {
 public:
  /// An empty policy with room for `max_intervals` intervals (allocates once, here).
  explicit Policy(int max_intervals = 0);

  /// Capacity in intervals.
  int capacity() const { return static_cast<int>(u_ff_.size()); }
  /// Intervals in use (0: empty).
  int numIntervals() const { return n_; }
  /// True before the first reset().
  bool empty() const { return n_ == 0; }
  /// Time of node 0 [s].
  double startTime() const { return t0_; }
  /// Time of the last node [s].
  double endTime() const { return t0_ + n_ * dt_; }
  /// Interval length [s].
  double dt() const { return dt_; }

  /// Starts filling a policy of `num_intervals` intervals of `dt` from `t0`. Throws
  /// std::length_error if that exceeds the capacity (never in a correctly sized loop).
  void reset(double t0, double dt, int num_intervals);
  /// Node values: x_ref at nodes 0..n, u_ff and K at nodes 0..n-1.
  State& stateAt(int node) { return x_ref_[node]; }
  Input& inputAt(int node) { return u_ff_[node]; }
  InputStateMatrix& gainAt(int node) { return K_[node]; }
  const State& stateAt(int node) const { return x_ref_[node]; }
  const Input& inputAt(int node) const { return u_ff_[node]; }
  const InputStateMatrix& gainAt(int node) const { return K_[node]; }
  /// Planned contact over interval `node`.
  ContactFlags& contactAt(int node) { return contact_[node]; }
  const ContactFlags& contactAt(int node) const { return contact_[node]; }
  /// Ground normal in W the plan assumes.
  Eigen::Vector3d& normal() { return normal_; }
  const Eigen::Vector3d& normal() const { return normal_; }

  /// Copies `other` into this policy's storage. Allocation-free when capacity() >=
  /// other.numIntervals(); throws std::length_error otherwise.
  void copyFrom(const Policy& other);

  /// Reference state x_ref(t) (clamped to the horizon).
  void calcState(double t, State& x) const;
  /// Feed-forward input u_ff(t) (clamped to the horizon).
  void calcFeedforward(double t, Input& u) const;
  /// u(t, x) = u_ff(t) + K(t) (x - x_ref(t)).
  void calcInput(double t, const State& x, Input& u) const;
  /// Planned contact at time t (held over each interval, clamped to the horizon).
  const ContactFlags& calcContact(double t) const;

 private:
  // Interval index and weight of the later node for time t.
  void locate(double t, int& k, double& a) const;

  int n_ = 0;
  double t0_ = 0.0;
  double dt_ = 0.0;
  std::vector<State> x_ref_;
  std::vector<Input> u_ff_;
  std::vector<InputStateMatrix> K_;
  std::vector<ContactFlags> contact_;
  Eigen::Vector3d normal_ = Eigen::Vector3d::UnitZ();
};

/// Lock-free single-producer single-consumer triple buffer of policies: the MPC thread
/// publishes, the real-time loop fetches the latest; neither blocks nor allocates after
/// construction. publish() only from one thread, fetch() only from one (other) thread.
class PolicyExchange {
 public:
  /// Three buffers of `max_intervals` intervals each.
  explicit PolicyExchange(int max_intervals);
  /// Copies `policy` into the back buffer and makes it the latest.
  void publish(const Policy& policy);
  /// If a policy newer than the last fetched one was published, copies it into `out` and
  /// returns true.
  bool fetch(Policy& out);

 private:
  static constexpr std::uint8_t kFresh = 4;  // flag bit in middle_: not yet fetched
  std::array<Policy, 3> buffers_;
  int back_ = 0;                      // producer's
  std::atomic<std::uint8_t> middle_;  // shared: index | kFresh
  int front_ = 2;                     // consumer's
};

}  // namespace wj::nmpc
