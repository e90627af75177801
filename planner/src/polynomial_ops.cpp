#include "planner/polynomial_ops.h"

#include <algorithm>

namespace wj::planner {

Polynomial add(const Polynomial& p, const Polynomial& q) {
  Polynomial r;
  r.c.assign(std::max(p.c.size(), q.c.size()), 0.0);
  for (std::size_t i = 0; i < p.c.size(); ++i) r.c[i] += p.c[i];
  for (std::size_t i = 0; i < q.c.size(); ++i) r.c[i] += q.c[i];
  return r;
}

Polynomial scale(const Polynomial& p, double s) {
  Polynomial r = p;
  for (double& c : r.c) c *= s;
  return r;
}

Polynomial multiply(const Polynomial& p, const Polynomial& q) {
  Polynomial r;
  if (p.c.empty() || q.c.empty()) return r;
  r.c.assign(p.c.size() + q.c.size() - 1, 0.0);
  for (std::size_t i = 0; i < p.c.size(); ++i)
    for (std::size_t j = 0; j < q.c.size(); ++j) r.c[i + j] += p.c[i] * q.c[j];
  return r;
}

Polynomial integrate(const Polynomial& p, double c0) {
  Polynomial r;
  r.c.resize(p.c.size() + 1);
  r.c[0] = c0;
  for (std::size_t i = 0; i < p.c.size(); ++i) r.c[i + 1] = p.c[i] / static_cast<double>(i + 1);
  return r;
}

Polynomial derivative(const Polynomial& p) {
  Polynomial r;
  for (std::size_t i = 1; i < p.c.size(); ++i) r.c.push_back(p.c[i] * static_cast<double>(i));
  return r;
}

Polynomial shift(const Polynomial& p, double s) {
  // Horner in polynomial arithmetic: r = (((c_n)(tau + s) + c_{n-1})(tau + s) + ...).
  const Polynomial linear{{s, 1.0}};
  Polynomial r;
  for (auto it = p.c.rbegin(); it != p.c.rend(); ++it)
    r = add(multiply(r, linear), Polynomial{{*it}});
  return r;
}

}  // namespace wj::planner
