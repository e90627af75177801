#pragma once
/// @file Small allocation-free helpers of the jump model's source files (jump_model_*.cpp):
/// fixed-capacity polynomials for the take-off's closed forms, and 2-D rotations in the
/// sagittal (x-z) plane. Internal to the planner library.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>

#include "planner/jump_plan.h"

namespace wj::planner::detail {

// Fixed-capacity polynomial in ascending powers: allocation-free for the DE's hot path.
struct Poly {
  static constexpr int kCap = 14;
  std::array<double, kCap> c{};
  int n = 0;  // number of coefficients in use

  Poly() = default;
  Poly(std::initializer_list<double> coeffs) {
    for (double v : coeffs) c[n++] = v;
  }
  double operator()(double t) const {
    double v = 0.0;
    for (int i = n - 1; i >= 0; --i) v = v * t + c[i];
    return v;
  }
};

inline Poly operator+(const Poly& p, const Poly& q) {
  Poly r;
  r.n = std::max(p.n, q.n);
  for (int i = 0; i < p.n; ++i) r.c[i] += p.c[i];
  for (int i = 0; i < q.n; ++i) r.c[i] += q.c[i];
  return r;
}
inline Poly operator*(double s, const Poly& p) {
  Poly r = p;
  for (int i = 0; i < r.n; ++i) r.c[i] *= s;
  return r;
}
inline Poly operator*(const Poly& p, const Poly& q) {
  Poly r;
  if (p.n == 0 || q.n == 0) return r;
  r.n = std::min(p.n + q.n - 1, Poly::kCap);
  for (int i = 0; i < p.n; ++i)
    for (int j = 0; j < q.n && i + j < Poly::kCap; ++j) r.c[i + j] += p.c[i] * q.c[j];
  return r;
}
inline Poly integral(const Poly& p, double c0 = 0.0) {
  Poly r;
  r.n = std::min(p.n + 1, Poly::kCap);
  r.c[0] = c0;
  for (int i = 0; i + 1 < r.n; ++i) r.c[i + 1] = p.c[i] / (i + 1);
  return r;
}
// p(t), p'(t) and p''(t) (Horner on the value and both derivatives).
inline std::array<double, 3> valueAndDerivatives(const Poly& p, double t) {
  double v = 0.0, d1 = 0.0, half_d2 = 0.0;
  for (int i = p.n - 1; i >= 0; --i) {
    half_d2 = half_d2 * t + d1;
    d1 = d1 * t + v;
    v = v * t + p.c[i];
  }
  return {v, d1, 2.0 * half_d2};
}
inline Poly derivative(const Poly& p) {
  Poly r;
  r.n = std::max(p.n - 1, 0);
  for (int i = 1; i < p.n; ++i) r.c[i - 1] = p.c[i] * i;
  return r;
}

inline Polynomial toPolynomial(const Poly& p) {
  return Polynomial{{p.c.begin(), p.c.begin() + p.n}};
}

// Rotation of body-frame x-z vectors by pitch (nose-up positive): R = [[c, -s], [s, c]].
// Built once per sample so that the trigonometry is not repeated for every point.
struct Rot2 {
  double c = 1.0, s = 0.0;
  Rot2() = default;
  explicit Rot2(double pitch) : c(std::cos(pitch)), s(std::sin(pitch)) {}
  Eigen::Vector2d operator*(const Eigen::Vector2d& v) const {
    return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
  }
  Eigen::Vector2d transposeTimes(const Eigen::Vector2d& v) const {
    return {c * v.x() + s * v.y(), -s * v.x() + c * v.y()};
  }
};
inline Eigen::Vector2d rot(double pitch, const Eigen::Vector2d& v) {
  return Rot2(pitch) * v;
}

inline double wrapToPi(double a) {
  return std::remainder(a, 2.0 * M_PI);
}

inline double smoothstep(double xi) {
  xi = std::clamp(xi, 0.0, 1.0);
  return xi * xi * (3.0 - 2.0 * xi);
}
inline double smoothstepRate(double xi) {
  return (xi <= 0.0 || xi >= 1.0) ? 0.0 : 6.0 * xi * (1.0 - xi);
}
// Constant acceleration to the midpoint, constant deceleration after it: 0 -> 1 over [0, 1],
// at rest at both ends (the drive-limited tuck, postures.drive_limited_tuck).
inline double bangBang(double xi) {
  xi = std::clamp(xi, 0.0, 1.0);
  return xi < 0.5 ? 2.0 * xi * xi : 1.0 - 2.0 * (1.0 - xi) * (1.0 - xi);
}
inline double bangBangRate(double xi) {
  return (xi <= 0.0 || xi >= 1.0) ? 0.0 : (xi < 0.5 ? 4.0 * xi : 4.0 * (1.0 - xi));
}

// R_y(q) v = (c x + s z, -s x + c z) and its derivative (-s x + c z, -c x - s z).
inline Eigen::Vector2d Rv(double sn, double cs, const Eigen::Vector2d& v) {
  return Eigen::Vector2d(cs * v.x() + sn * v.y(), -sn * v.x() + cs * v.y());
}
inline Eigen::Vector2d dRv(double sn, double cs, const Eigen::Vector2d& v) {
  return Eigen::Vector2d(-sn * v.x() + cs * v.y(), -cs * v.x() - sn * v.y());
}

}  // namespace wj::planner::detail
