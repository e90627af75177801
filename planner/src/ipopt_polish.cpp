// Ipopt polish of a DE candidate (Ipopt 3.11 from Debian: headers under coin/, MUMPS).
#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>
#include <cstdlib>
#include <limits>
#include <map>
#include <mutex>
#include <vector>

#include "planner/jump_planner.h"

namespace wj::planner {

namespace {

// Constraint violation (scaled margins, target residuals) at which a point counts as meeting
// the constraints; the full evaluation re-checks every sample before the point is accepted.
constexpr double kConstraintTolerance = 1e-6;
// Scaled margin below which a sampled constraint can become active during the polish.
constexpr double kActiveMargin = 3.0;

// MUMPS' sequential build shares Fortran state between instances: one solve at a time.
std::mutex& ipoptMutex() {
  static std::mutex m;
  return m;
}

// min energy_weight * energy(u)  s.t.  sampled margins >= 0, target errors = 0,
// |landing pitch| <= tolerance (apex targets). Derivatives by forward differences; the
// Hessian of the Lagrangian by a damped BFGS update kept here (dense, n <= 11): Ipopt's own
// limited-memory option spends most of its time in extra back-solves for problems this small. Only
// the constraint samples that are near-active at the DE's point are passed to Ipopt; the caller
// re-checks the full set before accepting the result.
class PolishNlp final : public Ipopt::TNLP {
 public:
  PolishNlp(const JumpModel& model, const Eigen::VectorXd& u0) : model_(model), u_full_(u0) {
    const auto& lo = model.lowerBounds();
    const auto& hi = model.upperBounds();
    for (int i = 0; i < model.dimension(); ++i)
      if (hi[i] > lo[i]) free_.push_back(i);
    Eigen::VectorXd g(model.numConstraintSamples());
    Eigen::Vector4d e;
    if (model.evaluateConstraints(u0, g, e, nullptr)) selectActive(model, g);
    apex_ = model.task().target.event == TargetEvent::Apex;
    residuals_ = apex_ ? std::vector<int>{0, 1, 2} : std::vector<int>{0, 2};
    m_ = static_cast<int>(active_.size() + residuals_.size()) + (apex_ ? 1 : 0);
    g_full_.resize(model.numConstraintSamples());
    best_u_ = u0;
  }

  // The samples passed to Ipopt: those within kActiveMargin (scaled) of their bound that are a
  // local minimum of their channel over time, and the samples on either side of such a minimum
  // (the minimum can move by a sample as u changes). A margin sampled densely along a smooth
  // trajectory otherwise enters as a dozen nearly parallel rows, which only slows MUMPS down; the
  // full set is re-checked by the caller before a result is accepted.
  void selectActive(const JumpModel& model, const Eigen::VectorXd& g) {
    const int n = static_cast<int>(g.size());
    std::map<int, std::vector<int>> channels;  // channel -> sample indices in time order
    for (int i = 0; i < n; ++i) channels[model.constraintSampleOrigin(i).channel].push_back(i);
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

  const Eigen::VectorXd& solution() const { return best_u_; }
  int iterations() const { return iterations_; }

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g,
                    Ipopt::Index& nnz_h_lag, IndexStyleEnum& index_style) override {
    n = static_cast<Ipopt::Index>(free_.size());
    m = m_;
    nnz_jac_g = n * m;
    nnz_h_lag = n * (n + 1) / 2;
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index m,
                       Ipopt::Number* g_l, Ipopt::Number* g_u) override {
    for (Ipopt::Index i = 0; i < n; ++i) {
      x_l[i] = model_.lowerBounds()[free_[i]];
      x_u[i] = model_.upperBounds()[free_[i]];
    }
    Ipopt::Index k = 0;
    for (std::size_t i = 0; i < active_.size(); ++i, ++k) {
      g_l[k] = model_.settings().polish_backoff;
      g_u[k] = 2e19;
    }
    for (std::size_t i = 0; i < residuals_.size(); ++i, ++k) g_l[k] = g_u[k] = 0.0;
    if (apex_) {
      const double tol = model_.settings().landing_pitch_tolerance_rad;
      g_l[k] = -tol;
      g_u[k] = tol;
      ++k;
    }
    return k == m;
  }

