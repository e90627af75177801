#include "planner/de/differential_evolution.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "adaptation.h"
#include "batch_team.h"
#include "operators.h"
#include "random.h"

namespace wj::planner::de {
namespace {

using Clock = std::chrono::steady_clock;

/// Throws std::invalid_argument "<field> must be <range>, got <value>" unless `ok`.
template <typename T>
void require(bool ok, std::string_view field, std::string_view range, const T& value) {
  if (ok) return;
  std::ostringstream message;
  message << field << " must be " << range << ", got " << value;
  throw std::invalid_argument(message.str());
}

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// Ordering of candidates: lower cost first; at equal cost a feasible one first.
bool ranksBefore(const Fitness& a, const Fitness& b) {
  if (a.cost != b.cost) return a.cost < b.cost;
  return a.feasible && !b.feasible;
}

/// The problem's bounds, checked: right size, finite, lower <= upper.
Box checkedBox(const Problem& problem) {
  const int dimension = problem.dimension();
  require(dimension >= 1, "Problem::dimension()", ">= 1", dimension);
  Box box{problem.lowerBounds(), problem.upperBounds(), {}};
  require(box.lower.size() == dimension, "Problem::lowerBounds().size()",
          "equal to dimension() = " + std::to_string(dimension), box.lower.size());
  require(box.upper.size() == dimension, "Problem::upperBounds().size()",
          "equal to dimension() = " + std::to_string(dimension), box.upper.size());
  for (int j = 0; j < dimension; ++j) {
    // (Appended, not "[" + ... : GCC 12 at -O3 warns falsely on that form, GCC bug 105651.)
    std::string index = "[";
    index += std::to_string(j);
    index += ']';
    require(std::isfinite(box.lower(j)), "lower bound" + index, "finite", box.lower(j));
    require(std::isfinite(box.upper(j)), "upper bound" + index, "finite", box.upper(j));
    std::ostringstream range;
    range << "<= upper bound" << index << " = " << box.upper(j);
    require(box.lower(j) <= box.upper(j), "lower bound" + index, range.str(), box.lower(j));
    if (box.lower(j) < box.upper(j)) box.free.push_back(j);
  }
  return box;
}

/// Checks a warm start: `dimension` rows (unless it has no column) and finite entries.
void checkWarmStart(const Eigen::MatrixXd& warm_start, int dimension) {
  if (warm_start.cols() == 0) return;
  require(warm_start.rows() == dimension, "warm_start.rows()",
          "equal to the problem dimension " + std::to_string(dimension), warm_start.rows());
  for (Eigen::Index c = 0; c < warm_start.cols(); ++c) {
    for (Eigen::Index r = 0; r < warm_start.rows(); ++r) {
      std::string entry = "(";  // appended: see checkedBox()
      entry += std::to_string(r);
      entry += ", ";
      entry += std::to_string(c);
      entry += ')';
      require(std::isfinite(warm_start(r, c)), "warm_start" + entry, "finite", warm_start(r, c));
    }
  }
}

/// State of one solve: every buffer is sized here once, so that a generation allocates nothing
/// (beyond what the problem does, and the log growing).
class Run {
 public:
  Run(const Settings& settings, const Problem& problem, Box box, Clock::time_point start)
      : settings_(settings),
        problem_(problem),
        box_(std::move(box)),
        np_(settings.population_size),
        dimension_(static_cast<int>(box_.lower.size())),
        start_(start),
        rng_(settings.seed),
        control_(makeParameterControl(settings, np_)),
        mutate_(mutationFor(settings.strategy)),
        population_(dimension_, np_),
        fitness_(static_cast<std::size_t>(np_)),
        trials_(dimension_, np_),
        trial_fitness_(static_cast<std::size_t>(np_)),
        trial_parameters_(static_cast<std::size_t>(np_)),
        mutant_(dimension_),
        ranking_(static_cast<std::size_t>(np_)),
        archive_(dimension_, settings.strategy == Strategy::CurrentToPBest1Bin ? np_ : 0),
        errors_(static_cast<std::size_t>(np_)) {
    // A problem that is not thread-safe is evaluated serially on a single workspace.
    const int workers = problem.isThreadSafe() ? std::min(settings.threads, np_) : 1;
    for (int w = 0; w < workers; ++w) {
      workspaces_.push_back(problem.createWorkspace());
      if (!workspaces_.back())
        throw std::invalid_argument("Problem::createWorkspace() returned null");
    }
    // SHADE's p_min = 2 / NP: the p-best pool has at least two members.
    pbest_count_ = std::clamp(static_cast<int>(std::lround(settings.p_best * np_)), 2, np_);
    if (settings.keep_log) {
      result_.log.reserve(static_cast<std::size_t>(std::min(settings.max_generations, 4096)) + 1);
    }
  }

