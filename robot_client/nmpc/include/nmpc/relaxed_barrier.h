#pragma once
/// @file Relaxed logarithmic barrier of Feller & Ebenbauer ("Relaxed logarithmic barrier
/// function based model predictive control of linear systems", IEEE TAC 2017):
///   B(h) = -mu ln(h)                                        for h > delta
///   B(h) = mu/2 (((h - 2 delta) / delta)^2 - 1) - mu ln(delta)   for h <= delta
/// C2 at h = delta, defined for every h, so an infeasible iterate has a finite cost.

#include <cmath>

namespace wj::nmpc {

/// Parameters of one relaxed barrier.
struct BarrierSettings {
  double mu = 0.1;     ///< weight of the barrier [cost units]
  double delta = 5.0;  ///< relaxation: below this the log becomes a quadratic [constraint units]
};

/// Value and first two derivatives of the relaxed barrier at h.
struct BarrierValue {
  double value = 0.0;
  double d1 = 0.0;  ///< dB/dh
  double d2 = 0.0;  ///< d2B/dh2 (> 0)
};

/// B(h), B'(h), B''(h) of the relaxed log barrier with settings `s`.
inline BarrierValue evalRelaxedBarrier(const BarrierSettings& s, double h) {
  BarrierValue b;
  if (h > s.delta) {
    b.value = -s.mu * std::log(h);
    b.d1 = -s.mu / h;
    b.d2 = s.mu / (h * h);
  } else {
    const double r = (h - 2.0 * s.delta) / s.delta;
    b.value = 0.5 * s.mu * (r * r - 1.0) - s.mu * std::log(s.delta);
    b.d1 = s.mu * r / s.delta;
    b.d2 = s.mu / (s.delta * s.delta);
  }
  return b;
}

}  // namespace wj::nmpc