  bool get_starting_point(Ipopt::Index n, bool init_x, Ipopt::Number* x, bool, Ipopt::Number*,
                          Ipopt::Number*, Ipopt::Index, bool, Ipopt::Number*) override {
    if (init_x)
      for (Ipopt::Index i = 0; i < n; ++i) x[i] = u_full_[free_[i]];
    return true;
  }

  bool eval_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Number& f) override {
    if (!update(n, x, new_x)) return false;
    f = f0_;
    return true;
  }
  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
                   Ipopt::Number* grad) override {
    if (!update(n, x, new_x) || !derivatives(n)) return false;
    for (Ipopt::Index i = 0; i < n; ++i) grad[i] = grad_[i];
    return true;
  }
  bool eval_g(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Index m,
              Ipopt::Number* g) override {
    if (!update(n, x, new_x)) return false;
    for (Ipopt::Index k = 0; k < m; ++k) g[k] = c0_[k];
    return true;
  }
  bool eval_jac_g(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Index m, Ipopt::Index,
                  Ipopt::Index* iRow, Ipopt::Index* jCol, Ipopt::Number* values) override {
    if (!values) {
      Ipopt::Index idx = 0;
      for (Ipopt::Index k = 0; k < m; ++k)
        for (Ipopt::Index i = 0; i < n; ++i, ++idx) {
          iRow[idx] = k;
          jCol[idx] = i;
        }
      return true;
    }
    if (!update(n, x, new_x) || !derivatives(n)) return false;
    for (Ipopt::Index k = 0; k < m; ++k)
      for (Ipopt::Index i = 0; i < n; ++i) values[k * n + i] = jac_(k, i);
    return true;
  }

  bool eval_h(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Number obj_factor,
              Ipopt::Index m, const Ipopt::Number* lambda, bool, Ipopt::Index, Ipopt::Index* iRow,
              Ipopt::Index* jCol, Ipopt::Number* values) override {
    if (!values) {
      Ipopt::Index idx = 0;
      for (Ipopt::Index i = 0; i < n; ++i)
        for (Ipopt::Index j = 0; j <= i; ++j, ++idx) {
          iRow[idx] = i;
          jCol[idx] = j;
        }
      return true;
    }
    if (!update(n, x, new_x) || !derivatives(n)) return false;
    const Eigen::Map<const Eigen::VectorXd> lam(lambda, m);
    const Eigen::Map<const Eigen::VectorXd> xv(x, n);
    if (B_.rows() != n) B_ = Eigen::MatrixXd::Identity(n, n);
    if (have_prev_) {
      // y = grad L(x_k, lambda_k) - grad L(x_{k-1}, lambda_k); Powell-damped BFGS.
      const Eigen::VectorXd s = xv - prev_x_;
      const Eigen::VectorXd y =
          obj_factor * (grad_ - prev_grad_) + (jac_ - prev_jac_).transpose() * lam;
      const Eigen::VectorXd Bs = B_ * s;
      const double sBs = s.dot(Bs), sy = s.dot(y);
      if (sBs > 1e-16) {
        const double theta = sy >= 0.2 * sBs ? 1.0 : 0.8 * sBs / (sBs - sy);
        const Eigen::VectorXd r = theta * y + (1.0 - theta) * Bs;
        B_ += r * r.transpose() / s.dot(r) - Bs * Bs.transpose() / sBs;
      }
    }
    prev_x_ = xv;
    prev_grad_ = grad_;
    prev_jac_ = jac_;
    have_prev_ = true;
    Ipopt::Index idx = 0;
    for (Ipopt::Index i = 0; i < n; ++i)
      for (Ipopt::Index j = 0; j <= i; ++j) values[idx++] = B_(i, j);
    return true;
  }

