#include "nmpc/policy.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wj::nmpc {

Policy::Policy(int max_intervals)
    : x_ref_(static_cast<std::size_t>(max_intervals + 1), State::Zero()),
      u_ff_(static_cast<std::size_t>(max_intervals), Input::Zero()),
      K_(static_cast<std::size_t>(max_intervals), InputStateMatrix::Zero()),
      contact_(static_cast<std::size_t>(max_intervals), ContactFlags{true, true, true, true}) {}

void Policy::reset(double t0, double dt, int num_intervals) {
  if (num_intervals > capacity() || num_intervals < 0)
    throw std::length_error("Policy::reset: more intervals than the capacity");
  t0_ = t0;
  dt_ = dt;
  n_ = num_intervals;
}

void Policy::copyFrom(const Policy& other) {
  reset(other.t0_, other.dt_, other.n_);
  std::copy_n(other.x_ref_.begin(), n_ + 1, x_ref_.begin());
  std::copy_n(other.u_ff_.begin(), n_, u_ff_.begin());
  std::copy_n(other.K_.begin(), n_, K_.begin());
  std::copy_n(other.contact_.begin(), n_, contact_.begin());
  normal_ = other.normal_;
}

const ContactFlags& Policy::calcContact(double t) const {
  int k = 0;
  double a = 0.0;
  locate(t, k, a);
  return contact_[k];
}

PolicyExchange::PolicyExchange(int max_intervals)
    : buffers_{Policy(max_intervals), Policy(max_intervals), Policy(max_intervals)}, middle_(1) {}

void PolicyExchange::publish(const Policy& policy) {
  buffers_[back_].copyFrom(policy);
  // Hand the written buffer over as the fresh middle one; take the old middle as the next back.
  const std::uint8_t old =
      middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel);
  back_ = old & ~kFresh;
}

bool PolicyExchange::fetch(Policy& out) {
  if ((middle_.load(std::memory_order_acquire) & kFresh) == 0) return false;
  const std::uint8_t old =
      middle_.exchange(static_cast<std::uint8_t>(front_), std::memory_order_acq_rel);
  front_ = old & ~kFresh;
  out.copyFrom(buffers_[front_]);
  return true;
}

void Policy::locate(double t, int& k, double& a) const {
  const double s = std::clamp((t - t0_) / dt_, 0.0, static_cast<double>(n_));
  k = std::min(static_cast<int>(std::floor(s)), n_ - 1);
  a = s - k;
}

void Policy::calcState(double t, State& x) const {
  int k = 0;
  double a = 0.0;
  locate(t, k, a);
  x = (1.0 - a) * x_ref_[k] + a * x_ref_[k + 1];
}

void Policy::calcFeedforward(double t, Input& u) const {
  int k = 0;
  double a = 0.0;
  locate(t, k, a);
  (void)a;
  u = u_ff_[k];  // held over the interval, as in the transcription
}

void Policy::calcInput(double t, const State& x, Input& u) const {
  int k = 0;
  double a = 0.0;
  locate(t, k, a);
  u = u_ff_[k];
  const State dx = x - ((1.0 - a) * x_ref_[k] + a * x_ref_[k + 1]);
  u.noalias() += K_[k] * dx;
}

}  // namespace wj::nmpc
