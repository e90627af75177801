#include "nmpc/sqp_solver.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <stdexcept>
#include <utility>

namespace wj::nmpc {

namespace {

// CPU time of the calling thread: the solver's own work, robust against other processes
// sharing the cores (the wall time of a solve is measured by the caller).
struct Clock {
  using time_point = double;  // [ms]
  static double now() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
  }
};

double msSince(Clock::time_point start) {
  return Clock::now() - start;
}

}  // namespace

void SqpSettings::validate() const {
  if (!(horizon_s > 0.0)) throw std::invalid_argument("SqpSettings.horizon_s must be > 0");
  if (!(dt_s > 0.0 && dt_s <= horizon_s))
    throw std::invalid_argument("SqpSettings.dt_s must be in (0, horizon_s]");
  if (max_iterations < 1) throw std::invalid_argument("SqpSettings.max_iterations must be >= 1");
  if (!(step_tolerance > 0.0))
    throw std::invalid_argument("SqpSettings.step_tolerance must be > 0");
  if (!(constraint_tolerance > 0.0))
    throw std::invalid_argument("SqpSettings.constraint_tolerance must be > 0");
  if (!(hessian_regularization >= 0.0))
    throw std::invalid_argument("SqpSettings.hessian_regularization must be >= 0");
  if (!(alpha_decay > 0.0 && alpha_decay < 1.0))
    throw std::invalid_argument("SqpSettings.alpha_decay must be in (0, 1)");
  if (!(alpha_min > 0.0 && alpha_min <= 1.0))
    throw std::invalid_argument("SqpSettings.alpha_min must be in (0, 1]");
  if (!(violation_max > violation_min && violation_min >= 0.0))
    throw std::invalid_argument("SqpSettings: need 0 <= violation_min < violation_max");
  if (!(armijo_factor >= 0.0 && cost_gamma >= 0.0 && violation_gamma >= 0.0))
    throw std::invalid_argument("SqpSettings: armijo_factor and the gammas must be >= 0");
}

std::string_view toString(SqpStatus status) {
  switch (status) {
    case SqpStatus::Converged:
      return "converged";
    case SqpStatus::IterationLimit:
      return "iteration_limit";
    case SqpStatus::LineSearchFailed:
      return "line_search_failed";
    case SqpStatus::RiccatiFailed:
      return "riccati_failed";
  }
  return "?";
}

SqpSolver::SqpSolver(const SqpSettings& settings, CentroidalOcp problem)
    : settings_(settings), problem_(std::move(problem)) {
  settings_.validate();
  n_ = static_cast<int>(std::ceil(settings_.horizon_s / settings_.dt_s - 1e-9));
  dt_ = settings_.horizon_s / n_;
  const auto N = static_cast<std::size_t>(n_);
  times_.resize(N + 1);
  nodes_.resize(N + 1);
  x_.resize(N + 1);
  x_trial_.resize(N + 1);
  dx_.resize(N + 1);
  u_.resize(N);
  u_trial_.resize(N);
  du_.resize(N);
  data_.resize(N + 1);
  A_.resize(N);
  B_.resize(N);
  cost_.resize(N + 1);
  eq_.resize(N);
  projection_.resize(N);
  lq_.resize(N);
  gains_.resize(N);
  dz_.resize(N);
  prev_contact_.resize(N);
  policy_ = Policy(n_);
  filter_.reserve(static_cast<std::size_t>(settings_.max_iterations) + 1);
}

void SqpSolver::initialize(const State& x0) {
  for (int k = 0; k <= n_; ++k) x_[k] = x0;
  for (int k = 0; k < n_; ++k) u_[k] = nodes_[k].u_ref;
  initialized_ = true;
}

void SqpSolver::shift(double t0) {
  // Previous iterate sampled at the new node times: states linearly, inputs held.
  x_trial_ = x_;
  u_trial_ = u_;
  for (int k = 0; k <= n_; ++k) {
    const double s = std::max(0.0, (t0 + k * dt_ - t0_) / dt_);
    const int i = static_cast<int>(std::floor(s));
    if (i >= n_) {
      x_[k] = x_trial_[n_];
    } else {
      const double a = s - i;
      x_[k] = (1.0 - a) * x_trial_[i] + a * x_trial_[i + 1];
    }
    if (k < n_) {
      const int j = std::min(i, n_ - 1);
      u_[k] = u_trial_[j];
      // A wheel whose contact changed at this node (the grid moves across the gait's switch
      // times) starts from the new mode's reference force, not from the other mode's.
      for (int leg = 0; leg < kNumLegs; ++leg)
        if (prev_contact_[j][leg] != nodes_[k].contact[leg])
          u_[k].segment<3>(input_index::force(leg)) =
              nodes_[k].u_ref.segment<3>(input_index::force(leg));
    }
  }
}