  bool intermediate_callback(Ipopt::AlgorithmMode, Ipopt::Index iter, Ipopt::Number, Ipopt::Number,
                             Ipopt::Number, Ipopt::Number, Ipopt::Number, Ipopt::Number,
                             Ipopt::Number, Ipopt::Number, Ipopt::Index, const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    iterations_ = iter;
    // Stop once a point meeting every constraint is known and `polish.stall_iterations`
    // iterations in a row have not lowered its energy by 0.1 %: past that point Ipopt's
    // finite-difference steps wander about the optimum without gaining.
    const int stall = model_.settings().polish_stall_iterations;
    if (best_feasible_u_.size() > 0) {
      if (best_f_ < stall_f_ - 1e-3 * std::abs(stall_f_)) {
        stall_f_ = best_f_;
        stall_iter_ = iter;
      }
      if (stall > 0 && iter - stall_iter_ >= stall) return false;
    }
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn, Ipopt::Index n, const Ipopt::Number* x,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Index,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Number,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    best_u_ = u_full_;
    for (Ipopt::Index i = 0; i < n; ++i) best_u_[free_[i]] = x[i];
    if (best_feasible_u_.size() > 0) best_u_ = best_feasible_u_;
  }

 private:
  // Objective and constraints at u (full vector); false if the model has no trajectory there.
  bool value(const Eigen::VectorXd& u, double& f, Eigen::VectorXd& c) {
    Eigen::Vector4d e;
    double energy = 0.0;
    if (!model_.evaluateConstraints(u, g_full_, e, &energy)) return false;
    f = model_.settings().energy_weight * energy;
    c.resize(m_);
    int k = 0;
    for (int i : active_) c[k++] = g_full_[i];
    for (int i : residuals_) c[k++] = e[i];
    if (apex_) c[k++] = e[3];
    return true;
  }

  // Ipopt may wander after having met every constraint; keep the best point that met them
  // (to Ipopt's own constr_viol_tol) among all the points it evaluated, and return that one.
  void rememberIfBest(const Eigen::VectorXd& u) {
    double violation = 0.0;
    const int n_ineq = static_cast<int>(active_.size());
    for (int k = 0; k < m_; ++k) {
      if (k < n_ineq) {
        violation = std::max(violation, model_.settings().polish_backoff - c0_[k]);
      } else if (k < n_ineq + static_cast<int>(residuals_.size())) {
        violation = std::max(violation, std::abs(c0_[k]));
      } else {
        violation =
            std::max(violation, std::abs(c0_[k]) - model_.settings().landing_pitch_tolerance_rad);
      }
    }
    if (violation <= kConstraintTolerance && f0_ < best_f_) {
      best_f_ = f0_;
      best_feasible_u_ = u;
    }
  }

  // The objective and constraints at a new x. Their derivatives wait for derivatives(): Ipopt
  // asks only for values at the line search's trial points, and most of those are rejected.
  bool update(Ipopt::Index n, const Ipopt::Number* x, bool new_x) {
    if (!new_x && have_) return ok_;
    have_ = true;
    have_derivatives_ = false;
    u_ = u_full_;
    for (Ipopt::Index i = 0; i < n; ++i) u_[free_[i]] = x[i];
    ok_ = value(u_, f0_, c0_);
    if (!ok_) return false;
    rememberIfBest(u_);
    return true;
  }

  // Forward-difference gradient and Jacobian at the point of the last update().
  bool derivatives(Ipopt::Index n) {
    if (have_derivatives_) return true;
    const Eigen::VectorXd& u = u_;
    grad_.resize(n);
    jac_.resize(m_, n);
    Eigen::VectorXd c1;
    for (Ipopt::Index i = 0; i < n; ++i) {
      const double h = 1e-7 * std::max(1.0, std::abs(u[free_[i]]));
      Eigen::VectorXd up = u;
      // Step inward at the upper bound so the probe stays in the box.
      const double step = up[free_[i]] + h <= model_.upperBounds()[free_[i]] ? h : -h;
      up[free_[i]] += step;
      double f1 = 0.0;
      if (!value(up, f1, c1)) return ok_ = false;
      grad_[i] = (f1 - f0_) / step;
      jac_.col(i) = (c1 - c0_) / step;
    }
    have_derivatives_ = true;
    return true;
  }

