// Dense Sl1QP solver for small NLPs (see dense_sqp.h for the references).
#include "dense_sqp.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>
#include <vector>

namespace wj::planner {

const char* toString(SqpStatus s) {
  switch (s) {
    case SqpStatus::Converged:
      return "converged";
    case SqpStatus::Stalled:
      return "stalled";
    case SqpStatus::MaxIterations:
      return "max_iterations";
    case SqpStatus::LocallyInfeasible:
      return "locally_infeasible";
    case SqpStatus::SmallStep:
      return "small_step";
    case SqpStatus::LineSearchFailed:
      return "line_search_failed";
    case SqpStatus::EvaluationFailed:
      return "evaluation_failed";
    case SqpStatus::QpFailed:
      return "qp_failed";
  }
  return "?";
}

namespace {

bool finite(double bound) {
  return std::abs(bound) < kSqpInfinity;
}

// The QP of one SQP iteration, in inequality form:
//   min 1/2 d'Bd + g'd + sum_i rho_i s_i   s.t.  a_i'd + s_i >= b_i,  s_i >= 0,
// where s_i is present (an elastic row) only where rho_i > 0 (the linearised constraints; the
// variable bounds are hard rows, met by d = 0). Primal-dual interior point with Mehrotra's
// predictor-corrector (Nocedal & Wright 2006, Algorithm 16.4) on
//   B d + g - A'z = 0,  rho - z - y = 0 (elastic rows),  A d + s - b - w = 0,
//   w.z = mu,  s.y = mu,
// with slacks w, s and multipliers z, y all > 0. The slacks and multipliers are eliminated
// row by row, which leaves one n x n system (B + A' D^-1 A) dd = r per solve (D diagonal).
// Relative accuracy of a QP solution: the SQP's own tolerances are 1e-6.
constexpr double kQpTolerance = 1e-9;

class DenseQp {
 public:
  // Solves the QP for `A` with `rows` rows in all: the first rows - 2n are dense (the
  // linearised constraints); then each variable j has two unit rows, +e_j (lower bound) at
  // dense + 2j and -e_j (upper) after it. Those never enter a product: they add to the Newton
  // matrix's diagonal only. They bound d to a box, and with `screen` the dense rows that hold
  // everywhere in that box are left out: they can neither bind nor be violated, so the
  // solution is the same, and an interior-point iteration costs O(kept rows n^2). False if
  // the Newton matrix cannot be factorised. The result is usable when the iteration limit
  // ends the solve first (the SQP's line search judges it). multipliers() are over all rows
  // (0 on those left out).
  bool solve(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, const Eigen::MatrixXd& A,
             const Eigen::VectorXd& b, const Eigen::VectorXd& rho, int max_iterations,
             bool screen) {
    const int n = static_cast<int>(A.cols());
    const int all = static_cast<int>(A.rows()), dense_all = all - 2 * n;
    kept_.clear();
    for (int i = 0; i < dense_all; ++i) {
      if (screen) {
        // The row's least value over the box b[+e_j] <= d_j <= -b[-e_j].
        double least = 0.0;
        for (int j = 0; j < n; ++j) {
          const double a = A(i, j);
          least += a > 0.0 ? a * b[dense_all + 2 * j] : -a * b[dense_all + 2 * j + 1];
        }
        if (least > b[i] + 1e-12 * (1.0 + std::abs(b[i]))) continue;
      }
      kept_.push_back(i);
    }
    const int kept = static_cast<int>(kept_.size());
    rows_offered += dense_all;
    rows_kept += kept;
    resize(n, kept + 2 * n);
    for (int r = 0; r < kept; ++r) {
      Ad_.row(r) = A.row(kept_[r]);
      b_[r] = b[kept_[r]];
      rho_[r] = rho[kept_[r]];
    }
    b_.tail(2 * n) = b.tail(2 * n);
    rho_.tail(2 * n) = rho.tail(2 * n);
    const bool ok = solveKept(B, g, max_iterations);
    z_all_.setZero(all);
    for (int r = 0; r < kept; ++r) z_all_[kept_[r]] = z_[r];
    z_all_.tail(2 * n) = z_.tail(2 * n);
    return ok;
  }

  int solves = 0, iterations = 0;        // counters for diagnosis
  long rows_offered = 0, rows_kept = 0;  // dense rows, summed over the solves
  const Eigen::VectorXd& step() const { return d_; }
  const Eigen::VectorXd& multipliers() const { return z_all_; }