  /// Number of worker threads (workspaces) this run evaluates on.
  int workers() const { return static_cast<int>(workspaces_.size()); }

  /// `team`: the threads that evaluate the batches with the calling one (nullptr: serial).
  Result solve(const Eigen::MatrixXd& warm_start, const std::atomic<bool>* cancel,
               BatchTeam* team = nullptr) {
    team_ = team;
    initialize(warm_start);
    rank();
    record(ControlParameters{settings_.F, settings_.CR});
    stagnation_reference_ = bestFitness().cost;

    std::optional<StopReason> stop;
    while (!(stop = checkStop(cancel))) {
      const auto remaining = settings_.max_evaluations - result_.evaluations;
      const int count = static_cast<int>(std::min<std::int64_t>(np_, remaining));
      const ControlParameters means = evolve(count);
      rank();
      updateStagnation();
      record(means);
    }
    return finish(*stop);
  }

 private:
  const Fitness& bestFitness() const { return fitness_[static_cast<std::size_t>(ranking_[0])]; }

  /// Evaluates columns [0, count) of `x` into `out` in parallel, then counts them and notes the
  /// first feasible one (by its index in the batch, so deterministically).
  /// With `bounds`, candidate i is evaluated with cut-off bounds[i].cost (evaluateBounded).
  void evaluate(const Eigen::MatrixXd& x, int count, std::vector<Fitness>& out,
                const std::vector<Fitness>* bounds = nullptr) {
    auto task = [&](int i, int thread) {
      Workspace& workspace = *workspaces_[static_cast<std::size_t>(thread)];
      try {
        Fitness f = bounds ? problem_.evaluateBounded(x.col(i), workspace,
                                                      (*bounds)[static_cast<std::size_t>(i)].cost)
                           : problem_.evaluate(x.col(i), workspace);
        if (std::isnan(f.cost)) f.cost = std::numeric_limits<double>::infinity();
        out[static_cast<std::size_t>(i)] = f;
      } catch (...) {  // rethrown below, on the calling thread
        errors_[static_cast<std::size_t>(i)] = std::current_exception();
      }
    };
    if (team_ != nullptr && count > 1 && count <= BatchTeam::kMaxCount) {
      team_->run(count, task);
    } else {
      for (int i = 0; i < count; ++i) task(i, 0);
    }
    for (int i = 0; i < count; ++i) {
      if (errors_[static_cast<std::size_t>(i)])
        std::rethrow_exception(errors_[static_cast<std::size_t>(i)]);
    }
    if (result_.first_feasible_evaluations < 0) {
      for (int i = 0; i < count; ++i) {
        if (out[static_cast<std::size_t>(i)].feasible) {
          result_.first_feasible_evaluations = result_.evaluations + i + 1;
          result_.first_feasible_s = secondsSince(start_);
          break;
        }
      }
    }
    result_.evaluations += count;
  }

  /// Draws, evaluates and, for opposition-based learning, reduces the initial population; the
  /// first min(k, NP) individuals are the warm start, clipped into the box.
  void initialize(const Eigen::MatrixXd& warm_start) {
    const int warm = static_cast<int>(std::min<Eigen::Index>(warm_start.cols(), np_));
    for (int c = 0; c < warm; ++c) {
      population_.col(c) = warm_start.col(c).cwiseMax(box_.lower).cwiseMin(box_.upper);
    }
    const int drawn = np_ - warm;
    auto sampled = population_.rightCols(drawn);
    switch (settings_.initialization) {
      case Initialization::Uniform:
      case Initialization::OppositionBased:
        sampleUniform(box_, rng_, sampled);
        break;
      case Initialization::LatinHypercube:
        sampleLatinHypercube(box_, rng_, sampled);
        break;
    }
    evaluate(population_, np_, fitness_);
    if (settings_.initialization == Initialization::OppositionBased && drawn > 0) {
      keepBestOfOpposites(warm, drawn);
    }
  }

