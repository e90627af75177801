#pragma once
/// @file The time-indexed policy that the NMPC publishes to the control loop:
///   u(t, x) = u_ff(t) + K(t) (x - x_ref(t)),
/// on the solver's uniform time grid: x_ref interpolated linearly between nodes, u_ff and K held
/// over each interval (the transcription holds the input over the interval too). Fixed capacity:
/// copyFrom() and every query are allocation-free, so a real-time loop can own a preallocated
/// Policy and refresh it from the MPC's (double buffer).

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
  bool empty() const { return n_ == 0; }
  double startTime() const { return t0_; }
  double endTime() const { return t0_ + n_ * dt_; }
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

  /// Copies `other` into this policy's storage. Allocation-free when capacity() >=
  /// other.numIntervals(); throws std::length_error otherwise.
  void copyFrom(const Policy& other);

  /// Reference state x_ref(t) (clamped to the horizon).
  void calcState(double t, State& x) const;
  /// Feed-forward input u_ff(t) (clamped to the horizon).
  void calcFeedforward(double t, Input& u) const;
  /// u(t, x) = u_ff(t) + K(t) (x - x_ref(t)).
  void calcInput(double t, const State& x, Input& u) const;

 private:
  // Interval index and weight of the later node for time t.
  void locate(double t, int& k, double& a) const;

  int n_ = 0;
  double t0_ = 0.0;
  double dt_ = 0.0;
  std::vector<State> x_ref_;
  std::vector<Input> u_ff_;
  std::vector<InputStateMatrix> K_;
};

}  // namespace wj::nmpc