  const JumpModel& model_;
  Eigen::VectorXd u_full_, best_u_, g_full_;
  std::vector<int> free_, active_, residuals_;
  bool apex_ = false;
  int m_ = 0;
  int iterations_ = 0;
  bool have_ = false, ok_ = false, have_derivatives_ = false;
  Eigen::VectorXd u_;  // full vector of the last update()
  double f0_ = 0.0;
  Eigen::VectorXd c0_, grad_;
  Eigen::MatrixXd jac_;
  Eigen::MatrixXd B_;  // BFGS approximation of the Lagrangian's Hessian
  Eigen::VectorXd prev_x_, prev_grad_;
  Eigen::MatrixXd prev_jac_;
  bool have_prev_ = false;
  double best_f_ = std::numeric_limits<double>::infinity();
  double stall_f_ = std::numeric_limits<double>::infinity();  // best_f_ when it last improved
  int stall_iter_ = 0;                                        // ... at this iteration
  Eigen::VectorXd best_feasible_u_;
};

}  // namespace

PolishOutcome polishWithIpopt(const JumpModel& model, const Eigen::VectorXd& u0, Eigen::VectorXd& u,
                              int* iterations, int max_iterations) {
  u = u0;
  Ipopt::SmartPtr<PolishNlp> nlp = new PolishNlp(model, u0);
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetStringValue("sb", "yes");
  app->Options()->SetIntegerValue("print_level", std::getenv("WJ_IPOPT_PRINT") ? 5 : 0);
  // Monotone barrier: one factorisation per iteration. The adaptive strategy's quality-function
  // oracle costs several extra MUMPS solves per iteration, which dominate on a problem this
  // small (docs/planner.md, "Polish").
  app->Options()->SetStringValue("mu_strategy", "monotone");
  app->Options()->SetIntegerValue(
      "max_iter", max_iterations > 0 ? max_iterations : model.settings().polish_max_iterations);
  app->Options()->SetNumericValue("tol", model.settings().polish_tolerance);
  app->Options()->SetNumericValue("constr_viol_tol", kConstraintTolerance);
  app->Options()->SetNumericValue("bound_push", 1e-6);
  app->Options()->SetNumericValue("bound_frac", 1e-6);
  app->Options()->SetNumericValue("mu_init", 1e-3);
  app->Options()->SetNumericValue("acceptable_tol", 1e-3);
  app->Options()->SetIntegerValue("acceptable_iter", 3);
  std::lock_guard<std::mutex> lock(ipoptMutex());
  // "": no options file. Ipopt otherwise reads ./ipopt.opt, and a stray file in the service's
  // working directory would change its plans behind the settings (and the cache key).
  if (app->Initialize("") != Ipopt::Solve_Succeeded) return PolishOutcome::Failed;
  const Ipopt::ApplicationReturnStatus status = app->OptimizeTNLP(nlp);
  if (iterations) *iterations = nlp->iterations();
  u = nlp->solution();
  switch (status) {
    case Ipopt::Solve_Succeeded:
    case Ipopt::Solved_To_Acceptable_Level:
    case Ipopt::Maximum_Iterations_Exceeded:
    case Ipopt::Search_Direction_Becomes_Too_Small:
    case Ipopt::Infeasible_Problem_Detected:
    case Ipopt::Restoration_Failed:
    case Ipopt::User_Requested_Stop:
      return PolishOutcome::Rejected;  // the caller decides on the full evaluation
    default:
      return PolishOutcome::Failed;
  }
}

}  // namespace wj::planner
