#include "planner/jump_planner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <random>
#include <sstream>

namespace wj::planner {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// The DE's view of the jump model: one Evaluation per worker thread.
class JumpProblem final : public de::Problem {
 public:
  explicit JumpProblem(const JumpModel& model) : model_(model) {}
  int dimension() const override { return model_.dimension(); }
  Eigen::VectorXd lowerBounds() const override { return model_.lowerBounds(); }
  Eigen::VectorXd upperBounds() const override { return model_.upperBounds(); }
  bool isThreadSafe() const override { return true; }

  struct Work final : de::Workspace {
    Evaluation ev;
  };
  std::unique_ptr<de::Workspace> createWorkspace() const override {
    return std::make_unique<Work>();
  }
  de::Fitness evaluate(const Eigen::Ref<const Eigen::VectorXd>& x,
                       de::Workspace& ws) const override {
    auto& ev = static_cast<Work&>(ws).ev;
    model_.evaluate(x, ev);
    return {ev.cost, ev.feasible};
  }
  de::Fitness evaluateBounded(const Eigen::Ref<const Eigen::VectorXd>& x, de::Workspace& ws,
                              double bound) const override {
    auto& ev = static_cast<Work&>(ws).ev;
    model_.evaluate(x, ev, bound);
    return {ev.cost, ev.feasible};
  }

 private:
  const JumpModel& model_;
};

}  // namespace

PolishGoal polishGoalFor(const Evaluation& ev) {
  return ev.constraints_ok && !ev.target_ok ? PolishGoal::ClosestApproach : PolishGoal::MeetTarget;
}

std::vector<ConstraintClass> findBindingClasses(const Evaluation& ev, double backoff) {
  std::vector<std::pair<int, ConstraintClass>> v;
  for (int i = 0; i < kNumConstraintClasses; ++i) {
    const auto c = static_cast<ConstraintClass>(i);
    if (ev.margins[i].worst < 0.0) v.emplace_back(JumpModel::classPriority(c), c);
  }
  if (v.empty() && !ev.target_ok) {
    // Constraints hold but the target is missed: the active ones are what stops it.
    for (int i = 0; i < kNumConstraintClasses; ++i) {
      const auto c = static_cast<ConstraintClass>(i);
      if (ev.margins[i].worst / JumpModel::classScale(c) < backoff + 0.05)
        v.emplace_back(JumpModel::classPriority(c), c);
    }
  }
  std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<ConstraintClass> out;
  for (const auto& [_, c] : v) out.push_back(c);
  return out;
}

std::string summarizeEvaluation(const Evaluation& ev, const std::vector<ConstraintClass>& binding) {
  std::ostringstream ss;
  if (ev.feasible) {
    ss << "feasible: all constraints hold and the target is met";
    return ss.str();
  }
  if (!ev.valid) return "infeasible: no valid trajectory found";
  ss << "infeasible: ";
  if (!ev.constraints_ok) {
    ss << "violated";
  } else {
    ss << "target missed (dx " << ev.err_dx << " m, height " << ev.err_height << " m, pitch "
       << ev.err_pitch << " rad); binding";
  }
  for (std::size_t i = 0; i < binding.size(); ++i) {
    const auto& m = ev.margins[static_cast<int>(binding[i])];
    ss << (i ? ", " : " ") << toString(binding[i]) << " (margin " << m.worst << " "
       << unitOf(binding[i]) << " at t=" << m.t << " s)";
  }
  return ss.str();
}

const char* toString(PolishOutcome o) {
  switch (o) {
    case PolishOutcome::NotRun:
      return "not_run";
    case PolishOutcome::Improved:
      return "improved";
    case PolishOutcome::Rejected:
      return "rejected";
    case PolishOutcome::Failed:
      return "failed";
  }
  return "?";
}