  /// Opposition-based initialization (Rahnamayan, Tizhoosh and Salama 2008): the opposites
  /// lower + upper - x of the `drawn` uniform samples are evaluated too (as many as the evaluation
  /// budget allows, in order) and the best `drawn` of both sets are kept. Warm-start individuals
  /// are kept as they are.
  void keepBestOfOpposites(int warm, int drawn) {
    const auto budget = settings_.max_evaluations - result_.evaluations;
    const int opposites = static_cast<int>(std::min<std::int64_t>(drawn, budget));
    if (opposites == 0) return;
    oppositePoints(box_, population_.middleCols(warm, opposites), trials_.leftCols(opposites));
    evaluate(trials_, opposites, trial_fitness_);

    // Candidates 0..drawn-1 are the samples, drawn..drawn+opposites-1 their opposites.
    std::vector<int> order(static_cast<std::size_t>(drawn + opposites));
    std::iota(order.begin(), order.end(), 0);
    const auto fitnessOf = [&](int k) -> const Fitness& {
      return k < drawn ? fitness_[static_cast<std::size_t>(warm + k)]
                       : trial_fitness_[static_cast<std::size_t>(k - drawn)];
    };
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return ranksBefore(fitnessOf(a), fitnessOf(b)); });
    Eigen::MatrixXd kept(dimension_, drawn);
    std::vector<Fitness> kept_fitness(static_cast<std::size_t>(drawn));
    for (int c = 0; c < drawn; ++c) {
      const int k = order[static_cast<std::size_t>(c)];
      kept.col(c) = k < drawn ? population_.col(warm + k) : trials_.col(k - drawn);
      kept_fitness[static_cast<std::size_t>(c)] = fitnessOf(k);
    }
    population_.rightCols(drawn) = kept;
    std::copy(kept_fitness.begin(), kept_fitness.end(), fitness_.begin() + warm);
  }

  /// One generation: builds the trials of individuals [0, count) serially with the single random
  /// generator, evaluates them as one parallel batch, then selects serially. Returns the mean F
  /// and CR of the trials.
  ControlParameters evolve(int count) {
    const MutationInput input{population_, ranking_, archive_, archive_size_, pbest_count_};
    ControlParameters sum{0.0, 0.0};
    for (int i = 0; i < count; ++i) {
      const ControlParameters p = control_->sample(i, rng_);
      trial_parameters_[static_cast<std::size_t>(i)] = p;
      sum.F += p.F;
      sum.CR += p.CR;
      mutate_(input, i, p.F, rng_, mutant_);
      crossoverBinomial(population_.col(i), mutant_, p.CR, box_, rng_, trials_.col(i));
    }
    evaluate(trials_, count, trial_fitness_, settings_.bounded_trials ? &fitness_ : nullptr);

    // Selection (Storn and Price 1997): the trial replaces its parent if it is better or equal.
    // A trial cut off by its parent's cost reports a cost above it, so it loses as it would have.
    for (int i = 0; i < count; ++i) {
      const auto s = static_cast<std::size_t>(i);
      const Fitness& trial = trial_fitness_[s];
      Fitness& parent = fitness_[s];
      const bool replaced = trial.cost <= parent.cost;
      const double improvement = trial.cost < parent.cost ? parent.cost - trial.cost : 0.0;
      if (improvement > 0.0) archive(i);
      control_->select(i, trial_parameters_[s], replaced, improvement);
      if (replaced) {
        population_.col(i) = trials_.col(i);
        parent = trial;
      }
    }
    control_->endGeneration();
    ++result_.generations;
    return {sum.F / count, sum.CR / count};
  }

  /// JADE's archive (Zhang and Sanderson 2009): a parent beaten by its trial is kept; when the
  /// archive holds NP members a random one is overwritten.
  void archive(int i) {
    if (archive_.cols() == 0) return;
    if (archive_size_ < archive_.cols()) {
      archive_.col(archive_size_++) = population_.col(i);
    } else {
      archive_.col(rng_.index(archive_size_)) = population_.col(i);
    }
  }

  /// Sorts ranking_ best first; ties broken by index, so the order is deterministic.
  void rank() {
    std::iota(ranking_.begin(), ranking_.end(), 0);
    std::sort(ranking_.begin(), ranking_.end(), [&](int a, int b) {
      const Fitness& fa = fitness_[static_cast<std::size_t>(a)];
      const Fitness& fb = fitness_[static_cast<std::size_t>(b)];
      if (ranksBefore(fa, fb)) return true;
      if (ranksBefore(fb, fa)) return false;
      return a < b;
    });
  }

