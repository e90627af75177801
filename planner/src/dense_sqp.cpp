// Dense Sl1QP solver for small NLPs (see dense_sqp.h for the references).
#include "dense_sqp.h"

#include "dense_qp.h"

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

using detail::DenseQp;

bool finite(double bound) {
  return std::abs(bound) < kSqpInfinity;
}

// One row of the QP: a bound of a constraint (elastic) or of a variable (hard).
struct QpRow {
  enum Kind { ConstraintLower, ConstraintUpper, VariableLower, VariableUpper } kind;
  int index;
  bool isConstraint() const { return kind == ConstraintLower || kind == ConstraintUpper; }
};

// What the line search along a step found.
struct LineSearchResult {
  double alpha = 1.0;  // the step fraction tried last (accepted if `accepted`)
  double slope = 0.0;  // the merit's predicted directional derivative
  bool accepted = false;
  bool soc = false;  // the second-order correction was accepted
};

// One solve: the iterate, the quasi-Newton model, the penalty and step limit, the best
// feasible point seen, and the QP workspaces. run() reads as the algorithm: build the QP,
// solve it with penalty steering, search along the step, update the multipliers and the
// Hessian model, probe feasibility, test termination.
class SqpRun {
 public:
  SqpRun(const DenseSqpProblem& p, const Eigen::VectorXd& x0, const DenseSqpSettings& st);
  DenseSqpResult run();

 private:
  void buildRows();
  double maxViolation(const Eigen::VectorXd& c) const;
  double sumViolation(const Eigen::VectorXd& c) const;
  void projectIntoBox(Eigen::VectorXd& x) const;
  // f and c at x; a point meeting the constraints joins the candidates for the best one.
  bool evaluate(const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c);
  // The QP at x: a_i'd + s_i >= b_i for each row.
  void buildQp();
  void setPenalty(double value);
  double linearViolation(const Eigen::VectorXd& d) const;
  // Steering: when the linearised constraints are not met at this penalty, raise it while that
  // reduces their violation (Byrd, Nocedal & Waltz 2008, simplified). `v_lin` is updated.
  void steerPenalty(double v, double& v_lin);
  // The penalty must make the step a descent direction of the merit with a predicted
  // reduction dominated by the constraints' (Nocedal & Wright 2006, Eq. 18.36).
  void raisePenaltyForDescent(const Eigen::VectorXd& d, double v, double v_lin);
  // l1 merit, Armijo backtracking along d, with one second-order correction.
  LineSearchResult searchLine(const Eigen::VectorXd& d, double v, double v_lin);
  bool tryPoint(const Eigen::VectorXd& step, double a, double phi0, double slope, bool& evaluated);
  // The step limit follows the line search.
  void updateStepLimit(double alpha);
  // Multipliers of the QP: lambda for the constraints, nu for the variable bounds.
  void updateMultipliers();
  void updateHessian();
  void probeFeasibility();
  // Every stopping rule that applies after an accepted step; none: keep going.
  bool stopsAfterStep(int iter, bool no_way_down, double v, SqpStatus& status);
  DenseSqpResult finish(SqpStatus status);

  const DenseSqpProblem& p_;
  const DenseSqpSettings& st_;
  const int n_, m_;
  DenseSqpResult result_;
  std::vector<QpRow> rows_;
  int nr_ = 0;

  // The best point meeting the constraints among all the values asked for.
  Eigen::VectorXd best_x_;
  double best_f_ = std::numeric_limits<double>::infinity(), best_violation_ = 0.0;

  Eigen::VectorXd x_;
  double f_ = 0.0, ft_ = 0.0;
  Eigen::VectorXd c_, grad_, g_old_, xt_, ct_, lambda_, nu_, s_, yv_, Bs_, r_, stat_, rho_rows_, b_,
      b_soc_, dc_, zero_g_, scale_;
  Eigen::MatrixXd J_, J_old_, A_;
  Eigen::MatrixXd B_;
  DenseQp qp_, qp_try_;
  double rho_ = 0.0;
  double radius_ = 0.0;
  std::vector<char> limited_;
  bool fresh_hessian_ = true;
  double stall_f_ = std::numeric_limits<double>::infinity();
  int stall_iter_ = 0;
  int infeasible_run_ = 0;  // iterations in a row that looked locally infeasible
};