SqpStatus SqpSolver::solve(double t0, const State& x0, const Targets& targets) {
  const auto start = Clock::now();
  stats_ = SqpStats{};
  for (int k = 0; k <= n_; ++k) {
    times_[k] = t0 + k * dt_;
    nodes_[k] = problem_.calcNodeTargets(targets, times_[k]);
  }
  if (!initialized_) {
    initialize(x0);
  } else {
    shift(t0);
  }
  t0_ = t0;
  x_[0] = x0;

  SqpStatus status = SqpStatus::IterationLimit;
  double cost = 0.0, violation = 0.0;
  filter_.clear();
  for (int it = 0; it < settings_.max_iterations; ++it) {
    linearize(cost, violation);
    if (!solveLq()) {
      status = SqpStatus::RiccatiFailed;
      break;
    }
    double new_cost = cost, new_violation = violation;
    const double alpha = lineSearch(cost, violation, new_cost, new_violation);
    ++stats_.iterations;
    stats_.last_alpha = alpha;
    if (alpha == 0.0) {
      status = SqpStatus::LineSearchFailed;
      break;
    }
    cost = new_cost;
    violation = new_violation;
    if ((stats_.step_norm < settings_.step_tolerance || converged_at_round_off_) &&
        violation < settings_.constraint_tolerance) {
      status = SqpStatus::Converged;
      break;
    }
  }
  for (int k = 0; k < n_; ++k) prev_contact_[k] = nodes_[k].contact;
  stats_.status = status;
  stats_.cost = cost;
  stats_.violation = violation;
  buildPolicy();
  stats_.timings.total_ms = msSince(start);
  return status;
}

void SqpSolver::linearize(double& cost, double& violation) {
  double lin_ms = 0.0, proj_ms = 0.0;
  cost = 0.0;
  double violation_sq = 0.0;
  for (int k = 0; k < n_; ++k) {
    auto t_start = Clock::now();
    const NodeTargets& node = nodes_[k];
    problem_.model().updateData(x_[k], data_[k]);
    State x_next;
    calcDiscreteDynamicsJacobians(problem_.model(), settings_.integrator, x_[k], u_[k], node.normal,
                                  dt_, data_[k], scratch_, x_next, A_[k], B_[k]);
    const State defect = x_next - x_[k + 1];
    CostQuadratic& c = cost_[k];
    problem_.calcStageCostQuadratic(node, x_[k], u_[k], c);
    c.value *= dt_;
    c.dx *= dt_;
    c.du *= dt_;
    c.dxx *= dt_;
    c.duu *= dt_;
    problem_.calcEqualitiesLinear(node, x_[k], u_[k], data_[k], eq_[k]);
    cost += c.value;
    violation_sq += defect.squaredNorm() + eq_[k].g.squaredNorm();
    auto t_mid = Clock::now();
    lin_ms += t_mid - t_start;
    calcInputProjection(eq_[k], projection_[k]);
    projectLqStage(A_[k], B_[k], defect, c, projection_[k], lq_[k]);
    proj_ms += msSince(t_mid);
  }
  const auto t_start = Clock::now();
  problem_.calcTerminalCostQuadratic(nodes_[n_], x_[n_], cost_[n_]);
  cost += cost_[n_].value;
  lin_ms += msSince(t_start);
  violation = std::sqrt(violation_sq);
  stats_.timings.linearization_ms += lin_ms;
  stats_.timings.projection_ms += proj_ms;
}

bool SqpSolver::solveLq() {
  auto start = Clock::now();
  const bool ok =
      solveRiccati(lq_, cost_[n_].dxx, cost_[n_].dx, settings_.hessian_regularization, gains_);
  stats_.timings.riccati_ms += msSince(start);
  if (!ok) return false;
  start = Clock::now();
  rolloutRiccati(lq_, gains_, State::Zero(), dx_, dz_);
  for (int k = 0; k < n_; ++k) {
    const InputProjection& p = projection_[k];
    du_[k] = p.u0;
    du_[k].noalias() += p.K * dx_[k];
    du_[k].noalias() += p.P * dz_[k];
  }
  stats_.timings.rollout_ms += msSince(start);
  return true;
}

