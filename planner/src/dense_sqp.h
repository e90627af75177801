#pragma once
/// @file A dense SQP solver for small smooth NLPs (n of the order of 10, m of the order of 100):
///   min f(x)  s.t.  cl <= c(x) <= cu,  xl <= x <= xu.
/// Sl1QP (Fletcher, "Practical Methods of Optimization", ch. 12.4; Nocedal & Wright 2006,
/// ch. 18.5): each subproblem is the QP with the linearised constraints made elastic, so it is
/// always feasible, solved by a dense Mehrotra primal-dual interior point (Nocedal & Wright
/// ch. 16.6) whose Newton systems are n x n Cholesky factorisations; damped-BFGS Hessian
/// (Powell 1978, N&W Procedure 18.2); l1 merit with Armijo backtracking; steering penalty update.
/// Internal to the planner library (used by the polish).

#include <Eigen/Core>
#include <functional>
#include <vector>

namespace wj::planner {

/// A bound at or beyond this magnitude is absent (Ipopt's convention: 2e19 = +inf).
inline constexpr double kSqpInfinity = 1e19;

/// The problem: values and derivatives by callback. Values are asked at every trial point,
/// derivatives only at accepted iterates (so the caller may take them by finite differences).
struct DenseSqpProblem {
  Eigen::VectorXd xl, xu;  ///< variable bounds (n), +-inf allowed
  Eigen::VectorXd cl, cu;  ///< constraint bounds (m); cl == cu is an equality
  /// f and c at x; false: no value there (the step is shortened).
  std::function<bool(const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c)> value;
  /// Gradient of f and Jacobian of c (m x n) at x, given f and c there; false: stop.
  std::function<bool(const Eigen::VectorXd& x, double f, const Eigen::VectorXd& c,
                     Eigen::VectorXd& grad, Eigen::MatrixXd& jac)>
      derivatives;
};

/// Solver settings (defaults suit the polish).
struct DenseSqpSettings {
  int max_iterations = 15;             ///< SQP iterations (one QP solve and line search each)
  double tolerance = 1e-6;             ///< KKT tolerance (stationarity, scaled by max(1, |grad f|))
  double constraint_tolerance = 1e-6;  ///< max violation at which a point counts as feasible
  int stall_iterations = 3;            ///< stop when the best feasible f has not dropped 0.1 %
                                       ///< in this many iterations (0 = off)
  /// Stop when no feasible point is known and, this many iterations in a row, the linearised
  /// constraints promised less than 1 % lower violation and the violation fell by less than
  /// 1 %: a locally infeasible point (0 = off).
  int infeasible_iterations = 2;
  double initial_penalty = 10.0;  ///< l1 penalty, times max(1, |grad f(x0)|_inf)
  double max_penalty = 1e9;       ///< the steering update stops here
  /// Initial step limit, as a fraction of each variable's range (or of max(1, |x0|) if
  /// unbounded); it doubles after full steps that reach it and shrinks to shortened ones.
  double initial_radius = 0.1;
  int max_backtracks = 12;     ///< line-search halvings before the step is given up
  int qp_max_iterations = 60;  ///< interior-point iterations per QP
  /// Leave out of each QP the linearised constraints that hold everywhere in the step's box
  /// (variable bounds and step limit): the same QP solution from fewer rows.
  bool screen_rows = true;
  bool print = false;  ///< one line per iteration on stderr (diagnosis)
};

/// Why the solver stopped.
enum class SqpStatus {
  Converged,          ///< KKT tolerance met at a feasible point
  Stalled,            ///< the stall rule (stall_iterations)
  MaxIterations,      ///< max_iterations reached
  SmallStep,          ///< the step became negligible (e.g. a locally infeasible stationary point)
  LocallyInfeasible,  ///< the violation stopped falling and the linearisation sees no way down
  LineSearchFailed,   ///< no decrease of the merit along the step, even after a BFGS reset
  EvaluationFailed,   ///< no value at the start point, or no derivatives at an iterate
  QpFailed,           ///< the QP's Newton matrix could not be factorised
};
const char* toString(SqpStatus s);

/// What the solver returns. `x` is the best point meeting the constraints to
/// constraint_tolerance among every point evaluated; when there is none, the last iterate.
struct DenseSqpResult {
  SqpStatus status = SqpStatus::EvaluationFailed;
  Eigen::VectorXd x;
  double f = 0.0;          ///< objective at x
  double violation = 0.0;  ///< max constraint violation at x
  bool feasible = false;   ///< violation <= constraint_tolerance
  int iterations = 0;
  int evaluations = 0;  ///< value() calls
  int qp_solves = 0;
  /// Linearised constraint rows offered to the QPs and kept by the screen, summed over them.
  long qp_rows_offered = 0, qp_rows_kept = 0;
};

/// Solves `problem` from x0 (projected into the box). Deterministic.
DenseSqpResult solveDenseSqp(const DenseSqpProblem& problem, const Eigen::VectorXd& x0,
                             const DenseSqpSettings& settings = {});

}  // namespace wj::planner