SqpRun::SqpRun(const DenseSqpProblem& p, const Eigen::VectorXd& x0, const DenseSqpSettings& st)
    : p_(p), st_(st), n_(static_cast<int>(x0.size())), m_(static_cast<int>(p.cl.size())), x_(x0) {
  buildRows();
  projectIntoBox(x_);
  const int n = n_, m = m_, nr = nr_;
  c_.resize(m);
  for (Eigen::VectorXd* v : {&grad_, &g_old_, &xt_, &nu_, &s_, &yv_, &Bs_, &r_, &stat_, &zero_g_})
    v->resize(n);
  for (Eigen::VectorXd* v : {&ct_, &lambda_, &dc_}) v->resize(m);
  for (Eigen::VectorXd* v : {&rho_rows_, &b_, &b_soc_}) v->resize(nr);
  J_.resize(m, n);
  J_old_.resize(m, n);
  A_.resize(nr, n);
  B_ = Eigen::MatrixXd::Identity(n, n);
}

void SqpRun::buildRows() {
  for (int i = 0; i < m_; ++i) {
    if (finite(p_.cl[i])) rows_.push_back({QpRow::ConstraintLower, i});
    if (finite(p_.cu[i])) rows_.push_back({QpRow::ConstraintUpper, i});
  }
  // Every variable has both rows: its bound or the step limit, whichever is tighter.
  for (int j = 0; j < n_; ++j) {
    rows_.push_back({QpRow::VariableLower, j});
    rows_.push_back({QpRow::VariableUpper, j});
  }
  nr_ = static_cast<int>(rows_.size());
}

double SqpRun::maxViolation(const Eigen::VectorXd& c) const {
  double v = 0.0;
  for (int i = 0; i < m_; ++i) {
    if (finite(p_.cl[i])) v = std::max(v, p_.cl[i] - c[i]);
    if (finite(p_.cu[i])) v = std::max(v, c[i] - p_.cu[i]);
  }
  return v;
}

double SqpRun::sumViolation(const Eigen::VectorXd& c) const {
  double v = 0.0;
  for (int i = 0; i < m_; ++i) {
    if (finite(p_.cl[i])) v += std::max(0.0, p_.cl[i] - c[i]);
    if (finite(p_.cu[i])) v += std::max(0.0, c[i] - p_.cu[i]);
  }
  return v;
}

void SqpRun::projectIntoBox(Eigen::VectorXd& x) const {
  for (int j = 0; j < n_; ++j) x[j] = std::clamp(x[j], p_.xl[j], std::max(p_.xl[j], p_.xu[j]));
}

bool SqpRun::evaluate(const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c) {
  ++result_.evaluations;
  if (!p_.value(x, f, c) || !std::isfinite(f) || !c.allFinite()) return false;
  const double violation = maxViolation(c);
  if (violation <= st_.constraint_tolerance && f < best_f_) {
    best_f_ = f;
    best_x_ = x;
    best_violation_ = violation;
  }
  return true;
}

DenseSqpResult SqpRun::finish(SqpStatus status) {
  result_.status = status;
  result_.qp_solves = qp_.solves + qp_try_.solves;
  result_.qp_rows_offered = qp_.rows_offered + qp_try_.rows_offered;
  result_.qp_rows_kept = qp_.rows_kept + qp_try_.rows_kept;
  if (st_.print)
    std::fprintf(stderr, "sqp QPs: %d solves, %d interior-point iterations, %ld of %ld rows\n",
                 qp_.solves + qp_try_.solves, qp_.iterations + qp_try_.iterations,
                 qp_.rows_kept + qp_try_.rows_kept, qp_.rows_offered + qp_try_.rows_offered);
  if (best_x_.size() > 0) {
    result_.x = best_x_;
    result_.f = best_f_;
    result_.feasible = true;
    result_.violation = best_violation_;
  } else {
    result_.x = x_;
    result_.f = f_;
    result_.violation = m_ > 0 ? maxViolation(c_) : 0.0;
    result_.feasible = false;
  }
  return result_;
}