 private:
  void resize(int n, int rows) {
    n_ = n;
    rows_ = rows;
    dense_ = rows - 2 * n;
    for (Eigen::VectorXd* v :
         {&w_,  &z_,  &s_,  &y_,   &rp_,  &rs_,  &D_,   &h_,        &rcw_, &rcs_, &dw_,
          &dz_, &ds_, &dy_, &dwa_, &dza_, &dsa_, &dya_, &tmp_rows_, &b_,   &rho_})
      v->resize(rows);
    for (Eigen::VectorXd* v : {&d_, &rd_, &dd_, &rhs_}) v->resize(n);
    M_.resize(n, n);
    Ad_.resize(dense_, n);
    AD_.resize(dense_, n);
    if (llt_size_ != n) {
      llt_ = Eigen::LLT<Eigen::MatrixXd>(n);
      llt_size_ = n;
    }
  }

  // The interior point on the kept rows: Ad_, then the 2n unit rows (b_, rho_ over both).
  bool solveKept(const Eigen::MatrixXd& B, const Eigen::VectorXd& g, int max_iterations) {
    ++solves;
    const Eigen::MatrixXd& Ad = Ad_;
    const Eigen::VectorXd& b = b_;
    const Eigen::VectorXd& rho = rho_;
    d_.setZero();
    for (int i = 0; i < rows_; ++i) {
      const double r0 = -b[i];  // a_i'd - b_i at d = 0
      if (rho[i] > 0) {
        s_[i] = std::max(1.0, 1.0 - r0);
        w_[i] = r0 + s_[i];
        z_[i] = std::min(1.0, 0.5 * rho[i]);
        y_[i] = rho[i] - z_[i];
      } else {
        s_[i] = 0.0;
        y_[i] = 0.0;
        w_[i] = std::max(1.0, r0);
        z_[i] = 1.0;
      }
    }
    int count = rows_;
    for (int i = 0; i < rows_; ++i) count += rho[i] > 0 ? 1 : 0;
    // Residuals relative to the data they are made of: the primal rows to b, stationarity and
    // the elastic rows to g and the penalties (the multipliers of elastic rows live in
    // [0, rho]), complementarity to both.
    const double primal_scale = 1.0 + b.lpNorm<Eigen::Infinity>();
    const double dual_scale =
        1.0 + std::max(g.lpNorm<Eigen::Infinity>(), rho.lpNorm<Eigen::Infinity>());
    for (int it = 0; it < max_iterations; ++it) {
      ++iterations;
      rd_.noalias() = B * d_;
      rd_ += g;
      transposeTimesSub(Ad, z_, rd_);
      times(Ad, d_, rp_);
      double mu = 0.0;
      for (int i = 0; i < rows_; ++i) {
        const bool el = rho[i] > 0;
        rp_[i] += (el ? s_[i] : 0.0) - b[i] - w_[i];
        rs_[i] = el ? rho[i] - z_[i] - y_[i] : 0.0;
        mu += w_[i] * z_[i] + (el ? s_[i] * y_[i] : 0.0);
      }
      mu /= std::max(1, count);
      if (rd_.lpNorm<Eigen::Infinity>() <= kQpTolerance * dual_scale &&
          rp_.lpNorm<Eigen::Infinity>() <= kQpTolerance * primal_scale &&
          rs_.lpNorm<Eigen::Infinity>() <= kQpTolerance * dual_scale &&
          mu <= 0.1 * kQpTolerance * primal_scale * dual_scale)
        break;
      // The Newton matrix (shared by the predictor and the corrector): B + A' D^-1 A, of which
      // the dense rows give a symmetric product (lower triangle, the one LLT reads) and the
      // unit rows the diagonal.
      for (int i = 0; i < rows_; ++i) {
        D_[i] = w_[i] / z_[i] + (rho[i] > 0 ? s_[i] / y_[i] : 0.0);
        tmp_rows_[i] = 1.0 / D_[i];
      }
      AD_.noalias() = tmp_rows_.head(dense_).asDiagonal() * Ad;
      for (int j = 0; j < n_; ++j) {
        for (int i = j; i < n_; ++i) M_(i, j) = B(i, j) + AD_.col(i).dot(Ad.col(j));
        M_(j, j) += tmp_rows_[dense_ + 2 * j] + tmp_rows_[dense_ + 2 * j + 1];
      }
      llt_.compute(M_);
      if (llt_.info() != Eigen::Success) {
        M_.diagonal().array() += 1e-10 * (1.0 + M_.diagonal().cwiseAbs().maxCoeff());
        llt_.compute(M_);
        if (llt_.info() != Eigen::Success) return false;
      }
      // Predictor (affine scaling).
      for (int i = 0; i < rows_; ++i) {
        rcw_[i] = -w_[i] * z_[i];
        rcs_[i] = -s_[i] * y_[i];
      }
      direction(Ad, rho);
      double alpha = stepToBoundary(rho, 1.0);
      double mu_aff = 0.0;
      for (int i = 0; i < rows_; ++i) {
        mu_aff += (w_[i] + alpha * dw_[i]) * (z_[i] + alpha * dz_[i]);
        if (rho[i] > 0) mu_aff += (s_[i] + alpha * ds_[i]) * (y_[i] + alpha * dy_[i]);
      }
      mu_aff /= std::max(1, count);
      const double sigma = std::pow(std::clamp(mu_aff / std::max(mu, 1e-300), 0.0, 1.0), 3);
      dwa_ = dw_;
      dza_ = dz_;
      dsa_ = ds_;
      dya_ = dy_;
      // Corrector.
      for (int i = 0; i < rows_; ++i) {
        rcw_[i] = sigma * mu - w_[i] * z_[i] - dwa_[i] * dza_[i];
        rcs_[i] = rho[i] > 0 ? sigma * mu - s_[i] * y_[i] - dsa_[i] * dya_[i] : 0.0;
      }
      direction(Ad, rho);
      alpha = stepToBoundary(rho, 0.995);
      d_ += alpha * dd_;
      w_ += alpha * dw_;
      z_ += alpha * dz_;
      s_ += alpha * ds_;
      y_ += alpha * dy_;
    }
    return true;
  }

