#pragma once
/// @file Generation-synchronous Differential Evolution with a parallel population evaluation.
///
/// Problem, settings and solver are separate types (see STYLE.md). The problem is immutable and
/// evaluated concurrently, each worker with its own Workspace (Pinocchio's model/data split).
/// Every random number is drawn by the solver's single seeded generator outside the parallel
/// section, so the same seed gives the same result whatever the thread count, unless a wall-time
/// budget or cancellation cuts the run short.

#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <string_view>
#include <vector>

namespace wj::planner::de {

/// Scratch memory of one worker thread; problems derive from it to keep buffers.
struct Workspace {
  virtual ~Workspace() = default;
};

/// Value of one candidate: the cost to minimise, and whether it satisfies all constraints.
struct Fitness {
  double cost = std::numeric_limits<double>::infinity();
  bool feasible = true;
};

/// A box-bounded minimisation problem.
class Problem {
 public:
  virtual ~Problem() = default;
  /// Number of decision variables.
  virtual int dimension() const = 0;
  /// Lower box bounds; lower(i) <= upper(i); equal bounds fix a variable.
  virtual Eigen::VectorXd lowerBounds() const = 0;
  /// Upper box bounds, same size as lowerBounds().
  virtual Eigen::VectorXd upperBounds() const = 0;
  /// Whether evaluate() may run concurrently on distinct workspaces (pagmo's thread safety
  /// declaration). The solver refuses to parallelise a problem that says no: it then evaluates
  /// the population serially on one workspace, whatever Settings::threads says.
  virtual bool isThreadSafe() const { return true; }
  /// A fresh workspace for one worker.
  virtual std::unique_ptr<Workspace> createWorkspace() const {
    return std::make_unique<Workspace>();
  }
  /// Cost of candidate x (inside the bounds). Must not throw; return +inf for a failed model.
  virtual Fitness evaluate(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace& ws) const = 0;
  /// evaluate() with a cut-off: it may stop as soon as the cost is known to exceed `bound`, and
  /// then return a lower bound of the cost that is > bound, with feasible = false. The solver
  /// passes a trial's parent cost, and a trial that costs more than its parent is rejected
  /// whatever its exact cost, so a run makes the same decisions as with full evaluations, only
  /// sooner. The default evaluates in full.
  virtual Fitness evaluateBounded(const Eigen::Ref<const Eigen::VectorXd>& x, Workspace& ws,
                                  double bound) const {
    (void)bound;
    return evaluate(x, ws);
  }
};

/// Mutation strategy (Storn and Price notation).
enum class Strategy {
  Rand1Bin,            ///< v = x_r1 + F (x_r2 - x_r3)
  Best1Bin,            ///< v = x_best + F (x_r1 - x_r2)
  CurrentToBest1Bin,   ///< v = x_i + F (x_best - x_i) + F (x_r1 - x_r2)
  Rand2Bin,            ///< v = x_r1 + F (x_r2 - x_r3) + F (x_r4 - x_r5)
  CurrentToPBest1Bin,  ///< JADE/SHADE: v = x_i + F (x_pbest - x_i) + F (x_r1 - x_r2)
};

/// Self-adaptation of F and CR.
enum class Adaptation {
  None,   ///< fixed F and CR from the settings
  JDE,    ///< Brest et al. 2006: per-individual F, CR resampled with probability tau1, tau2
  SHADE,  ///< Tanabe and Fukunaga 2013: success-history memories of F and CR
};

/// How the first population is drawn.
enum class Initialization {
  Uniform,          ///< independent uniform samples in the box
  LatinHypercube,   ///< one sample per stratum in every dimension
  OppositionBased,  ///< Rahnamayan et al.: the best half of uniform samples and their opposites
};

/// Why the solver stopped.
enum class StopReason {
  MaxGenerations,
  MaxEvaluations,
  TimeBudget,
  Tolerance,      ///< the population's cost spread fell below the tolerance
  Stagnation,     ///< the best cost did not improve for stagnation_generations
  TargetReached,  ///< a feasible candidate reached target_cost
  Cancelled,
};
/// Name of a stop reason, e.g. "MaxEvaluations".
std::string_view toString(StopReason reason);
/// Name of a strategy, e.g. "CurrentToPBest1Bin".
std::string_view toString(Strategy strategy);
/// Name of an adaptation scheme, e.g. "SHADE".
std::string_view toString(Adaptation adaptation);
/// Name of an initialization, e.g. "LatinHypercube".
std::string_view toString(Initialization initialization);

struct Settings {
  int population_size = 40;  ///< NP >= 5 (>= 7 for Rand2Bin)
  Strategy strategy = Strategy::CurrentToPBest1Bin;
  Adaptation adaptation = Adaptation::JDE;
  Initialization initialization = Initialization::LatinHypercube;
  double F = 0.5;                            ///< scale factor, fixed or initial, in (0, 2]
  double CR = 0.9;                           ///< crossover rate, fixed or initial, in [0, 1]
  double p_best = 0.1;                       ///< CurrentToPBest1Bin: top fraction, (0, 1]
  int max_generations = 1000;                ///< >= 1
  std::int64_t max_evaluations = 1'000'000;  ///< >= population_size
  double time_budget_s = 0.0;                ///< wall-time limit; 0 = none
  double tolerance = 0.0;                    ///< stop when max - min cost < tolerance; 0 = off
  int stagnation_generations = 0;            ///< 0 = off
  /// Relative drop of the best cost that counts as progress for the stagnation test, in [0, 1).
  double stagnation_tolerance = 1e-12;
  double target_cost = -std::numeric_limits<double>::infinity();  ///< stop at a feasible one <=
  int threads = 1;         ///< OpenMP threads for evaluation, >= 1
  std::uint64_t seed = 1;  ///< seed of the only random source
  bool keep_log = true;    ///< record one GenerationLog per generation
  /// SHADE success-history length H >= 0; 0 = population_size (Tanabe and Fukunaga 2013: H = NP).
  int shade_memory_size = 0;
  /// Evaluate trials with their parent's cost as cut-off (Problem::evaluateBounded). The
  /// result is the same either way; off, every evaluation runs in full. (One statistic can
  /// differ: first_feasible_* misses a feasible trial that lost to a cheaper infeasible parent,
  /// which a problem whose feasible costs lie below its infeasible ones never has.)
  bool bounded_trials = true;

  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

/// One generation of the log. Generation 0 is the initial population; mean_F and mean_CR are the
/// means over the trial vectors built in that generation (the initial values for generation 0).
struct GenerationLog {
  int generation = 0;
  std::int64_t evaluations = 0;
  double best_cost = 0.0;
  double mean_cost = 0.0;
  bool best_feasible = false;
  double mean_F = 0.0;
  double mean_CR = 0.0;
  double elapsed_s = 0.0;  ///< wall time since the start (not part of determinism)
};

struct Result {
  Eigen::VectorXd best_x;
  Fitness best;
  StopReason stop_reason = StopReason::MaxGenerations;
  std::int64_t evaluations = 0;  ///< all evaluations, the initial population's included
  int generations = 0;           ///< generations after the initial population (log has one more)
  double elapsed_s = 0.0;
  /// Evaluations and seconds until the first feasible candidate; -1 if none was found. The count
  /// is exact (batch order); the time is taken when that candidate's batch finished.
  std::int64_t first_feasible_evaluations = -1;
  double first_feasible_s = -1.0;
  std::vector<GenerationLog> log;
  /// Final population (one candidate per column) and costs, sorted best first.
  Eigen::MatrixXd population;
  std::vector<Fitness> fitness;
};

class Solver {
 public:
  /// Validates the settings (throws std::invalid_argument).
  explicit Solver(Settings settings);
  const Settings& settings() const { return settings_; }

  /// Minimises `problem`. `warm_start` (dimension x k, k >= 0) seeds the first k individuals,
  /// clipped into the bounds; the rest is drawn by the configured initialization. `cancel`, if
  /// given, is polled once per generation. Throws std::invalid_argument for inconsistent
  /// bounds (lower > upper, non-finite) or a warm start of the wrong dimension or with a non-finite
  /// entry. If evaluate() throws anyway, the exception is rethrown once the batch has finished.
  Result solve(const Problem& problem, const Eigen::MatrixXd& warm_start = Eigen::MatrixXd(),
               const std::atomic<bool>* cancel = nullptr) const;

 private:
  Settings settings_;
};

}  // namespace wj::planner::de
