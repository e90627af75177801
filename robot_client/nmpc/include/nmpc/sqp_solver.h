#pragma once
/// @file Multiple-shooting SQP for the centroidal NMPC (the scheme of OCS2's SqpSolver, written
/// from the papers): per iteration, linearise dynamics and constraints at every node, eliminate
/// the state-input equalities by projection, solve the LQ subproblem by a Riccati recursion,
/// and take a step chosen by a filter line search on (cost, constraint violation). Inequalities
/// enter the cost as relaxed barriers. With max_iterations = 1 it is a real-time iteration
/// scheme: one SQP iteration per MPC cycle, warm-started from the shifted previous solution.
///
/// Usage:
///   SqpSolver solver(settings, CentroidalOcp(CentroidalModel(robot), problem_settings));
///   solver.solve(t, x, targets);          // every MPC cycle
///   policy.copyFrom(solver.policy());     // publish to the control loop
///
/// Thread safety: one solver per thread; the problem inside is immutable.

#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

#include "nmpc/discretization.h"
#include "nmpc/policy.h"
#include "nmpc/problem.h"
#include "nmpc/riccati.h"

namespace wj::nmpc {

/// Settings of the SQP solver.
struct SqpSettings {
  double horizon_s = 1.0;  ///< prediction horizon (paper; OCS2's legged robot example) [s]
  double dt_s = 0.015;     ///< node spacing; rounded down so that nodes tile the horizon [s]
  Integrator integrator = Integrator::ForwardEuler;  ///< discretisation of each interval
  int max_iterations = 1;  ///< SQP iterations per solve() (1 = real-time iteration)
  /// Converged when the step's 2-norm is below this (or the step cannot change the cost by more
  /// than round-off)...
  double step_tolerance = 1e-6;
  double constraint_tolerance = 1e-6;    ///< ...and the constraint violation is below this
  double hessian_regularization = 1e-8;  ///< added to the reduced input Hessians
  double alpha_decay = 0.5;              ///< line search: step shrink factor
  double alpha_min = 1e-3;               ///< line search: smallest step tried
  double violation_max = 1e6;            ///< filter: a trial violating more is always rejected
  double violation_min = 1e-6;           ///< filter: below this only the cost has to decrease
  double armijo_factor = 1e-4;    ///< sufficient cost decrease per unit of directional derivative
  double cost_gamma = 1e-6;       ///< filter margin on the cost, times the violation
  double violation_gamma = 1e-6;  ///< filter margin on the violation (relative)
  bool feedback_policy = true;    ///< publish the Riccati gains (false: K = 0)

  /// Throws std::invalid_argument naming the field when a value is out of range.
  void validate() const;
};

/// Why solve() returned.
enum class SqpStatus : std::uint8_t {
  Converged,         ///< step and constraint violation below their tolerances
  IterationLimit,    ///< max_iterations done (the normal outcome of a real-time iteration)
  LineSearchFailed,  ///< no trial step was accepted; the previous iterate was kept
  RiccatiFailed,     ///< a reduced Hessian could not be made positive definite
};

/// "converged", "iteration_limit", "line_search_failed", "riccati_failed".
std::string_view toString(SqpStatus status);

/// CPU time of the solving thread in the parts of the last solve() [ms], summed over its
/// iterations.
struct SqpTimings {
  double linearization_ms = 0.0;  ///< dynamics, cost and constraint derivatives at all nodes
  double projection_ms = 0.0;     ///< QR of the constraint Jacobians and LQ projection
  double riccati_ms = 0.0;        ///< backward Riccati recursion
  double rollout_ms = 0.0;        ///< forward pass of the LQ solution (state and input steps)
  double line_search_ms = 0.0;    ///< trial evaluations of the filter line search
  double total_ms = 0.0;          ///< the whole solve(), including setup and policy
};

/// Outcome of the last solve().
struct SqpStats {
  SqpStatus status = SqpStatus::IterationLimit;
  int iterations = 0;
  double cost = 0.0;        ///< of the final iterate
  double violation = 0.0;   ///< 2-norm of the dynamics defects and equality residuals
  double step_norm = 0.0;   ///< 2-norm of the last accepted step
  double last_alpha = 0.0;  ///< last accepted step size (0: rejected)
  SqpTimings timings;
};

/// See the file comment.
class SqpSolver {
 public:
  /// Allocates everything the solver needs, here, once. Throws std::invalid_argument on bad
  /// settings.
  SqpSolver(const SqpSettings& settings, CentroidalOcp problem);

  /// One MPC cycle from time t0 at measured state x0 with these targets. The first call (or
  /// the first after reset()) starts from x0 held over the horizon and the weight-sharing
  /// input; later calls warm-start from the previous solution shifted to t0.
  SqpStatus solve(double t0, const State& x0, const Targets& targets);
  /// Forgets the previous solution (the next solve() starts cold).
  void reset() { initialized_ = false; }

  /// Policy of the last solve().
  const Policy& policy() const { return policy_; }
  /// Outcome of the last solve().
  const SqpStats& stats() const { return stats_; }
  /// Solver settings.
  const SqpSettings& settings() const { return settings_; }
  /// The optimal control problem.
  const CentroidalOcp& problem() const { return problem_; }

  /// Number of shooting intervals N (nodes 0..N).
  int numIntervals() const { return n_; }
  /// Interval length [s].
  double dt() const { return dt_; }
  /// Node times, states (N + 1) and inputs (N) of the current iterate.
  const std::vector<double>& times() const { return times_; }
  const std::vector<State>& states() const { return x_; }
  const std::vector<Input>& inputs() const { return u_; }
  /// Node targets of the last solve() (N + 1).
  const std::vector<NodeTargets>& nodeTargets() const { return nodes_; }

  /// Cost and constraint violation of a trajectory under the node targets of the last solve.
  void evaluateTrajectory(const std::vector<State>& x, const std::vector<Input>& u, double& cost,
                          double& violation);

 private:
  void initialize(const State& x0);
  void shift(double t0);
  // Linearises and projects every node; returns the cost and violation of the iterate and the
  // directional derivative data kept in members.
  void linearize(double& cost, double& violation);
  bool solveLq();
  double lineSearch(double cost, double violation, double& new_cost, double& new_violation);
  void buildPolicy();

  SqpSettings settings_;
  CentroidalOcp problem_;
  int n_ = 0;
  double dt_ = 0.0;
  bool initialized_ = false;
  double t0_ = 0.0;

  std::vector<double> times_;
  std::vector<NodeTargets> nodes_;
  std::vector<State> x_, x_trial_, dx_;
  std::vector<Input> u_, u_trial_, du_;
  std::vector<ModelData> data_;
  ModelData scratch_;
  std::vector<StateMatrix> A_;
  std::vector<StateInputMatrix> B_;
  std::vector<CostQuadratic> cost_;
  std::vector<EqualityLinearization> eq_;
  std::vector<InputProjection> projection_;
  std::vector<LqStage> lq_;
  std::vector<RiccatiGain> gains_;
  std::vector<ReducedVector> dz_;
  std::vector<ContactFlags> prev_contact_;  // node contacts of the previous solve

  std::vector<std::pair<double, double>> filter_;
  bool converged_at_round_off_ =
      false;  // the last step could only change round-off  // (cost, violation) of the filter

  Policy policy_;
  SqpStats stats_;
};

}  // namespace wj::nmpc