  // out = A d over all rows (dense rows Ad, then the unit rows).
  void times(const Eigen::MatrixXd& Ad, const Eigen::VectorXd& d, Eigen::VectorXd& out) const {
    out.head(dense_).noalias() = Ad * d;
    for (int j = 0; j < n_; ++j) {
      out[dense_ + 2 * j] = d[j];
      out[dense_ + 2 * j + 1] = -d[j];
    }
  }
  // out -= A' v over all rows.
  void transposeTimesSub(const Eigen::MatrixXd& Ad, const Eigen::VectorXd& v,
                         Eigen::VectorXd& out) const {
    out.noalias() -= Ad.transpose() * v.head(dense_);
    for (int j = 0; j < n_; ++j) out[j] -= v[dense_ + 2 * j] - v[dense_ + 2 * j + 1];
  }

  // The Newton direction for the complementarity right-hand sides rcw_, rcs_ (residuals in
  // rd_, rp_, rs_; factorisation in llt_).
  void direction(const Eigen::MatrixXd& Ad, const Eigen::VectorXd& rho) {
    for (int i = 0; i < rows_; ++i) {
      h_[i] = -rp_[i] + rcw_[i] / z_[i];
      if (rho[i] > 0) h_[i] -= (rcs_[i] - s_[i] * rs_[i]) / y_[i];
      tmp_rows_[i] = h_[i] / D_[i];
    }
    rhs_ = rd_;
    transposeTimesSub(Ad, tmp_rows_, rhs_);
    rhs_ = -rhs_;
    dd_ = llt_.solve(rhs_);
    times(Ad, dd_, tmp_rows_);
    for (int i = 0; i < rows_; ++i) {
      dz_[i] = (h_[i] - tmp_rows_[i]) / D_[i];
      dw_[i] = (rcw_[i] - w_[i] * dz_[i]) / z_[i];
      if (rho[i] > 0) {
        dy_[i] = rs_[i] - dz_[i];
        ds_[i] = (rcs_[i] - s_[i] * dy_[i]) / y_[i];
      } else {
        dy_[i] = ds_[i] = 0.0;
      }
    }
  }