void SqpSolver::evaluateTrajectory(const std::vector<State>& x, const std::vector<Input>& u,
                                   double& cost, double& violation) {
  cost = 0.0;
  double violation_sq = 0.0;
  EqVector g;
  for (int k = 0; k < n_; ++k) {
    const NodeTargets& node = nodes_[k];
    ModelData& data = data_[n_];  // the terminal node's data is free during trial evaluations
    problem_.model().updateData(x[k], data);
    State x_next;
    calcDiscreteDynamics(problem_.model(), settings_.integrator, x[k], u[k], node.normal, dt_, data,
                         scratch_, x_next);
    problem_.calcEqualities(node, x[k], u[k], data, g);
    cost += dt_ * problem_.calcStageCost(node, x[k], u[k]);
    violation_sq += (x_next - x[k + 1]).squaredNorm() + g.squaredNorm();
  }
  cost += problem_.calcTerminalCost(nodes_[n_], x[n_]);
  violation = std::sqrt(violation_sq);
}

double SqpSolver::lineSearch(double cost, double violation, double& new_cost,
                             double& new_violation) {
  const auto start = Clock::now();
  converged_at_round_off_ = false;
  // Directional derivative of the cost along the step.
  double slope = cost_[n_].dx.dot(dx_[n_]);
  double step_sq = dx_[n_].squaredNorm();
  for (int k = 0; k < n_; ++k) {
    slope += cost_[k].dx.dot(dx_[k]) + cost_[k].du.dot(du_[k]);
    step_sq += dx_[k].squaredNorm() + du_[k].squaredNorm();
  }
  // Wachter-Biegler filter: a trial must beat every stored (cost, violation) pair in one of
  // the two by a margin; when the iterate is (nearly) feasible and the step descends, the
  // cost must decrease by Armijo's rule instead and the pair is not stored.
  const bool switching = slope < 0.0 && violation < settings_.violation_min;
  const auto acceptable = [&](double c, double v) {
    for (const auto& [fc, fv] : filter_)
      if (!(c < fc - settings_.cost_gamma * fv || v < (1.0 - settings_.violation_gamma) * fv))
        return false;
    return true;
  };
  const double round_off = 1e-12 * (1.0 + std::abs(cost));
  const bool at_round_off =
      std::sqrt(step_sq) < settings_.step_tolerance ||
      (violation < settings_.constraint_tolerance && std::abs(slope) < round_off);
  const double violation_cap = std::max(settings_.violation_max, 1e4 * violation);
  double accepted = 0.0;
  for (double alpha = 1.0; alpha >= settings_.alpha_min; alpha *= settings_.alpha_decay) {
    for (int k = 0; k <= n_; ++k) x_trial_[k] = x_[k] + alpha * dx_[k];
    for (int k = 0; k < n_; ++k) u_trial_[k] = u_[k] + alpha * du_[k];
    double c = 0.0, v = 0.0;
    evaluateTrajectory(x_trial_, u_trial_, c, v);
    if (!std::isfinite(c) || !std::isfinite(v) || v > violation_cap) continue;
    bool ok = false;
    if (at_round_off) {
      ok = true;  // converged: what the step could change is within round-off of the cost
    } else if (switching) {
      // Armijo; near convergence a change within round-off counts as no harm.
      ok = v < settings_.violation_min &&
           (c < cost + settings_.armijo_factor * alpha * slope || c <= cost + round_off);
    } else {
      ok = acceptable(c, v) && (c < cost - settings_.cost_gamma * violation ||
                                v < (1.0 - settings_.violation_gamma) * violation);
    }
    if (ok) {
      if (!switching) filter_.emplace_back(cost, violation);
      accepted = alpha;
      new_cost = c;
      new_violation = v;
      x_.swap(x_trial_);
      u_.swap(u_trial_);
      stats_.step_norm = alpha * std::sqrt(step_sq);
      converged_at_round_off_ = at_round_off;
      break;
    }
  }
  stats_.timings.line_search_ms += msSince(start);
  return accepted;
}

void SqpSolver::buildPolicy() {
  policy_.reset(times_[0], dt_, n_);
  for (int k = 0; k <= n_; ++k) policy_.stateAt(k) = x_[k];
  policy_.normal() = nodes_[0].normal;
  for (int k = 0; k < n_; ++k) {
    policy_.inputAt(k) = u_[k];
    policy_.contactAt(k) = nodes_[k].contact;
    InputStateMatrix& K = policy_.gainAt(k);
    if (settings_.feedback_policy && stats_.iterations > 0) {
      K = projection_[k].K;
      K.noalias() += projection_[k].P * gains_[k].K;
    } else {
      K.setZero();
    }
  }
}

}  // namespace wj::nmpc
