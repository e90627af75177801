// The polish NLP of a DE candidate (see polish_problem.h).
#include "polish_problem.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <map>

namespace wj::planner {

namespace {
// Scaled margin below which a sampled constraint can become active during the polish.
constexpr double kActiveMargin = 3.0;
}  // namespace

PolishProblem::PolishProblem(const JumpModel& model, const Eigen::VectorXd& u0, PolishGoal goal)
    : model_(model), u0_(u0), goal_(goal) {
  const auto& lo = model.lowerBounds();
  const auto& hi = model.upperBounds();
  for (int i = 0; i < model.dimension(); ++i)
    if (hi[i] > lo[i]) free_.push_back(i);
  work_.resize(1);
  work_[0].g.resize(model.numConstraintSamples());
  Eigen::Vector4d e;
  if (model.evaluateConstraints(u0, work_[0].g, e, nullptr)) selectActive(work_[0].g);
  apex_ = model.task().target.event == TargetEvent::Apex;
  // (Touchdown targets: the height error is zero by the event's definition.)
  residuals_ = apex_ ? std::vector<int>{0, 1, 2} : std::vector<int>{0, 2};
  if (goal_ == PolishGoal::ClosestApproach) residuals_.clear();
  m_ = static_cast<int>(active_.size() + residuals_.size()) + (apex_ ? 1 : 0);

  const int n = numVariables();
  xl_.resize(n);
  xu_.resize(n);
  for (int i = 0; i < n; ++i) {
    xl_[i] = lo[free_[i]];
    xu_[i] = hi[free_[i]];
  }
  cl_.resize(m_);
  cu_.resize(m_);
  int k = 0;
  for (std::size_t i = 0; i < active_.size(); ++i, ++k) {
    cl_[k] = model.settings().polish_backoff;
    cu_[k] = 2e19;
  }
  for (std::size_t i = 0; i < residuals_.size(); ++i, ++k) cl_[k] = cu_[k] = 0.0;
  if (apex_) {
    const double tol = model.settings().landing_pitch_tolerance_rad;
    cl_[k] = -tol;
    cu_[k] = tol;
  }
  work_[0].u = u0;
  work_[0].c.resize(m_);
}

void PolishProblem::setTeam(de::BatchTeam* team, int threads) {
  team_ = team;
  const std::size_t count = team ? static_cast<std::size_t>(std::max(1, threads)) : 1;
  work_.resize(std::max(work_.size(), count), work_[0]);
}

// A margin sampled densely along a smooth trajectory otherwise enters as a dozen nearly parallel
// rows, which only slows the solver down; the full set is re-checked by the caller before a
// result is accepted.
void PolishProblem::selectActive(const Eigen::VectorXd& g) {
  const int n = static_cast<int>(g.size());
  std::map<int, std::vector<int>> channels;  // channel -> sample indices in time order
  for (int i = 0; i < n; ++i) channels[model_.constraintSampleOrigin(i).channel].push_back(i);
  std::vector<bool> keep(n, false);
  for (const auto& [channel, idx] : channels) {
    const int m = static_cast<int>(idx.size());
    for (int k = 0; k < m; ++k) {
      const double v = g[idx[k]];
      if (!(v < kActiveMargin)) continue;
      const bool left_ok = k == 0 || v <= g[idx[k - 1]];
      const bool right_ok = k == m - 1 || v <= g[idx[k + 1]];
      if (!(left_ok && right_ok)) continue;
      for (int d = -1; d <= 1; ++d)
        if (k + d >= 0 && k + d < m) keep[idx[k + d]] = true;
    }
  }
  for (int i = 0; i < n; ++i)
    if (keep[i]) active_.push_back(i);
}

Eigen::VectorXd PolishProblem::startPoint() const {
  Eigen::VectorXd x(numVariables());
  for (int i = 0; i < numVariables(); ++i) x[i] = u0_[free_[i]];
  return x;
}

Eigen::VectorXd PolishProblem::fullVector(const Eigen::VectorXd& x) const {
  Eigen::VectorXd u = u0_;
  for (int i = 0; i < numVariables(); ++i) u[free_[i]] = x[i];
  return u;
}

bool PolishProblem::value(const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c) {
  return valueWith(work_[0], x, f, c);
}

bool PolishProblem::valueWith(Workspace& w, const Eigen::VectorXd& x, double& f,
                              Eigen::VectorXd& c) const {
  for (int i = 0; i < numVariables(); ++i) w.u[free_[i]] = x[i];
  Eigen::Vector4d e;
  double energy = 0.0;
  if (!model_.evaluateConstraints(w.u, w.g, e, &energy)) return false;
  f = model_.settings().energy_weight * energy;
  if (goal_ == PolishGoal::ClosestApproach) f += model_.targetErrorCost(e);
  c.resize(m_);
  int k = 0;
  for (int i : active_) c[k++] = w.g[i];
  for (int i : residuals_) c[k++] = e[i];
  if (apex_) c[k++] = e[3];
  return true;
}

bool PolishProblem::derivatives(const Eigen::VectorXd& x, double f, const Eigen::VectorXd& c,
                                Eigen::VectorXd& grad, Eigen::MatrixXd& jac) {
  const int n = numVariables();
  grad.resize(n);
  jac.resize(m_, n);
  // Column i on thread `thread` (its own scratch; the model is immutable). A team's task must
  // not throw: an exception is kept and rethrown here, on the calling thread.
  std::vector<char> ok(static_cast<std::size_t>(n), 0);
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(n));
  auto column = [&](int i, int thread) {
    try {
      Workspace& w = work_[static_cast<std::size_t>(thread)];
      Eigen::VectorXd xp = x;
      const double h = 1e-7 * std::max(1.0, std::abs(x[i]));
      const double step = x[i] + h <= xu_[i] ? h : -h;
      xp[i] = x[i] + step;
      double f1 = 0.0;
      if (!valueWith(w, xp, f1, w.c)) return;
      grad[i] = (f1 - f) / step;
      jac.col(i) = (w.c - c) / step;
      ok[static_cast<std::size_t>(i)] = 1;
    } catch (...) {
      errors[static_cast<std::size_t>(i)] = std::current_exception();
    }
  };
  if (team_ != nullptr && n > 1) {
    team_->run(n, column);
  } else {
    for (int i = 0; i < n; ++i) column(i, 0);
  }
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  return std::all_of(ok.begin(), ok.end(), [](char v) { return v != 0; });
}

double PolishProblem::violation(const Eigen::VectorXd& c) const {
  double v = 0.0;
  for (int k = 0; k < m_; ++k) {
    v = std::max(v, cl_[k] - c[k]);
    if (cu_[k] < 1e19) v = std::max(v, c[k] - cu_[k]);
  }
  return v;
}

void PolishProblem::rememberIfBest(const Eigen::VectorXd& x, double f, const Eigen::VectorXd& c) {
  if (violation(c) <= kPolishConstraintTolerance && f < best_f_) {
    best_f_ = f;
    best_x_ = x;
  }
}

}  // namespace wj::planner
