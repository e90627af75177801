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
  if (options.warm_start.cols() > 0 || !task.isBackflip() || settings_.flip_initial_guess.empty())
    return options.warm_start;
  // A cold backflip: the flip's shape (settings.flip_initial_guess) starts the search.
  return Eigen::Map<const Eigen::VectorXd>(settings_.flip_initial_guess.data(),
                                           static_cast<Eigen::Index>(kNumDecision));
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

}  // namespace

PlannerResult JumpPlanner::plan(const JumpTask& task, const InitialState& initial,
                                const PlanOptions& options) const {
  const auto t_start = Clock::now();
  const JumpModel model(robot_, settings_, task, initial);
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
  const JumpProblem problem(model);

  PlannerResult r;
  auto t0 = Clock::now();
  // Restarts: the evaluation budget is split into attempts; an attempt that ends without a
  // feasible candidate (trapped in a penalty basin) is followed by one from a fresh
  // population (deterministic seed sequence), keeping the best overall.
  const std::int64_t total_budget = des.max_evaluations;
  const std::int64_t attempt_budget =
      std::max<std::int64_t>(total_budget / (settings_.de_restarts + 1), 10 * des.population_size);
  // The best point of every attempt, for the polish retries.
  std::vector<std::pair<double, Eigen::VectorXd>> attempt_bests;
  {
    de::Settings first = des;
    first.max_evaluations = std::min(attempt_budget, total_budget);
    r.de = de::Solver(first).solve(
        problem, warmCloud(model, initialGuesses(task, options), des.seed), options.cancel);
    attempt_bests.emplace_back(r.de.best.cost, r.de.best_x);
  }
  // A restart is for an attempt trapped in a penalty basin: its best violates a constraint.
  // When the best meets every constraint and only misses the target, the target is what is out
  // of reach (the attempts end at the same frontier), so the budget is not spent again.
  auto trapped = [&model](const Eigen::VectorXd& x) {
    Evaluation ev;
    model.evaluate(x, ev);
    return !ev.constraints_ok;
  };
  const bool polish_on =
      options.polish.value_or(settings_.polish) && settings_.polish_max_iterations > 0;
  // Polish between attempts: a trapped attempt often ends next to a feasible plan that the
  // polish reaches (forward preset: 5 of 10 first attempts), and the attempts after it are then
  // not needed. The points polished here are not polished again below.
  using Polished = std::pair<Eigen::VectorXd, Evaluation>;
  std::vector<Eigen::VectorXd> polished;
  auto wasPolished = [&polished](const Eigen::VectorXd& x) {
    return std::find(polished.begin(), polished.end(), x) != polished.end();
  };
  // Polishes an attempt's best x (cold iteration limit) and returns the result if it is
  // feasible; x is not polished again.
  auto polishToFeasible = [&](const Eigen::VectorXd& x) -> std::optional<Polished> {
    polished.push_back(x);
    Eigen::VectorXd u_polished;
    int iterations = 0;
    if (polishCandidate(model, x, u_polished, &iterations, 0, PolishGoal::MeetTarget,
                        des.threads) == PolishOutcome::Failed)
      return std::nullopt;
    r.polish_iterations += iterations;
    Evaluation ev;
    model.evaluate(u_polished, ev);
    if (!ev.feasible) return std::nullopt;
    return Polished{u_polished, ev};
  };
  double between_polish_ms = 0.0;
  std::optional<Polished> early;
  for (int restart = 1;
       !r.de.best.feasible && restart <= settings_.de_restarts && trapped(r.de.best_x); ++restart) {
    if (polish_on && settings_.polish_between_attempts &&
        !(options.cancel && options.cancel->load())) {
      const auto tp = Clock::now();
      early = polishToFeasible(attempt_bests.back().second);
      between_polish_ms += msSince(tp);
      if (early) break;
    }
    const bool cut_short = r.de.stop_reason == de::StopReason::Cancelled ||
                           r.de.stop_reason == de::StopReason::TimeBudget;
    const std::int64_t left = total_budget - r.de.evaluations;
    if (cut_short || left < 10 * des.population_size) break;
    de::Settings again = des;
    again.seed = des.seed + 0x9E3779B97F4A7C15ULL * static_cast<std::uint64_t>(restart);
    again.max_evaluations =
        restart == settings_.de_restarts ? left : std::min(left, attempt_budget);
    if (des.time_budget_s > 0.0) {
      again.time_budget_s = des.time_budget_s - msSince(t0) / 1e3;
      if (again.time_budget_s <= 0.0) break;
    }
    de::Result next = de::Solver(again).solve(problem, Eigen::MatrixXd(), options.cancel);
    attempt_bests.emplace_back(next.best.cost, next.best_x);
    for (auto& g : next.log) {
      g.generation += r.de.generations;
      g.evaluations += r.de.evaluations;
    }
    if (next.first_feasible_evaluations >= 0) {
      next.first_feasible_evaluations += r.de.evaluations;
      next.first_feasible_s = msSince(t0) / 1e3 - (next.elapsed_s - next.first_feasible_s);
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
  r.de.elapsed_s = (msSince(t0) - between_polish_ms) / 1e3;
  r.de_ms = msSince(t0) - between_polish_ms;
  r.de_cost = r.de.best.cost;
  r.u = r.de.best_x;
  model.evaluate(r.u, r.evaluation);

  if (early) {
    r.u = early->first;
    r.evaluation = early->second;
    r.polish = PolishOutcome::Improved;
  }
  r.polish_ms = between_polish_ms;
  const bool do_polish = polish_on && r.evaluation.valid && !early;
  if (do_polish) {
    t0 = Clock::now();
    Eigen::VectorXd u_pol;
    // A warm start begins next to a polished neighbour: a few iterations meet the target and
    // the back-off there; the energy it would still gain is small (docs/planner.md).
    const int max_iterations =
        options.warm_start.cols() > 0 ? settings_.polish_warm_max_iterations : 0;
    if (wasPolished(r.u)) {
      // The best attempt was polished between attempts, in vain: only the retries remain.
      r.polish = PolishOutcome::Rejected;
    } else {
      int iterations = 0;
      r.polish_goal = polishGoalFor(r.evaluation);
      r.polish = polishCandidate(model, r.u, u_pol, &iterations, max_iterations, r.polish_goal,
                                 des.threads);
      r.polish_iterations += iterations;
      if (r.polish != PolishOutcome::Failed) {
        Evaluation ev;
        model.evaluate(u_pol, ev);
        if (r.polish_goal == PolishGoal::ClosestApproach && !ev.constraints_ok)
          u_pol = backToTheConstraints(model, r.u, r.evaluation, u_pol, ev);
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
    }
    // Still infeasible: the other attempts' bests, lowest cost first.
    std::sort(attempt_bests.begin(), attempt_bests.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    int retries = 0;
    for (const auto& [cost, x] : attempt_bests) {
      if (r.evaluation.feasible || retries >= settings_.polish_retries) break;
      if (x.size() != r.de.best_x.size() || x == r.de.best_x || wasPolished(x)) continue;
      if (options.cancel && options.cancel->load()) break;
      ++retries;
      if (const auto p = polishToFeasible(x)) {
        r.u = p->first;
        r.evaluation = p->second;
        r.polish = PolishOutcome::Improved;
      }
    }
    r.polish_retries = retries;
    r.polish_ms = between_polish_ms + msSince(t0);
  }
  r.final_cost = r.evaluation.cost;

  // Distinct candidates for verification: the best, then the DE population in cost order,
  // skipping points closer than 1e-3 of the box (normalised) to one already taken.
  const Eigen::VectorXd range = (model.upperBounds() - model.lowerBounds()).cwiseMax(1e-12);
  r.candidates.push_back({r.u, r.evaluation});
  for (int j = 0;
       j < r.de.population.cols() && static_cast<int>(r.candidates.size()) < options.num_candidates;
       ++j) {
    const Eigen::VectorXd x = r.de.population.col(j);
    bool distinct = true;
    for (const auto& c : r.candidates)
      if (((x - c.u).cwiseQuotient(range)).norm() < 1e-3) distinct = false;
    if (!distinct) continue;
    Candidate c{x, {}};
    model.evaluate(x, c.evaluation);
    if (c.evaluation.valid) r.candidates.push_back(std::move(c));
  }

  r.binding = findBindingClasses(r.evaluation, settings_.polish_backoff);
  r.summary = summarizeEvaluation(r.evaluation, r.binding);
  if (r.evaluation.valid) r.plan = model.buildPlan(r.u, &r.evaluation);
  r.total_ms = msSince(t_start);
  return r;
}

}  // namespace wj::planner
