#include "planner/plan_knots.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wj::planner {

namespace {

bool finite(const PlanarState& s) {
  return std::isfinite(s.x) && std::isfinite(s.z) && std::isfinite(s.pitch) &&
         std::isfinite(s.vx) && std::isfinite(s.vz) && std::isfinite(s.pitch_rate);
}

// Cubic Hermite value and derivative on [0, h] at s = tau / h.
struct Hermite {
  double h00, h10, h01, h11;  // value basis (h10, h11 already times h)
  double d00, d10, d01, d11;  // derivative basis
  Hermite(double s, double h) {
    const double s2 = s * s, s3 = s2 * s;
    h00 = 2 * s3 - 3 * s2 + 1;
    h10 = (s3 - 2 * s2 + s) * h;
    h01 = -2 * s3 + 3 * s2;
    h11 = (s3 - s2) * h;
    d00 = (6 * s2 - 6 * s) / h;
    d10 = 3 * s2 - 4 * s + 1;
    d01 = (-6 * s2 + 6 * s) / h;
    d11 = 3 * s2 - 2 * s;
  }
  double value(double p0, double m0, double p1, double m1) const {
    return h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1;
  }
  double rate(double p0, double m0, double p1, double m1) const {
    return d00 * p0 + d10 * m0 + d01 * p1 + d11 * m1;
  }
};

}  // namespace

Eigen::MatrixXd knotTorqueSlopes(const PlanKnots& K) {
  const int n = K.size();
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n, K.tau.cols());
  int first = 0;
  while (first < n) {
    int last = first;
    while (last + 1 < n && K.t[last + 1] > K.t[last]) ++last;
    const int count = last - first + 1;
    for (int k = first; k <= last; ++k) {
      if (count == 2) {
        m.row(k) = (K.tau.row(last) - K.tau.row(first)) / (K.t[last] - K.t[first]);
        continue;
      }
      // The three knots around k (shifted inside the phase at its ends).
      const int c = std::clamp(k, first + 1, last - 1);
      const double h0 = K.t[c] - K.t[c - 1], h1 = K.t[c + 1] - K.t[c];
      double w0, w1, w2;
      if (k == first) {
        w0 = -(2 * h0 + h1) / (h0 * (h0 + h1));
        w1 = (h0 + h1) / (h0 * h1);
        w2 = -h0 / (h1 * (h0 + h1));
      } else if (k == last) {
        w0 = h1 / (h0 * (h0 + h1));
        w1 = -(h0 + h1) / (h0 * h1);
        w2 = (2 * h1 + h0) / (h1 * (h0 + h1));
      } else {
        w0 = -h1 / (h0 * (h0 + h1));
        w1 = (h1 - h0) / (h0 * h1);
        w2 = h0 / (h1 * (h0 + h1));
      }
      m.row(k) = w0 * K.tau.row(c - 1) + w1 * K.tau.row(c) + w2 * K.tau.row(c + 1);
    }
    first = last + 1;
  }
  return m;
}

std::string checkKnots(const JumpPlan& plan) {
  const PlanKnots& K = plan.knots;
  const int n = K.size();
  if (n < 2) return "the plan has fewer than 2 knots";
  if (static_cast<int>(K.centroidal.size()) != n)
    return "knots: " + std::to_string(K.centroidal.size()) + " CoM states for " +
           std::to_string(n) + " knot times";
  for (const auto* m : {&K.q, &K.qd, &K.tau})
    if (m->rows() != n || m->cols() != model::kNumJoints)
      return "knots: joint arrays must be " + std::to_string(n) + " x 16";
  if (!std::isfinite(plan.t3) || !(plan.t3 > 0.0)) return "knots: t3 must be finite and > 0";
  for (int k = 0; k < n; ++k) {
    if (!std::isfinite(K.t[k])) return "knots: time " + std::to_string(k) + " is not finite";
    if (k > 0 && K.t[k] < K.t[k - 1])
      return "knots: times must not decrease (knot " + std::to_string(k) + ")";
    if (k > 1 && K.t[k] == K.t[k - 1] && K.t[k - 1] == K.t[k - 2])
      return "knots: time " + std::to_string(K.t[k]) + " s appears more than twice";
  }
  if (K.t.front() != 0.0) return "knots: the first knot must be at t = 0";
  if (std::abs(K.t.back() - plan.t3) > 1e-9 * std::max(1.0, plan.t3))
    return "knots: the last knot must be at t3 = " + std::to_string(plan.t3) + " s";
  // With no time thrice, only the first and the last phase can have a single knot time.
  if (K.t[1] == K.t[0] || K.t[n - 1] == K.t[n - 2])
    return "knots: every phase needs two distinct knot times";
  for (const PlanarState& s : K.centroidal)
    if (!finite(s)) return "knots: a CoM state is not finite";
  if (!K.q.allFinite() || !K.qd.allFinite() || !K.tau.allFinite())
    return "knots: a joint value is not finite";
  return "";
}

void densify(JumpPlan& plan, double dt) {
  if (!(dt > 0.0) || dt > 0.002)
    throw std::invalid_argument("densify: dt must be in (0, 0.002] s, got " + std::to_string(dt));
  if (const std::string problem = checkKnots(plan); !problem.empty())
    throw std::invalid_argument(problem);
  const PlanKnots& K = plan.knots;
  const int nk = K.size();
  const Eigen::MatrixXd tau_slope = knotTorqueSlopes(K);
  const int n = static_cast<int>(std::ceil(plan.t3 / dt - 1e-9)) + 1;
  const int nj = model::kNumJoints;
  plan.dt = dt;
  plan.centroidal.resize(static_cast<std::size_t>(n));
  plan.q.resize(n, nj);
  plan.qd.resize(n, nj);
  plan.tau.resize(n, nj);
  int a = 0;  // interval [a, a + 1] with t[a] < t[a + 1]
  for (int k = 0; k < n; ++k) {
    const double t = std::min(k * dt, plan.t3);
    while (a + 2 < nk && (K.t[a + 1] <= K.t[a] || t > K.t[a + 1])) ++a;
    const double h = K.t[a + 1] - K.t[a];
    const Hermite H(std::clamp((t - K.t[a]) / h, 0.0, 1.0), h);
    const int b = a + 1;
    for (int j = 0; j < nj; ++j) {
      plan.q(k, j) = H.value(K.q(a, j), K.qd(a, j), K.q(b, j), K.qd(b, j));
      plan.qd(k, j) = H.rate(K.q(a, j), K.qd(a, j), K.q(b, j), K.qd(b, j));
      plan.tau(k, j) = H.value(K.tau(a, j), tau_slope(a, j), K.tau(b, j), tau_slope(b, j));
    }
    const PlanarState& s0 = K.centroidal[a];
    const PlanarState& s1 = K.centroidal[b];
    PlanarState& s = plan.centroidal[static_cast<std::size_t>(k)];
    s.x = H.value(s0.x, s0.vx, s1.x, s1.vx);
    s.vx = H.rate(s0.x, s0.vx, s1.x, s1.vx);
    s.z = H.value(s0.z, s0.vz, s1.z, s1.vz);
    s.vz = H.rate(s0.z, s0.vz, s1.z, s1.vz);
    s.pitch = H.value(s0.pitch, s0.pitch_rate, s1.pitch, s1.pitch_rate);
    s.pitch_rate = H.rate(s0.pitch, s0.pitch_rate, s1.pitch, s1.pitch_rate);
  }
}

}  // namespace wj::planner
