// Dense-SQP polish of a DE candidate (the problem is polish_problem.h, the solver dense_sqp.h),
// and the polish entry point that picks the solver from `polish.solver`.
#include <cstdio>
#include <cstdlib>

#include "dense_sqp.h"
#include "planner/jump_planner.h"
#include "polish_problem.h"

namespace wj::planner {

PolishOutcome polishWithSqp(const JumpModel& model, const Eigen::VectorXd& u0, Eigen::VectorXd& u,
                            int* iterations, int max_iterations, PolishGoal goal, int threads) {
  u = u0;
  PolishProblem problem(model, u0, goal);
  DenseSqpProblem nlp;
  nlp.xl = problem.xLower();
  nlp.xu = problem.xUpper();
  nlp.cl = problem.cLower();
  nlp.cu = problem.cUpper();
  nlp.value = [&problem](const Eigen::VectorXd& x, double& f, Eigen::VectorXd& c) {
    return problem.value(x, f, c);
  };
  nlp.derivatives = [&problem](const Eigen::VectorXd& x, double f, const Eigen::VectorXd& c,
                               Eigen::VectorXd& grad, Eigen::MatrixXd& jac) {
    return problem.derivatives(x, f, c, grad, jac);
  };
  const PlannerSettings& s = model.settings();
  DenseSqpSettings st;
  st.max_iterations = max_iterations > 0 ? max_iterations : s.polish_max_iterations;
  st.tolerance = s.polish_tolerance;
  st.constraint_tolerance = kPolishConstraintTolerance;
  st.stall_iterations = s.polish_stall_iterations;
  st.print = std::getenv("WJ_SQP_PRINT") != nullptr;
  const DenseSqpResult r = problem.solveWithThreads(
      threads, [&] { return solveDenseSqp(nlp, problem.startPoint(), st); });
  if (iterations) *iterations = r.iterations;
  if (st.print)
    std::fprintf(stderr, "sqp polish (%s): %s after %d iterations, %d evaluations, feasible %d\n",
                 toString(goal), toString(r.status), r.iterations, r.evaluations,
                 r.feasible ? 1 : 0);
  // No value at the DE's point: nothing to polish (Ipopt reports the same as an error).
  if (r.status == SqpStatus::EvaluationFailed && r.evaluations <= 1) return PolishOutcome::Failed;
  u = problem.fullVector(r.x);
  return PolishOutcome::Rejected;  // the caller decides on the full evaluation
}

PolishOutcome polishCandidate(const JumpModel& model, const Eigen::VectorXd& u0, Eigen::VectorXd& u,
                              int* iterations, int max_iterations, PolishGoal goal, int threads) {
  switch (model.settings().polish_solver) {
    case PolishSolver::Ipopt:
      return polishWithIpopt(model, u0, u, iterations, max_iterations, goal, threads);
    case PolishSolver::Sqp:
      break;
  }
  return polishWithSqp(model, u0, u, iterations, max_iterations, goal, threads);
}

const char* toString(PolishGoal g) {
  switch (g) {
    case PolishGoal::MeetTarget:
      return "meet_target";
    case PolishGoal::ClosestApproach:
      return "closest_approach";
  }
  return "?";
}

}  // namespace wj::planner