  /// Resets the stagnation counter if the best cost dropped by more than stagnation_tolerance
  /// (relative) since the counter was last reset.
  void updateStagnation() {
    const double best = bestFitness().cost;
    const double ref = stagnation_reference_;
    const bool improved = std::isfinite(ref)
                              ? best < ref - settings_.stagnation_tolerance * std::abs(ref)
                              : best < ref;
    if (improved) {
      stagnation_reference_ = best;
      stagnant_generations_ = 0;
    } else {
      ++stagnant_generations_;
    }
  }

  /// The first criterion that holds, deterministic ones first, then wall time and cancellation.
  std::optional<StopReason> checkStop(const std::atomic<bool>* cancel) const {
    const Fitness& best = bestFitness();
    if (best.feasible && best.cost <= settings_.target_cost) return StopReason::TargetReached;
    if (settings_.tolerance > 0.0) {
      const double spread = fitness_[static_cast<std::size_t>(ranking_.back())].cost - best.cost;
      if (spread < settings_.tolerance) return StopReason::Tolerance;
    }
    if (settings_.stagnation_generations > 0 &&
        stagnant_generations_ >= settings_.stagnation_generations) {
      return StopReason::Stagnation;
    }
    if (result_.evaluations >= settings_.max_evaluations) return StopReason::MaxEvaluations;
    if (result_.generations >= settings_.max_generations) return StopReason::MaxGenerations;
    if (settings_.time_budget_s > 0.0 && secondsSince(start_) >= settings_.time_budget_s) {
      return StopReason::TimeBudget;
    }
    if (cancel != nullptr && cancel->load(std::memory_order_relaxed)) return StopReason::Cancelled;
    return std::nullopt;
  }

  /// Appends the log entry of the generation just completed.
  void record(const ControlParameters& means) {
    if (!settings_.keep_log) return;
    GenerationLog entry;
    entry.generation = result_.generations;
    entry.evaluations = result_.evaluations;
    entry.best_cost = bestFitness().cost;
    entry.best_feasible = bestFitness().feasible;
    double sum = 0.0;
    for (const Fitness& f : fitness_) sum += f.cost;
    entry.mean_cost = sum / np_;
    entry.mean_F = means.F;
    entry.mean_CR = means.CR;
    entry.elapsed_s = secondsSince(start_);
    result_.log.push_back(entry);
  }

  Result finish(StopReason reason) {
    result_.stop_reason = reason;
    result_.population.resize(dimension_, np_);
    result_.fitness.resize(static_cast<std::size_t>(np_));
    for (int c = 0; c < np_; ++c) {
      const int k = ranking_[static_cast<std::size_t>(c)];
      result_.population.col(c) = population_.col(k);
      result_.fitness[static_cast<std::size_t>(c)] = fitness_[static_cast<std::size_t>(k)];
    }
    result_.best_x = result_.population.col(0);
    result_.best = result_.fitness.front();
    result_.elapsed_s = secondsSince(start_);
    return std::move(result_);
  }

  const Settings& settings_;
  const Problem& problem_;
  const Box box_;
  const int np_;
  const int dimension_;
  const Clock::time_point start_;
  Random rng_;
  std::unique_ptr<ParameterControl> control_;
  MutationFunction mutate_;
  int pbest_count_ = 2;

  Eigen::MatrixXd population_;  ///< one individual per column
  std::vector<Fitness> fitness_;
  Eigen::MatrixXd trials_;  ///< the generation's trial vectors
  std::vector<Fitness> trial_fitness_;
  std::vector<ControlParameters> trial_parameters_;
  Eigen::VectorXd mutant_;
  std::vector<int> ranking_;  ///< population indices, best first
  Eigen::MatrixXd archive_;   ///< JADE archive (CurrentToPBest1Bin only)
  int archive_size_ = 0;
  std::vector<std::unique_ptr<Workspace>> workspaces_;  ///< one per OpenMP thread
  BatchTeam* team_ = nullptr;
  std::vector<std::exception_ptr> errors_;  ///< evaluation errors of a batch

  double stagnation_reference_ = std::numeric_limits<double>::infinity();
  int stagnant_generations_ = 0;
  Result result_;
};

}  // namespace