Eigen::MatrixXd JumpPlanner::warmCloud(const JumpModel& model, const Eigen::MatrixXd& warm,
                                       std::uint64_t seed) const {
  const int k = static_cast<int>(warm.cols());
  const int extra = settings_.warm_start_cloud;
  if (k == 0 || extra == 0) return warm;
  // The given points first, then `extra` Gaussian perturbations of them in turn (sigma a
  // fraction of each variable's range; fixed variables stay fixed). A polished neighbour sits
  // on its active bounds, so at the new velocity it is usually just infeasible while a point a
  // little inside is not (docs/planner.md, "Warm start").
  const Eigen::VectorXd range = model.upperBounds() - model.lowerBounds();
  Eigen::MatrixXd out(warm.rows(), k + extra);
  out.leftCols(k) = warm;
  std::mt19937_64 rng(seed ^ 0xA5A5A5A5DEADBEEFULL);
  auto gaussian = [&rng] {
    // Box-Muller from two 53-bit uniforms in (0, 1]: the same numbers on every platform.
    const double u1 = (static_cast<double>(rng() >> 11) + 1.0) * 0x1.0p-53;
    const double u2 = static_cast<double>(rng() >> 11) * 0x1.0p-53;
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  };
  for (int j = 0; j < extra; ++j) {
    Eigen::VectorXd x = warm.col(j % k);
    for (Eigen::Index i = 0; i < x.size(); ++i)
      x[i] += settings_.warm_start_spread * range[i] * gaussian();
    out.col(k + j) = x;
  }
  return out;
}

Eigen::MatrixXd JumpPlanner::initialGuesses(const JumpTask& task,
                                            const PlanOptions& options) const {
  if (!task.isBackflip() || settings_.flip_initial_guess.empty()) return options.warm_start;
  // A backflip: the flip's shape (settings.flip_initial_guess) starts the search, after the
  // request's warm start if it brings one. The service warm-starts a miss from its cached
  // neighbouring speeds, and for a flip those were often infeasible answers: without the guess
  // the client's retries searched from them alone and found no flip (docs/backflip.md,
  // "Session 14").
  const Eigen::Index k = options.warm_start.cols();
  Eigen::MatrixXd out(static_cast<Eigen::Index>(kNumDecision), k + 1);
  if (k > 0) out.leftCols(k) = options.warm_start;
  out.col(k) = Eigen::Map<const Eigen::VectorXd>(settings_.flip_initial_guess.data(),
                                                 static_cast<Eigen::Index>(kNumDecision));
  return out;
}

JumpPlanner::JumpPlanner(model::RobotModel robot, PlannerSettings settings)
    : robot_(std::move(robot)), settings_(std::move(settings)) {
  settings_.validate();
}

Eigen::Matrix<double, model::kNumJoints, 1> JumpPlanner::standPosture() const {
  Eigen::Matrix<double, model::kNumJoints, 1> q =
      Eigen::Matrix<double, model::kNumJoints, 1>::Zero();
  for (const model::Leg leg : model::kLegs) {
    q[model::jointIndex(leg, model::JointKind::HFE)] = settings_.stand_hfe_rad;
    q[model::jointIndex(leg, model::JointKind::KFE)] = settings_.stand_kfe_rad;
  }
  return q;
}

namespace {

// A closest approach can move far from its start, past constraints that were not near their
// bound there and so were not in the polish's problem (polish_problem.h). The last point of
// the segment from `start` (meeting every constraint) to `end` that still meets them all, by
// bisection to 1/64 of the segment; `ev` becomes its evaluation (`start_ev` if none).
Eigen::VectorXd backToTheConstraints(const JumpModel& model, const Eigen::VectorXd& start,
                                     const Evaluation& start_ev, const Eigen::VectorXd& end,
                                     Evaluation& ev) {
  double lo = 0.0, hi = 1.0;
  ev = start_ev;
  Evaluation trial;
  for (int k = 0; k < 6; ++k) {
    const double mid = 0.5 * (lo + hi);
    model.evaluate(start + mid * (end - start), trial);
    if (trial.valid && trial.constraints_ok) {
      lo = mid;
      ev = trial;
    } else {
      hi = mid;
    }
  }
  return start + lo * (end - start);
}

// One plan() call after its input is checked: the DE attempts with restarts and the polish
// between them, the final polish and its retries, the candidates for verification. Each step
// fills its part of the result.
class PlanRun {
 public:
  PlanRun(const PlannerSettings& settings, const JumpModel& model, const PlanOptions& options,
          const de::Settings& des)
      : settings_(settings),
        model_(model),
        options_(options),
        des_(des),
        problem_(model),
        polish_on_(options.polish.value_or(settings.polish) && settings.polish_max_iterations > 0) {
  }

