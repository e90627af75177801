#pragma once
/// @file Arithmetic on Polynomial (coefficients in ascending powers), used to integrate the
/// force polynomials of the take-off in closed form.

#include "planner/jump_plan.h"

namespace wj::planner {

/// p + q.
Polynomial add(const Polynomial& p, const Polynomial& q);
/// s * p.
Polynomial scale(const Polynomial& p, double s);
/// p * q.
Polynomial multiply(const Polynomial& p, const Polynomial& q);
/// The antiderivative P with P(0) = c0 and P' = p.
Polynomial integrate(const Polynomial& p, double c0 = 0.0);
/// p'.
Polynomial derivative(const Polynomial& p);
/// p(tau + shift) as a polynomial in tau (Taylor shift).
Polynomial shift(const Polynomial& p, double shift);

}  // namespace wj::planner