std::string_view toString(StopReason reason) {
  switch (reason) {
    case StopReason::MaxGenerations:
      return "MaxGenerations";
    case StopReason::MaxEvaluations:
      return "MaxEvaluations";
    case StopReason::TimeBudget:
      return "TimeBudget";
    case StopReason::Tolerance:
      return "Tolerance";
    case StopReason::Stagnation:
      return "Stagnation";
    case StopReason::TargetReached:
      return "TargetReached";
    case StopReason::Cancelled:
      return "Cancelled";
  }
  return "Unknown";
}

std::string_view toString(Strategy strategy) {
  switch (strategy) {
    case Strategy::Rand1Bin:
      return "Rand1Bin";
    case Strategy::Best1Bin:
      return "Best1Bin";
    case Strategy::CurrentToBest1Bin:
      return "CurrentToBest1Bin";
    case Strategy::Rand2Bin:
      return "Rand2Bin";
    case Strategy::CurrentToPBest1Bin:
      return "CurrentToPBest1Bin";
  }
  return "Unknown";
}

std::string_view toString(Adaptation adaptation) {
  switch (adaptation) {
    case Adaptation::None:
      return "None";
    case Adaptation::JDE:
      return "JDE";
    case Adaptation::SHADE:
      return "SHADE";
  }
  return "Unknown";
}

std::string_view toString(Initialization initialization) {
  switch (initialization) {
    case Initialization::Uniform:
      return "Uniform";
    case Initialization::LatinHypercube:
      return "LatinHypercube";
    case Initialization::OppositionBased:
      return "OppositionBased";
  }
  return "Unknown";
}

void Settings::validate() const {
  require(toString(strategy) != "Unknown", "strategy", "a Strategy enumerator",
          static_cast<int>(strategy));
  require(toString(adaptation) != "Unknown", "adaptation", "an Adaptation enumerator",
          static_cast<int>(adaptation));
  require(toString(initialization) != "Unknown", "initialization", "an Initialization enumerator",
          static_cast<int>(initialization));
  require(population_size >= 5, "population_size", ">= 5", population_size);
  require(strategy != Strategy::Rand2Bin || population_size >= 7, "population_size",
          ">= 7 for Rand2Bin", population_size);
  require(F > 0.0 && F <= 2.0, "F", "in (0, 2]", F);
  require(CR >= 0.0 && CR <= 1.0, "CR", "in [0, 1]", CR);
  require(p_best > 0.0 && p_best <= 1.0, "p_best", "in (0, 1]", p_best);
  require(max_generations >= 1, "max_generations", ">= 1", max_generations);
  require(max_evaluations >= population_size, "max_evaluations",
          ">= population_size (" + std::to_string(population_size) + ")", max_evaluations);
  require(time_budget_s >= 0.0, "time_budget_s", ">= 0 (0 = no limit)", time_budget_s);
  require(tolerance >= 0.0, "tolerance", ">= 0 (0 = off)", tolerance);
  require(stagnation_generations >= 0, "stagnation_generations", ">= 0 (0 = off)",
          stagnation_generations);
  require(stagnation_tolerance >= 0.0 && stagnation_tolerance < 1.0, "stagnation_tolerance",
          "in [0, 1)", stagnation_tolerance);
  require(!std::isnan(target_cost), "target_cost", "a number or -inf (not NaN)", target_cost);
  require(threads >= 1, "threads", ">= 1", threads);
  require(shade_memory_size >= 0, "shade_memory_size", ">= 0 (0 = population_size)",
          shade_memory_size);
}

Solver::Solver(Settings settings) : settings_(std::move(settings)) {
  settings_.validate();
}

Result Solver::solve(const Problem& problem, const Eigen::MatrixXd& warm_start,
                     const std::atomic<bool>* cancel) const {
  const Clock::time_point start = Clock::now();
  Box box = checkedBox(problem);
  checkWarmStart(warm_start, static_cast<int>(box.lower.size()));
  Run run(settings_, problem, std::move(box), start);
  // One OpenMP team for the whole solve: thread 0 runs the algorithm, the others evaluate each
  // generation's batch with it (batch_team.h). The spin outlasts the serial work between two
  // batches (a few microseconds at NP = 32) with room to spare.
  return runWithTeam(run.workers(), std::chrono::microseconds(50),
                     [&](BatchTeam* team) { return run.solve(warm_start, cancel, team); });
}

}  // namespace wj::planner::de