  // Restarts: the evaluation budget is split into attempts; an attempt that ends without a
  // feasible candidate (trapped in a penalty basin) is followed by one from a fresh
  // population (deterministic seed sequence), keeping the best overall.
  void search(const Eigen::MatrixXd& first_population);
  // The polish of the best point (unless the polish between attempts already reached a
  // feasible one), then the other attempts' bests while the result is still infeasible.
  void polish();
  // Distinct candidates for verification: the best, then the DE population in cost order,
  // skipping points closer than 1e-3 of the box (normalised) to one already taken.
  void pickCandidates();

  PlannerResult result;

 private:
  using Polished = std::pair<Eigen::VectorXd, Evaluation>;

  // A restart is for an attempt trapped in a penalty basin: its best violates a constraint.
  // When the best meets every constraint and only misses the target, the target is what is out
  // of reach (the attempts end at the same frontier), so the budget is not spent again.
  bool trapped(const Eigen::VectorXd& x) const {
    Evaluation ev;
    model_.evaluate(x, ev);
    return !ev.constraints_ok;
  }
  bool cancelled() const { return options_.cancel && options_.cancel->load(); }
  bool wasPolished(const Eigen::VectorXd& x) const {
    return std::find(polished_.begin(), polished_.end(), x) != polished_.end();
  }
  // Polishes an attempt's best x (cold iteration limit) and returns the result if it is
  // feasible; x is not polished again.
  std::optional<Polished> polishToFeasible(const Eigen::VectorXd& x);
  // The settings of restart `restart`, false when the budget (evaluations or time) is spent.
  bool nextAttempt(int restart, de::Settings& again) const;
  // Folds the result of a restart into the result so far: logs and counters continue, the
  // best stays the best.
  void mergeAttempt(de::Result next);
  // The polish of result.u with the goal its evaluation calls for.
  void polishFinal(int max_iterations);
  // Still infeasible: the other attempts' bests, lowest cost first.
  void retryOtherAttempts();

