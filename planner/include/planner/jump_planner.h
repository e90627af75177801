#pragma once
/// @file The jump planner: Differential Evolution over the planar jump model, then a gradient
/// polish (dense SQP or Ipopt) with hard constraints and the target as an equality.

#include <Eigen/Core>
#include <atomic>
#include <optional>
#include <string>
#include <vector>

#include "planner/de/differential_evolution.h"
#include "planner/jump_model.h"
#include "planner/jump_plan.h"
#include "planner/jump_task.h"
#include "planner/planner_settings.h"
#include "robot_model/robot_model.h"

namespace wj::planner {

/// Per-request overrides of the settings.
struct PlanOptions {
  std::optional<std::uint64_t> seed;            ///< DE seed
  std::optional<std::int64_t> max_evaluations;  ///< DE evaluation budget
  std::optional<double> time_budget_s;          ///< DE wall-time budget
  std::optional<int> threads;                   ///< DE evaluation threads
  std::optional<bool> polish;                   ///< run the polish
  /// Warm-start candidates in the search space u (kNumDecision x k), e.g. from the cache.
  Eigen::MatrixXd warm_start;
  /// How many distinct candidates to return for verification (best first), >= 1.
  int num_candidates = 1;
  /// The lift-off correction of the model's flight (JumpModel's constructor); zero: none.
  LiftOffCorrection liftoff_correction;
  const std::atomic<bool>* cancel = nullptr;  ///< polled between DE generations
};

/// Outcome of the polish.
enum class PolishOutcome {
  NotRun,    ///< disabled, or nothing to polish
  Improved,  ///< accepted: lower cost than the DE's best
  Rejected,  ///< the solver ended, but its point was not better; the DE's best is kept
  Failed,    ///< the solver reported an error; the DE's best is kept
};
const char* toString(PolishOutcome o);

/// What the polish asks of the target.
enum class PolishGoal {
  /// The target errors are equalities (= 0); minimise the take-off energy. For a target in
  /// reach: it is met exactly.
  MeetTarget,
  /// For a target out of reach, from a point meeting every constraint: the target cost (the
  /// planner's, sum of (error / tolerance)^2) plus the energy term is the objective, and the
  /// constraints stay hard, so the polish comes as close to the target as they allow. With
  /// MeetTarget it would trade constraint violation for target error, which the planner's
  /// prioritized cost then rejects (docs/planner.md, "Polish").
  ClosestApproach,
};
/// "meet_target" or "closest_approach".
const char* toString(PolishGoal g);
/// The goal the planner gives the polish of a point evaluated as `ev`: ClosestApproach when it
/// meets every constraint and misses the target (the DE stops early only within the target's
/// tolerances, so the target is out of reach from there), else MeetTarget.
PolishGoal polishGoalFor(const Evaluation& ev);

/// A solved candidate: its search vector, evaluation and plan.
struct Candidate {
  Eigen::VectorXd u;
  Evaluation evaluation;
};

struct PlannerResult {
  JumpPlan plan;                      ///< dense plan of the best candidate
  Evaluation evaluation;              ///< evaluation of the best candidate (after the polish)
  Eigen::VectorXd u;                  ///< its search vector
  std::vector<Candidate> candidates;  ///< best distinct candidates, best first (incl. the best)
  de::Result de;                      ///< the DE's result and per-generation log
  int de_restarts = 0;                ///< DE restarts after stagnation without a feasible candidate
  PolishOutcome polish = PolishOutcome::NotRun;
  PolishGoal polish_goal = PolishGoal::MeetTarget;  ///< of the final polish (the retries meet)
  int polish_iterations = 0;
  int polish_retries = 0;   ///< other attempts' bests polished after the best stayed infeasible
  double de_cost = 0.0;     ///< best cost after the DE
  double final_cost = 0.0;  ///< after the polish (<= de_cost)
  double de_ms = 0.0, polish_ms = 0.0, total_ms = 0.0;
  /// Violated classes (most important first); when feasible, empty. If the constraints hold
  /// but the target is missed, the classes with the smallest relative margin (the ones that
  /// bind) are listed instead.
  std::vector<ConstraintClass> binding;
  std::string summary;  ///< one sentence
};

/// Plans jumps for one robot with one set of settings. Immutable; plan() is const and
/// thread-safe (each call builds its own model and workspaces).
class JumpPlanner {
 public:
  JumpPlanner(model::RobotModel robot, PlannerSettings settings);

  /// Plans `task` from `initial`. Throws std::invalid_argument (naming the field) for bad input.
  PlannerResult plan(const JumpTask& task, const InitialState& initial,
                     const PlanOptions& options = {}) const;

  const model::RobotModel& robot() const { return robot_; }
  const PlannerSettings& settings() const { return settings_; }
  /// The take-off posture of the presets (all legs at the settings' stand angles).
  Eigen::Matrix<double, model::kNumJoints, 1> standPosture() const;

 private:
  /// The warm start handed to the DE: the given points and warm_start_cloud perturbations.
  Eigen::MatrixXd warmCloud(const JumpModel& model, const Eigen::MatrixXd& warm,
                            std::uint64_t seed) const;
  /// The points the first population starts from: the request's warm start and, for a
  /// backflip, the settings' flip_initial_guess after it (none if empty).
  Eigen::MatrixXd initialGuesses(const JumpTask& task, const PlanOptions& options) const;

  model::RobotModel robot_;
  PlannerSettings settings_;
};

/// The binding constraint classes of an evaluation: the violated ones, highest priority first;
/// when the constraints hold but the target is missed, the nearly active ones (margin under
/// `backoff` + 5 % of the class scale; `backoff` is the margin the polish keeps,
/// polish.backoff), which are what stop the target; empty when feasible.
std::vector<ConstraintClass> findBindingClasses(const Evaluation& ev, double backoff);
/// One sentence on an evaluation and its binding classes (PlannerResult::summary).
std::string summarizeEvaluation(const Evaluation& ev, const std::vector<ConstraintClass>& binding);

/// Polish of candidate u0 on `model`: minimises the take-off energy subject to every
/// sampled constraint (>= polish.backoff) and the target errors (= 0), or with
/// PolishGoal::ClosestApproach the target cost subject to the same constraints, in at most
/// `max_iterations` (0: polish.max_iterations), with the solver of `polish.solver`. Returns the
/// polished point in `u` (the best point meeting the constraints, else the last iterate); the
/// caller accepts it only after a full evaluation. Failed: no value at u0 or a solver error.
/// `threads` share the finite-difference Jacobians (the result does not depend on them).
PolishOutcome polishCandidate(const JumpModel& model, const Eigen::VectorXd& u0, Eigen::VectorXd& u,
                              int* iterations, int max_iterations = 0,
                              PolishGoal goal = PolishGoal::MeetTarget, int threads = 1);
/// The polish by Ipopt 3.11 + MUMPS (polish.solver: ipopt).
PolishOutcome polishWithIpopt(const JumpModel& model, const Eigen::VectorXd& u0, Eigen::VectorXd& u,
                              int* iterations, int max_iterations = 0,
                              PolishGoal goal = PolishGoal::MeetTarget, int threads = 1);
/// The polish by the dense SQP solver of the planner (polish.solver: sqp).
PolishOutcome polishWithSqp(const JumpModel& model, const Eigen::VectorXd& u0, Eigen::VectorXd& u,
                            int* iterations, int max_iterations = 0,
                            PolishGoal goal = PolishGoal::MeetTarget, int threads = 1);

}  // namespace wj::planner