  // Largest alpha <= 1 keeping (w, z, s, y) >= (1 - fraction) of their values.
  double stepToBoundary(const Eigen::VectorXd& rho, double fraction) const {
    double alpha = 1.0;
    auto limit = [&](double v, double dv) {
      if (dv < 0) alpha = std::min(alpha, -fraction * v / dv);
    };
    for (int i = 0; i < rows_; ++i) {
      limit(w_[i], dw_[i]);
      limit(z_[i], dz_[i]);
      if (rho[i] > 0) {
        limit(s_[i], ds_[i]);
        limit(y_[i], dy_[i]);
      }
    }
    return alpha;
  }

  int n_ = 0, rows_ = 0, dense_ = 0, llt_size_ = -1;
  Eigen::VectorXd d_, rd_, dd_, rhs_;
  Eigen::VectorXd w_, z_, s_, y_, rp_, rs_, D_, h_, rcw_, rcs_, dw_, dz_, ds_, dy_;
  Eigen::VectorXd dwa_, dza_, dsa_, dya_, tmp_rows_, b_, rho_, z_all_;
  Eigen::MatrixXd M_, Ad_, AD_;
  std::vector<int> kept_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
};

// One row of the QP: a bound of a constraint (elastic) or of a variable (hard).
struct QpRow {
  enum Kind { ConstraintLower, ConstraintUpper, VariableLower, VariableUpper } kind;
  int index;
};

}  // namespace

DenseSqpResult solveDenseSqp(const DenseSqpProblem& p, const Eigen::VectorXd& x0,
                             const DenseSqpSettings& st) {
  const int n = static_cast<int>(x0.size());
  const int m = static_cast<int>(p.cl.size());
  DenseSqpResult result;

  std::vector<QpRow> rows;
  for (int i = 0; i < m; ++i) {
    if (finite(p.cl[i])) rows.push_back({QpRow::ConstraintLower, i});
    if (finite(p.cu[i])) rows.push_back({QpRow::ConstraintUpper, i});
  }
  // Every variable has both rows: its bound or the step limit, whichever is tighter.
  for (int j = 0; j < n; ++j) {
    rows.push_back({QpRow::VariableLower, j});
    rows.push_back({QpRow::VariableUpper, j});
  }
  const int nr = static_cast<int>(rows.size());

  auto maxViolation = [&](const Eigen::VectorXd& c) {
    double v = 0.0;
    for (int i = 0; i < m; ++i) {
      if (finite(p.cl[i])) v = std::max(v, p.cl[i] - c[i]);
      if (finite(p.cu[i])) v = std::max(v, c[i] - p.cu[i]);
    }
    return v;
  };
  auto sumViolation = [&](const Eigen::VectorXd& c) {
    double v = 0.0;
    for (int i = 0; i < m; ++i) {
      if (finite(p.cl[i])) v += std::max(0.0, p.cl[i] - c[i]);
      if (finite(p.cu[i])) v += std::max(0.0, c[i] - p.cu[i]);
    }
    return v;
  };

  // The best point meeting the constraints among all the values asked for.
  Eigen::VectorXd best_x;
  double best_f = std::numeric_limits<double>::infinity(), best_violation = 0.0;
  auto evaluate = [&](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c) {
    ++result.evaluations;
    if (!p.value(x, f, c) || !std::isfinite(f) || !c.allFinite()) return false;
    const double violation = maxViolation(c);
    if (violation <= st.constraint_tolerance && f < best_f) {
      best_f = f;
      best_x = x;
      best_violation = violation;
    }
    return true;
  };

  Eigen::VectorXd x = x0;
  for (int j = 0; j < n; ++j) x[j] = std::clamp(x[j], p.xl[j], std::max(p.xl[j], p.xu[j]));
  double f = 0.0;
  Eigen::VectorXd c(m), grad(n), g_old(n), xt(n), ct(m), lambda(m), nu(n), s(n), yv(n), Bs(n), r(n),
      stat(n), rho_rows(nr), b(nr), b_soc(nr), dc(m), zero_g(n);
  Eigen::MatrixXd J(m, n), J_old(m, n), A(nr, n);
  Eigen::MatrixXd B = Eigen::MatrixXd::Identity(n, n);
  DenseQp qp, qp_try;

  auto finish = [&](SqpStatus status) {
    result.status = status;
    result.qp_solves = qp.solves + qp_try.solves;
    result.qp_rows_offered = qp.rows_offered + qp_try.rows_offered;
    result.qp_rows_kept = qp.rows_kept + qp_try.rows_kept;
    if (st.print)
      std::fprintf(stderr, "sqp QPs: %d solves, %d interior-point iterations, %ld of %ld rows\n",
                   qp.solves + qp_try.solves, qp.iterations + qp_try.iterations,
                   qp.rows_kept + qp_try.rows_kept, qp.rows_offered + qp_try.rows_offered);
    if (best_x.size() > 0) {
      result.x = best_x;
      result.f = best_f;
      result.feasible = true;
      result.violation = best_violation;
    } else {
      result.x = x;
      result.f = f;
      result.violation = m > 0 ? maxViolation(c) : 0.0;
      result.feasible = false;
    }
    return result;
  };

  if (!evaluate(x, f, c)) return finish(SqpStatus::EvaluationFailed);
  if (!p.derivatives(x, f, c, grad, J)) return finish(SqpStatus::EvaluationFailed);
  double rho = st.initial_penalty * std::max(1.0, grad.lpNorm<Eigen::Infinity>());
  // Step limit |d_j| <= radius * scale_j (scale: the variable's range, else max(1, |x0_j|)):
  // BFGS steps far beyond where the linearisation holds are cut before the line search.
  Eigen::VectorXd scale(n);
  for (int j = 0; j < n; ++j)
    scale[j] = finite(p.xl[j]) && finite(p.xu[j]) && p.xu[j] > p.xl[j]
                   ? p.xu[j] - p.xl[j]
                   : std::max(1.0, std::abs(x[j]));
  double radius = st.initial_radius;
  std::vector<char> limited(nr, 0);
  bool fresh_hessian = true;
  double stall_f = std::numeric_limits<double>::infinity();
  int stall_iter = 0;
  int infeasible_run = 0;  // iterations in a row that looked locally infeasible

  // The QP at x: a_i'd + s_i >= b_i for each row.
  auto buildQp = [&]() {
    for (int k = 0; k < nr; ++k) {
      const QpRow& row = rows[k];
      switch (row.kind) {
        case QpRow::ConstraintLower:
          A.row(k) = J.row(row.index);
          b[k] = p.cl[row.index] - c[row.index];
          break;
        case QpRow::ConstraintUpper:
          A.row(k) = -J.row(row.index);
          b[k] = c[row.index] - p.cu[row.index];
          break;
        case QpRow::VariableLower: {
          A.row(k).setZero();
          A(k, row.index) = 1.0;
          const double bound =
              finite(p.xl[row.index]) ? p.xl[row.index] - x[row.index] : -kSqpInfinity;
          const double limit = -radius * scale[row.index];
          limited[k] = limit > bound;
          b[k] = std::max(bound, limit);
          break;
        }
        case QpRow::VariableUpper: {
          A.row(k).setZero();
          A(k, row.index) = -1.0;
          const double bound =
              finite(p.xu[row.index]) ? x[row.index] - p.xu[row.index] : -kSqpInfinity;
          const double limit = -radius * scale[row.index];
          limited[k] = limit > bound;
          b[k] = std::max(bound, limit);
          break;
        }
      }
    }
  };
  for (int iter = 1; iter <= st.max_iterations; ++iter) {
    result.iterations = iter;
    buildQp();
    auto linearViolation = [&](const Eigen::VectorXd& d) {
      double v = 0.0;
      for (int k = 0; k < nr; ++k)
        if (rows[k].kind == QpRow::ConstraintLower || rows[k].kind == QpRow::ConstraintUpper)
          v += std::max(0.0, b[k] - A.row(k).dot(d));
      return v;
    };
    auto setPenalty = [&](double value) {
      for (int k = 0; k < nr; ++k)
        rho_rows[k] =
            rows[k].kind == QpRow::ConstraintLower || rows[k].kind == QpRow::ConstraintUpper ? value
                                                                                             : 0.0;
    };
    setPenalty(rho);
    if (!qp.solve(B, grad, A, b, rho_rows, st.qp_max_iterations, st.screen_rows))
      return finish(SqpStatus::QpFailed);
    const double v = sumViolation(c);
    double v_lin = linearViolation(qp.step());
    // Steering: when the linearised constraints are not met at this penalty, raise it while that
    // reduces their violation (Byrd, Nocedal & Waltz 2008, simplified).
    for (int tries = 0; tries < 3 && v_lin > 1e-9 * (1.0 + v) && rho < st.max_penalty; ++tries) {
      setPenalty(10.0 * rho);
      if (!qp_try.solve(B, grad, A, b, rho_rows, st.qp_max_iterations, st.screen_rows)) break;
      const double v_try = linearViolation(qp_try.step());
      if (!(v_try < 0.9 * v_lin)) break;
      rho *= 10.0;
      std::swap(qp, qp_try);
      v_lin = v_try;
    }
    // The linearisation sees no way to lower the violation (lin ~ actual).
    const bool no_way_down = v > st.constraint_tolerance && v_lin >= 0.99 * v;
    const Eigen::VectorXd& d = qp.step();
    const double dnorm = d.lpNorm<Eigen::Infinity>();
    if (dnorm <= 1e-12 * (1.0 + x.lpNorm<Eigen::Infinity>())) return finish(SqpStatus::SmallStep);

    // The penalty must make the step a descent direction of the merit with a predicted
    // reduction dominated by the constraints' (Nocedal & Wright 2006, Eq. 18.36):
    //   rho >= (g'd + 1/2 d'Bd) / ((1 - 0.1) (v - v_lin)).
    if (v - v_lin > 1e-12) {
      const double needed = (grad.dot(d) + 0.5 * d.dot(B * d)) / (0.9 * (v - v_lin));
      if (needed > rho) rho = std::min(st.max_penalty, std::max(needed, 2.0 * rho));
    }
    // l1 merit, Armijo backtracking along d.
    const double phi0 = f + rho * v;
    const double slope = grad.dot(d) - rho * (v - v_lin);
    double alpha = 1.0, ft = 0.0;
    bool accepted = false, soc = false;
    bool evaluated = false;
    auto tryPoint = [&](const Eigen::VectorXd& step, double a) {
      xt = x + step;
      for (int j = 0; j < n; ++j) xt[j] = std::clamp(xt[j], p.xl[j], std::max(p.xl[j], p.xu[j]));
      evaluated = evaluate(xt, ft, ct);
      if (!evaluated) return false;
      return ft + rho * sumViolation(ct) <= phi0 + 1e-4 * a * std::min(slope, 0.0);
    };
    for (int k = 0; k <= st.max_backtracks; ++k, alpha *= 0.5) {
      if (tryPoint(alpha * d, alpha)) {
        accepted = true;
        break;
      }
      if (k == 0 && m > 0 && evaluated) {
        // Second-order correction (N&W Algorithm 18.3's idea): the full step was rejected, its
        // constraint values are known; shift the QP's rows by the linearisation's error
        // c(x + d) - c(x) - J d and take the corrected step instead.
        dc = ct - c;
        dc.noalias() -= J * d;
        for (int k2 = 0; k2 < nr; ++k2) {
          b_soc[k2] = b[k2];
          if (rows[k2].kind == QpRow::ConstraintLower) b_soc[k2] -= dc[rows[k2].index];
          if (rows[k2].kind == QpRow::ConstraintUpper) b_soc[k2] += dc[rows[k2].index];
        }
        if (qp_try.solve(B, grad, A, b_soc, rho_rows, st.qp_max_iterations, st.screen_rows) &&
            tryPoint(qp_try.step(), 1.0)) {
          accepted = true;
          soc = true;
          break;
        }
      }
    }
    if (st.print)
      std::fprintf(stderr,
                   "sqp %2d (n %d, m %d) f %.6e viol %.2e (lin %.2e) rho %.1e |d| %.2e slope %.2e "
                   "alpha %.3g radius %.2g%s%s\n",
                   iter, n, m, f, v, v_lin, rho, dnorm, slope, alpha, radius, soc ? " soc" : "",
                   accepted ? "" : " (no step)");
    if (!accepted) {
      if (fresh_hessian) return finish(SqpStatus::LineSearchFailed);
      B.setIdentity();  // the quasi-Newton model misleads: start it again
      fresh_hessian = true;
      continue;
    }
    // The step limit follows the line search: at least twice the last full step, and after a
    // shortened step the accepted length, shrinking by at most a factor of 4 per iteration.
    {
      const double reach = ((xt - x).cwiseQuotient(scale)).lpNorm<Eigen::Infinity>();
      if (alpha < 1.0)
        radius = std::max({reach, 0.25 * radius, 1e-8});
      else
        radius = std::min(std::max(radius, 2.0 * reach), 1e3);
    }
    s = xt - x;
    g_old = grad;
    J_old = J;
    x = xt;
    f = ft;
    c = ct;
    if (!p.derivatives(x, f, c, grad, J)) return finish(SqpStatus::EvaluationFailed);

    // Multipliers of the QP: lambda for the constraints, nu for the variable bounds.
    lambda.setZero();
    nu.setZero();
    const Eigen::VectorXd& z = qp.multipliers();
    for (int k = 0; k < nr; ++k) {
      switch (rows[k].kind) {
        case QpRow::ConstraintLower:
          lambda[rows[k].index] += z[k];
          break;
        case QpRow::ConstraintUpper:
          lambda[rows[k].index] -= z[k];
          break;
        case QpRow::VariableLower:
          if (!limited[k]) nu[rows[k].index] += z[k];
          break;
        case QpRow::VariableUpper:
          if (!limited[k]) nu[rows[k].index] -= z[k];
          break;
      }
    }
    // Damped BFGS on the Lagrangian's gradient difference (Powell's damping keeps B positive
    // definite).
    yv = grad - g_old;
    yv.noalias() -= (J - J_old).transpose() * lambda;
    Bs.noalias() = B * s;
    const double sBs = s.dot(Bs), sy = s.dot(yv);
    if (sBs > 1e-16) {
      const double theta = sy >= 0.2 * sBs ? 1.0 : 0.8 * sBs / (sBs - sy);
      r = theta * yv + (1.0 - theta) * Bs;
      B.noalias() += r * r.transpose() / s.dot(r);
      B.noalias() -= Bs * Bs.transpose() / sBs;
      fresh_hessian = false;
    }

    // Feasibility probe: a step that cut the objective usually leaves a small violation (the
    // constraints' curvature). The B-norm projection onto the linearised constraints at the new
    // point (the QP without gradient) is evaluated once; if it meets the constraints, it joins
    // the candidates for the best feasible point. The iterate stays where it is.
    if (m > 0 && maxViolation(c) > st.constraint_tolerance) {
      buildQp();
      setPenalty(rho);
      zero_g.setZero();
      if (qp_try.solve(B, zero_g, A, b, rho_rows, st.qp_max_iterations, st.screen_rows)) {
        xt = x + qp_try.step();
        for (int j = 0; j < n; ++j) xt[j] = std::clamp(xt[j], p.xl[j], std::max(p.xl[j], p.xu[j]));
        evaluate(xt, ft, ct);
      }
    }
    // Local infeasibility: nothing feasible seen, and the violation neither fell nor was
    // predicted to (the vertical and backflip targets out of reach: the violation settles
    // within 5 iterations and the remaining ones cannot move it).
    if (best_x.size() == 0 && no_way_down && sumViolation(c) >= 0.99 * v) {
      if (st.infeasible_iterations > 0 && ++infeasible_run >= st.infeasible_iterations)
        return finish(SqpStatus::LocallyInfeasible);
    } else {
      infeasible_run = 0;
    }
    // KKT at the new point with the QP's multipliers.
    stat = grad - nu;
    stat.noalias() -= J.transpose() * lambda;
    if (maxViolation(c) <= st.constraint_tolerance &&
        stat.lpNorm<Eigen::Infinity>() <=
            st.tolerance * std::max(1.0, grad.lpNorm<Eigen::Infinity>()))
      return finish(SqpStatus::Converged);
    // The stall rule: a feasible point is known and its objective has not dropped 0.1 % in
    // stall_iterations iterations.
    // Iterations whose iterate is still far from feasible (max violation > 1e-3) do not count:
    // a feasible point found by an early probe would otherwise stop the solve while the iterates
    // are still on their way to the optimum.
    if (best_x.size() > 0) {
      // (The first feasible point starts the count: stall_f is +inf until then.)
      if (!std::isfinite(stall_f) || best_f < stall_f - 1e-3 * std::abs(stall_f) ||
          maxViolation(c) > 1e-3) {
        stall_f = std::min(stall_f, best_f);
        stall_iter = iter;
      }
      if (st.stall_iterations > 0 && iter - stall_iter >= st.stall_iterations)
        return finish(SqpStatus::Stalled);
    }
    if (s.lpNorm<Eigen::Infinity>() <= 1e-12 * (1.0 + x.lpNorm<Eigen::Infinity>()))
      return finish(SqpStatus::SmallStep);
  }
  return finish(SqpStatus::MaxIterations);
}

}  // namespace wj::planner