  const PlannerSettings& settings_;
  const JumpModel& model_;
  const PlanOptions& options_;
  const de::Settings des_;
  const JumpProblem problem_;
  const bool polish_on_;
  const Clock::time_point t0_ = Clock::now();  // the DE's clock (the warm start counts)
  std::int64_t attempt_budget_ = 0;
  // The best point of every attempt, for the polish retries.
  std::vector<std::pair<double, Eigen::VectorXd>> attempt_bests_;
  // The points polished between attempts are not polished again.
  std::vector<Eigen::VectorXd> polished_;
  double between_polish_ms_ = 0.0;
  std::optional<Polished> early_;
};

std::optional<PlanRun::Polished> PlanRun::polishToFeasible(const Eigen::VectorXd& x) {
  polished_.push_back(x);
  Eigen::VectorXd u_polished;
  int iterations = 0;
  if (polishCandidate(model_, x, u_polished, &iterations, 0, PolishGoal::MeetTarget,
                      des_.threads) == PolishOutcome::Failed)
    return std::nullopt;
  result.polish_iterations += iterations;
  Evaluation ev;
  model_.evaluate(u_polished, ev);
  if (!ev.feasible) return std::nullopt;
  return Polished{u_polished, ev};
}

bool PlanRun::nextAttempt(int restart, de::Settings& again) const {
  const PlannerResult& r = result;
  const bool cut_short = r.de.stop_reason == de::StopReason::Cancelled ||
                         r.de.stop_reason == de::StopReason::TimeBudget;
  const std::int64_t left = des_.max_evaluations - r.de.evaluations;
  if (cut_short || left < 10 * des_.population_size) return false;
  again = des_;
  again.seed = des_.seed + 0x9E3779B97F4A7C15ULL * static_cast<std::uint64_t>(restart);
  again.max_evaluations = restart == settings_.de_restarts ? left : std::min(left, attempt_budget_);
  if (des_.time_budget_s > 0.0) {
    again.time_budget_s = des_.time_budget_s - msSince(t0_) / 1e3;
    if (again.time_budget_s <= 0.0) return false;
  }
  return true;
}

void PlanRun::mergeAttempt(de::Result next) {
  PlannerResult& r = result;
  for (auto& g : next.log) {
    g.generation += r.de.generations;
    g.evaluations += r.de.evaluations;
  }
  if (next.first_feasible_evaluations >= 0) {
    next.first_feasible_evaluations += r.de.evaluations;
    next.first_feasible_s = msSince(t0_) / 1e3 - (next.elapsed_s - next.first_feasible_s);
  }
  next.log.insert(next.log.begin(), r.de.log.begin(), r.de.log.end());
  next.evaluations += r.de.evaluations;
  next.generations += r.de.generations;
  if (!(next.best.cost < r.de.best.cost)) {
    // Keep the earlier best but account for the work done.
    next.best = r.de.best;
    next.best_x = r.de.best_x;
    next.population = r.de.population;
    next.fitness = r.de.fitness;
  }
  r.de = std::move(next);
  ++r.de_restarts;
}

void PlanRun::search(const Eigen::MatrixXd& first_population) {
  PlannerResult& r = result;
  const std::int64_t total_budget = des_.max_evaluations;
  attempt_budget_ =
      std::max<std::int64_t>(total_budget / (settings_.de_restarts + 1), 10 * des_.population_size);
  {
    de::Settings first = des_;
    first.max_evaluations = std::min(attempt_budget_, total_budget);
    r.de = de::Solver(first).solve(problem_, first_population, options_.cancel);
    attempt_bests_.emplace_back(r.de.best.cost, r.de.best_x);
  }
  const bool beyond_planned = settings_.de_restart_while_budget;
  for (int restart = 1;
       !r.de.best.feasible && (restart <= settings_.de_restarts || beyond_planned) &&
       trapped(r.de.best_x);
       ++restart) {
    // Polish between attempts: a trapped attempt often ends next to a feasible plan that the
    // polish reaches (forward preset: 5 of 10 first attempts), and the attempts after it are
    // then not needed. The points polished here are not polished again below.
    if (polish_on_ && settings_.polish_between_attempts && !cancelled()) {
      const auto tp = Clock::now();
      early_ = polishToFeasible(attempt_bests_.back().second);
      between_polish_ms_ += msSince(tp);
      if (early_) break;
    }
    de::Settings again;
    if (!nextAttempt(restart, again)) break;
    de::Result next = de::Solver(again).solve(problem_, Eigen::MatrixXd(), options_.cancel);
    attempt_bests_.emplace_back(next.best.cost, next.best_x);
    mergeAttempt(std::move(next));
  }
  r.de.elapsed_s = (msSince(t0_) - between_polish_ms_) / 1e3;
  r.de_ms = msSince(t0_) - between_polish_ms_;
  r.de_cost = r.de.best.cost;
  r.u = r.de.best_x;
  model_.evaluate(r.u, r.evaluation);
  if (early_) {
    r.u = early_->first;
    r.evaluation = early_->second;
    r.polish = PolishOutcome::Improved;
  }
  r.polish_ms = between_polish_ms_;
}

void PlanRun::polishFinal(int max_iterations) {
  PlannerResult& r = result;
  if (wasPolished(r.u)) {
    // The best attempt was polished between attempts, in vain: only the retries remain.
    r.polish = PolishOutcome::Rejected;
    return;
  }
  Eigen::VectorXd u_pol;
  int iterations = 0;
  r.polish_goal = polishGoalFor(r.evaluation);
  r.polish =
      polishCandidate(model_, r.u, u_pol, &iterations, max_iterations, r.polish_goal, des_.threads);
  r.polish_iterations += iterations;
  if (r.polish == PolishOutcome::Failed) return;
  Evaluation ev;
  model_.evaluate(u_pol, ev);
  if (r.polish_goal == PolishGoal::ClosestApproach && !ev.constraints_ok)
    u_pol = backToTheConstraints(model_, r.u, r.evaluation, u_pol, ev);
  // The polish never worsens the result: keep its point only if the cost drops and it is
  // feasible whenever the DE's point was.
  const bool better = ev.cost < r.evaluation.cost && (ev.feasible || !r.evaluation.feasible);
  if (better) {
    r.u = u_pol;
    r.evaluation = ev;
    r.polish = PolishOutcome::Improved;
  } else {
    r.polish = PolishOutcome::Rejected;
  }
}

void PlanRun::retryOtherAttempts() {
  PlannerResult& r = result;
  std::sort(attempt_bests_.begin(), attempt_bests_.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  int retries = 0;
  for (const auto& [cost, x] : attempt_bests_) {
    if (r.evaluation.feasible || retries >= settings_.polish_retries) break;
    if (x.size() != r.de.best_x.size() || x == r.de.best_x || wasPolished(x)) continue;
    if (cancelled()) break;
    ++retries;
    if (const auto p = polishToFeasible(x)) {
      r.u = p->first;
      r.evaluation = p->second;
      r.polish = PolishOutcome::Improved;
    }
  }
  r.polish_retries = retries;
}

void PlanRun::polish() {
  PlannerResult& r = result;
  const bool do_polish = polish_on_ && r.evaluation.valid && !early_;
  if (do_polish) {
    const auto t0 = Clock::now();
    // A warm start begins next to a polished neighbour: a few iterations meet the target and
    // the back-off there; the energy it would still gain is small (docs/planner.md).
    const int max_iterations =
        options_.warm_start.cols() > 0 ? settings_.polish_warm_max_iterations : 0;
    polishFinal(max_iterations);
    retryOtherAttempts();
    r.polish_ms = between_polish_ms_ + msSince(t0);
  }
  r.final_cost = r.evaluation.cost;
}

void PlanRun::pickCandidates() {
  PlannerResult& r = result;
  const Eigen::VectorXd range = (model_.upperBounds() - model_.lowerBounds()).cwiseMax(1e-12);
  r.candidates.push_back({r.u, r.evaluation});
  for (int j = 0; j < r.de.population.cols() &&
                  static_cast<int>(r.candidates.size()) < options_.num_candidates;
       ++j) {
    const Eigen::VectorXd x = r.de.population.col(j);
    bool distinct = true;
    for (const auto& c : r.candidates)
      if (((x - c.u).cwiseQuotient(range)).norm() < 1e-3) distinct = false;
    if (!distinct) continue;
    Candidate c{x, {}};
    model_.evaluate(x, c.evaluation);
    if (c.evaluation.valid) r.candidates.push_back(std::move(c));
  }
}

}  // namespace

PlannerResult JumpPlanner::plan(const JumpTask& task, const InitialState& initial,
                                const PlanOptions& options) const {
  const auto t_start = Clock::now();
  const JumpModel model(robot_, settings_, task, initial, options.liftoff_correction);
  if (options.num_candidates < 1)
    throw std::invalid_argument("options.num_candidates must be >= 1, got " +
                                std::to_string(options.num_candidates));
  if (options.warm_start.size() > 0 && options.warm_start.rows() != kNumDecision)
    throw std::invalid_argument("options.warm_start must have " + std::to_string(kNumDecision) +
                                " rows, got " + std::to_string(options.warm_start.rows()));

  de::Settings des = settings_.de;
  if (options.seed) des.seed = *options.seed;
  if (options.max_evaluations) des.max_evaluations = *options.max_evaluations;
  if (options.time_budget_s) des.time_budget_s = *options.time_budget_s;
  if (options.threads) des.threads = *options.threads;
  des.validate();

  PlanRun run(settings_, model, options, des);
  run.search(warmCloud(model, initialGuesses(task, options), des.seed));
  run.polish();
  run.pickCandidates();

  PlannerResult& r = run.result;
  r.binding = findBindingClasses(r.evaluation, settings_.polish_backoff);
  r.summary = summarizeEvaluation(r.evaluation, r.binding);
  if (r.evaluation.valid) r.plan = model.buildPlan(r.u, &r.evaluation);
  r.total_ms = msSince(t_start);
  return std::move(r);
}

}  // namespace wj::planner