void SqpRun::buildQp() {
  for (int k = 0; k < nr_; ++k) {
    const QpRow& row = rows_[k];
    switch (row.kind) {
      case QpRow::ConstraintLower:
        A_.row(k) = J_.row(row.index);
        b_[k] = p_.cl[row.index] - c_[row.index];
        break;
      case QpRow::ConstraintUpper:
        A_.row(k) = -J_.row(row.index);
        b_[k] = c_[row.index] - p_.cu[row.index];
        break;
      case QpRow::VariableLower: {
        A_.row(k).setZero();
        A_(k, row.index) = 1.0;
        const double bound =
            finite(p_.xl[row.index]) ? p_.xl[row.index] - x_[row.index] : -kSqpInfinity;
        const double limit = -radius_ * scale_[row.index];
        limited_[k] = limit > bound;
        b_[k] = std::max(bound, limit);
        break;
      }
      case QpRow::VariableUpper: {
        A_.row(k).setZero();
        A_(k, row.index) = -1.0;
        const double bound =
            finite(p_.xu[row.index]) ? x_[row.index] - p_.xu[row.index] : -kSqpInfinity;
        const double limit = -radius_ * scale_[row.index];
        limited_[k] = limit > bound;
        b_[k] = std::max(bound, limit);
        break;
      }
    }
  }
}

void SqpRun::setPenalty(double value) {
  for (int k = 0; k < nr_; ++k) rho_rows_[k] = rows_[k].isConstraint() ? value : 0.0;
}

double SqpRun::linearViolation(const Eigen::VectorXd& d) const {
  double v = 0.0;
  for (int k = 0; k < nr_; ++k)
    if (rows_[k].isConstraint()) v += std::max(0.0, b_[k] - A_.row(k).dot(d));
  return v;
}

void SqpRun::steerPenalty(double v, double& v_lin) {
  for (int tries = 0; tries < 3 && v_lin > 1e-9 * (1.0 + v) && rho_ < st_.max_penalty; ++tries) {
    setPenalty(10.0 * rho_);
    if (!qp_try_.solve(B_, grad_, A_, b_, rho_rows_, st_.qp_max_iterations, st_.screen_rows)) break;
    const double v_try = linearViolation(qp_try_.step());
    if (!(v_try < 0.9 * v_lin)) break;
    rho_ *= 10.0;
    std::swap(qp_, qp_try_);
    v_lin = v_try;
  }
}

void SqpRun::raisePenaltyForDescent(const Eigen::VectorXd& d, double v, double v_lin) {
  //   rho >= (g'd + 1/2 d'Bd) / ((1 - 0.1) (v - v_lin)).
  if (v - v_lin > 1e-12) {
    const double needed = (grad_.dot(d) + 0.5 * d.dot(B_ * d)) / (0.9 * (v - v_lin));
    if (needed > rho_) rho_ = std::min(st_.max_penalty, std::max(needed, 2.0 * rho_));
  }
}

bool SqpRun::tryPoint(const Eigen::VectorXd& step, double a, double phi0, double slope,
                      bool& evaluated) {
  xt_ = x_ + step;
  projectIntoBox(xt_);
  evaluated = evaluate(xt_, ft_, ct_);
  if (!evaluated) return false;
  return ft_ + rho_ * sumViolation(ct_) <= phi0 + 1e-4 * a * std::min(slope, 0.0);
}

LineSearchResult SqpRun::searchLine(const Eigen::VectorXd& d, double v, double v_lin) {
  LineSearchResult ls;
  const double phi0 = f_ + rho_ * v;
  ls.slope = grad_.dot(d) - rho_ * (v - v_lin);
  bool evaluated = false;
  for (int k = 0; k <= st_.max_backtracks; ++k, ls.alpha *= 0.5) {
    if (tryPoint(ls.alpha * d, ls.alpha, phi0, ls.slope, evaluated)) {
      ls.accepted = true;
      break;
    }
    if (k == 0 && m_ > 0 && evaluated) {
      // Second-order correction (N&W Algorithm 18.3's idea): the full step was rejected, its
      // constraint values are known; shift the QP's rows by the linearisation's error
      // c(x + d) - c(x) - J d and take the corrected step instead.
      dc_ = ct_ - c_;
      dc_.noalias() -= J_ * d;
      for (int k2 = 0; k2 < nr_; ++k2) {
        b_soc_[k2] = b_[k2];
        if (rows_[k2].kind == QpRow::ConstraintLower) b_soc_[k2] -= dc_[rows_[k2].index];
        if (rows_[k2].kind == QpRow::ConstraintUpper) b_soc_[k2] += dc_[rows_[k2].index];
      }
      if (qp_try_.solve(B_, grad_, A_, b_soc_, rho_rows_, st_.qp_max_iterations, st_.screen_rows) &&
          tryPoint(qp_try_.step(), 1.0, phi0, ls.slope, evaluated)) {
        ls.accepted = true;
        ls.soc = true;
        break;
      }
    }
  }
  return ls;
}

