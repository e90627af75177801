// Ipopt polish of a DE candidate (Ipopt 3.11 from Debian: headers under coin/, MUMPS); the
// problem is polish_problem.h.
#include <cmath>
#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <vector>

#include "planner/jump_planner.h"
#include "polish_problem.h"

namespace wj::planner {

namespace {

// MUMPS' sequential build shares Fortran state between instances: one solve at a time.
std::mutex& ipoptMutex() {
  static std::mutex m;
  return m;
}

// The polish problem (polish_problem.h) for Ipopt. Derivatives by forward differences; the
// Hessian of the Lagrangian by a damped BFGS update kept here (dense, n <= 11): Ipopt's own
// limited-memory option spends most of its time in extra back-solves for problems this small.
// Only the constraint samples that are near-active at the DE's point are passed to Ipopt; the
// caller re-checks the full set before accepting the result.
class PolishNlp final : public Ipopt::TNLP {
 public:
  PolishNlp(const JumpModel& model, const Eigen::VectorXd& u0, PolishGoal goal)
      : model_(model), problem_(model, u0, goal), best_u_(u0) {}

  const Eigen::VectorXd& solution() const { return best_u_; }
  int iterations() const { return iterations_; }
  PolishProblem& problem() { return problem_; }

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g,
                    Ipopt::Index& nnz_h_lag, IndexStyleEnum& index_style) override {
    n = problem_.numVariables();
    m = problem_.numConstraints();
    nnz_jac_g = n * m;
    nnz_h_lag = n * (n + 1) / 2;
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index m,
                       Ipopt::Number* g_l, Ipopt::Number* g_u) override {
    if (n != problem_.numVariables() || m != problem_.numConstraints()) return false;
    for (Ipopt::Index i = 0; i < n; ++i) {
      x_l[i] = problem_.xLower()[i];
      x_u[i] = problem_.xUpper()[i];
    }
    for (Ipopt::Index k = 0; k < m; ++k) {
      g_l[k] = problem_.cLower()[k];
      g_u[k] = problem_.cUpper()[k];
    }
    return true;
  }

  bool get_starting_point(Ipopt::Index n, bool init_x, Ipopt::Number* x, bool, Ipopt::Number*,
                          Ipopt::Number*, Ipopt::Index, bool, Ipopt::Number*) override {
    if (init_x) Eigen::Map<Eigen::VectorXd>(x, n) = problem_.startPoint();
    return true;
  }

  bool eval_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Number& f) override {
    if (!update(n, x, new_x)) return false;
    f = f0_;
    return true;
  }
  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
                   Ipopt::Number* grad) override {
    if (!update(n, x, new_x) || !derivatives()) return false;
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
    if (!update(n, x, new_x) || !derivatives()) return false;
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
    if (!update(n, x, new_x) || !derivatives()) return false;
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
    if (problem_.hasFeasible()) {
      const double best_f = problem_.bestObjective();
      // (The first feasible point starts the count: stall_f_ is +inf until then, and
      // inf - inf would compare false.)
      if (!std::isfinite(stall_f_) || best_f < stall_f_ - 1e-3 * std::abs(stall_f_)) {
        stall_f_ = best_f;
        stall_iter_ = iter;
      }
      if (stall > 0 && iter - stall_iter_ >= stall) return false;
    }
    return true;
  }

  // Ipopt may wander after having met every constraint: the best point that met them (to
  // Ipopt's own constr_viol_tol) among all the points it evaluated is returned.
  void finalize_solution(Ipopt::SolverReturn, Ipopt::Index n, const Ipopt::Number* x,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Index,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Number,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    best_u_ = problem_.hasFeasible() ? problem_.fullVector(problem_.bestFeasible())
                                     : problem_.fullVector(Eigen::Map<const Eigen::VectorXd>(x, n));
  }

 private:
  // The objective and constraints at a new x. Their derivatives wait for derivatives(): Ipopt
  // asks only for values at the line search's trial points, and most of those are rejected.
  bool update(Ipopt::Index n, const Ipopt::Number* x, bool new_x) {
    if (!new_x && have_) return ok_;
    have_ = true;
    have_derivatives_ = false;
    x_ = Eigen::Map<const Eigen::VectorXd>(x, n);
    ok_ = problem_.value(x_, f0_, c0_);
    if (!ok_) return false;
    problem_.rememberIfBest(x_, f0_, c0_);
    return true;
  }

  // Forward-difference gradient and Jacobian at the point of the last update().
  bool derivatives() {
    if (have_derivatives_) return true;
    if (!problem_.derivatives(x_, f0_, c0_, grad_, jac_)) return ok_ = false;
    have_derivatives_ = true;
    return true;
  }

  const JumpModel& model_;
  PolishProblem problem_;
  Eigen::VectorXd best_u_;
  int iterations_ = 0;
  bool have_ = false, ok_ = false, have_derivatives_ = false;
  Eigen::VectorXd x_;  // free variables of the last update()
  double f0_ = 0.0;
  Eigen::VectorXd c0_, grad_;
  Eigen::MatrixXd jac_;
  Eigen::MatrixXd B_;  // BFGS approximation of the Lagrangian's Hessian
  Eigen::VectorXd prev_x_, prev_grad_;
  Eigen::MatrixXd prev_jac_;
  bool have_prev_ = false;
  double stall_f_ =
      std::numeric_limits<double>::infinity();  // best objective when it last improved
  int stall_iter_ = 0;                          // ... at this iteration
};

}  // namespace

PolishOutcome polishWithIpopt(const JumpModel& model, const Eigen::VectorXd& u0, Eigen::VectorXd& u,
                              int* iterations, int max_iterations, PolishGoal goal, int threads) {
  u = u0;
  Ipopt::SmartPtr<PolishNlp> nlp = new PolishNlp(model, u0, goal);
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
  app->Options()->SetNumericValue("constr_viol_tol", kPolishConstraintTolerance);
  app->Options()->SetNumericValue("bound_push", 1e-6);
  app->Options()->SetNumericValue("bound_frac", 1e-6);
  app->Options()->SetNumericValue("mu_init", 1e-3);
  app->Options()->SetNumericValue("acceptable_tol", 1e-3);
  app->Options()->SetIntegerValue("acceptable_iter", 3);
  std::lock_guard<std::mutex> lock(ipoptMutex());
  // "": no options file. Ipopt otherwise reads ./ipopt.opt, and a stray file in the service's
  // working directory would change its plans behind the settings (and the cache key).
  if (app->Initialize("") != Ipopt::Solve_Succeeded) return PolishOutcome::Failed;
  const Ipopt::ApplicationReturnStatus status =
      nlp->problem().solveWithThreads(threads, [&] { return app->OptimizeTNLP(nlp); });
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