void SqpRun::updateStepLimit(double alpha) {
  // At least twice the last full step, and after a shortened step the accepted length,
  // shrinking by at most a factor of 4 per iteration.
  const double reach = ((xt_ - x_).cwiseQuotient(scale_)).lpNorm<Eigen::Infinity>();
  if (alpha < 1.0)
    radius_ = std::max({reach, 0.25 * radius_, 1e-8});
  else
    radius_ = std::min(std::max(radius_, 2.0 * reach), 1e3);
}

void SqpRun::updateMultipliers() {
  lambda_.setZero();
  nu_.setZero();
  const Eigen::VectorXd& z = qp_.multipliers();
  for (int k = 0; k < nr_; ++k) {
    switch (rows_[k].kind) {
      case QpRow::ConstraintLower:
        lambda_[rows_[k].index] += z[k];
        break;
      case QpRow::ConstraintUpper:
        lambda_[rows_[k].index] -= z[k];
        break;
      case QpRow::VariableLower:
        if (!limited_[k]) nu_[rows_[k].index] += z[k];
        break;
      case QpRow::VariableUpper:
        if (!limited_[k]) nu_[rows_[k].index] -= z[k];
        break;
    }
  }
}

void SqpRun::updateHessian() {
  // Damped BFGS on the Lagrangian's gradient difference (Powell's damping keeps B positive
  // definite).
  yv_ = grad_ - g_old_;
  yv_.noalias() -= (J_ - J_old_).transpose() * lambda_;
  Bs_.noalias() = B_ * s_;
  const double sBs = s_.dot(Bs_), sy = s_.dot(yv_);
  if (sBs > 1e-16) {
    const double theta = sy >= 0.2 * sBs ? 1.0 : 0.8 * sBs / (sBs - sy);
    r_ = theta * yv_ + (1.0 - theta) * Bs_;
    B_.noalias() += r_ * r_.transpose() / s_.dot(r_);
    B_.noalias() -= Bs_ * Bs_.transpose() / sBs;
    fresh_hessian_ = false;
  }
}

void SqpRun::probeFeasibility() {
  // A step that cut the objective usually leaves a small violation (the constraints'
  // curvature). The B-norm projection onto the linearised constraints at the new point (the QP
  // without gradient) is evaluated once; if it meets the constraints, it joins the candidates
  // for the best feasible point. The iterate stays where it is.
  if (m_ > 0 && maxViolation(c_) > st_.constraint_tolerance) {
    buildQp();
    setPenalty(rho_);
    zero_g_.setZero();
    if (qp_try_.solve(B_, zero_g_, A_, b_, rho_rows_, st_.qp_max_iterations, st_.screen_rows)) {
      xt_ = x_ + qp_try_.step();
      projectIntoBox(xt_);
      evaluate(xt_, ft_, ct_);
    }
  }
}

bool SqpRun::stopsAfterStep(int iter, bool no_way_down, double v, SqpStatus& status) {
  // Local infeasibility: nothing feasible seen, and the violation neither fell nor was
  // predicted to (the vertical and backflip targets out of reach: the violation settles
  // within 5 iterations and the remaining ones cannot move it).
  if (best_x_.size() == 0 && no_way_down && sumViolation(c_) >= 0.99 * v) {
    if (st_.infeasible_iterations > 0 && ++infeasible_run_ >= st_.infeasible_iterations) {
      status = SqpStatus::LocallyInfeasible;
      return true;
    }
  } else {
    infeasible_run_ = 0;
  }
  // KKT at the new point with the QP's multipliers.
  stat_ = grad_ - nu_;
  stat_.noalias() -= J_.transpose() * lambda_;
  if (maxViolation(c_) <= st_.constraint_tolerance &&
      stat_.lpNorm<Eigen::Infinity>() <=
          st_.tolerance * std::max(1.0, grad_.lpNorm<Eigen::Infinity>())) {
    status = SqpStatus::Converged;
    return true;
  }
  // The stall rule: a feasible point is known and its objective has not dropped 0.1 % in
  // stall_iterations iterations.
  // Iterations whose iterate is still far from feasible (max violation > 1e-3) do not count:
  // a feasible point found by an early probe would otherwise stop the solve while the iterates
  // are still on their way to the optimum.
  if (best_x_.size() > 0) {
    // (The first feasible point starts the count: stall_f is +inf until then.)
    if (!std::isfinite(stall_f_) || best_f_ < stall_f_ - 1e-3 * std::abs(stall_f_) ||
        maxViolation(c_) > 1e-3) {
      stall_f_ = std::min(stall_f_, best_f_);
      stall_iter_ = iter;
    }
    if (st_.stall_iterations > 0 && iter - stall_iter_ >= st_.stall_iterations) {
      status = SqpStatus::Stalled;
      return true;
    }
  }
  if (s_.lpNorm<Eigen::Infinity>() <= 1e-12 * (1.0 + x_.lpNorm<Eigen::Infinity>())) {
    status = SqpStatus::SmallStep;
    return true;
  }
  return false;
}

DenseSqpResult SqpRun::run() {
  if (!evaluate(x_, f_, c_)) return finish(SqpStatus::EvaluationFailed);
  if (!p_.derivatives(x_, f_, c_, grad_, J_)) return finish(SqpStatus::EvaluationFailed);
  rho_ = st_.initial_penalty * std::max(1.0, grad_.lpNorm<Eigen::Infinity>());
  // Step limit |d_j| <= radius * scale_j (scale: the variable's range, else max(1, |x0_j|)):
  // BFGS steps far beyond where the linearisation holds are cut before the line search.
  scale_.resize(n_);
  for (int j = 0; j < n_; ++j)
    scale_[j] = finite(p_.xl[j]) && finite(p_.xu[j]) && p_.xu[j] > p_.xl[j]
                    ? p_.xu[j] - p_.xl[j]
                    : std::max(1.0, std::abs(x_[j]));
  radius_ = st_.initial_radius;
  limited_.assign(nr_, 0);

  for (int iter = 1; iter <= st_.max_iterations; ++iter) {
    result_.iterations = iter;
    buildQp();
    setPenalty(rho_);
    if (!qp_.solve(B_, grad_, A_, b_, rho_rows_, st_.qp_max_iterations, st_.screen_rows))
      return finish(SqpStatus::QpFailed);
    const double v = sumViolation(c_);
    double v_lin = linearViolation(qp_.step());
    steerPenalty(v, v_lin);
    // The linearisation sees no way to lower the violation (lin ~ actual).
    const bool no_way_down = v > st_.constraint_tolerance && v_lin >= 0.99 * v;
    const Eigen::VectorXd& d = qp_.step();
    const double dnorm = d.lpNorm<Eigen::Infinity>();
    if (dnorm <= 1e-12 * (1.0 + x_.lpNorm<Eigen::Infinity>())) return finish(SqpStatus::SmallStep);
    raisePenaltyForDescent(d, v, v_lin);

    const LineSearchResult ls = searchLine(d, v, v_lin);
    if (st_.print)
      std::fprintf(stderr,
                   "sqp %2d (n %d, m %d) f %.6e viol %.2e (lin %.2e) rho %.1e |d| %.2e slope %.2e "
                   "alpha %.3g radius %.2g%s%s\n",
                   iter, n_, m_, f_, v, v_lin, rho_, dnorm, ls.slope, ls.alpha, radius_,
                   ls.soc ? " soc" : "", ls.accepted ? "" : " (no step)");
    if (!ls.accepted) {
      if (fresh_hessian_) return finish(SqpStatus::LineSearchFailed);
      B_.setIdentity();  // the quasi-Newton model misleads: start it again
      fresh_hessian_ = true;
      continue;
    }
    updateStepLimit(ls.alpha);
    s_ = xt_ - x_;
    g_old_ = grad_;
    J_old_ = J_;
    x_ = xt_;
    f_ = ft_;
    c_ = ct_;
    if (!p_.derivatives(x_, f_, c_, grad_, J_)) return finish(SqpStatus::EvaluationFailed);

    updateMultipliers();
    updateHessian();
    probeFeasibility();
    SqpStatus status;
    if (stopsAfterStep(iter, no_way_down, v, status)) return finish(status);
  }
  return finish(SqpStatus::MaxIterations);
}

}  // namespace

DenseSqpResult solveDenseSqp(const DenseSqpProblem& p, const Eigen::VectorXd& x0,
                             const DenseSqpSettings& st) {
  return SqpRun(p, x0, st).run();
}

}  // namespace wj::planner
