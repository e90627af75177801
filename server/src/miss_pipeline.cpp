#include "server/miss_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <tuple>
#include <utility>

#include "planner/liftoff_correction.h"

namespace wj::server {

namespace {

double msBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

std::int64_t unixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Multibody verdicts of a batch of candidates, filled by the verify pool.
struct VerifyBatch {
  explicit VerifyBatch(std::size_t n) : verdicts(n), plans(n) {}
  std::mutex mu;
  std::condition_variable cv;
  std::vector<std::optional<VerifierVerdict>> verdicts;  ///< nullopt: not run (yet)
  std::vector<planner::JumpPlan> plans;  ///< the plan each verdict is of (set with it)
  std::size_t finished = 0;              ///< run or skipped
  std::atomic<bool> abandoned{false};    ///< the requester stopped waiting
};

}  // namespace

std::optional<std::size_t> choiceIsFinal(
    const std::vector<std::optional<VerifierVerdict>>& verdicts,
    const std::vector<bool>& feasible) {
  for (std::size_t k = 0; k < verdicts.size(); ++k) {
    if (!verdicts[k]) return std::nullopt;
    if (verdicts[k]->passed && feasible[k]) return k;
  }
  return std::nullopt;
}

std::optional<std::size_t> chooseVerified(
    const std::vector<std::optional<VerifierVerdict>>& verdicts,
    const std::vector<bool>& feasible) {
  for (std::size_t k = 0; k < verdicts.size(); ++k)
    if (verdicts[k] && verdicts[k]->passed && feasible[k]) return k;
  for (std::size_t k = 0; k < verdicts.size(); ++k)
    if (verdicts[k] && verdicts[k]->passed) return k;
  for (std::size_t k = 0; k < verdicts.size(); ++k)
    if (verdicts[k]) return k;
  return std::nullopt;
}

/// The outcome of verifying the top K: the chosen candidate, its plan and what the answer and
/// the cache say of its verification; or the error that replaces them.
struct MissPipeline::Verified {
  std::optional<ServiceError> error;
  std::size_t chosen = 0;
  planner::JumpPlan plan;
  VerificationSummary summary;
  StoredVerification stored;
  double verify_ms = 0.0;
  /// Fills summary and stored from the chosen candidate's verdict, of `verified` simulated.
  void record(const VerifierVerdict& v, int verified);
};

MissPipeline::MissPipeline(const ServerConfig& config, const planner::JumpPlanner& planner,
                           const PlanVerifier* verifier, BoundedExecutor& verify_pool)
    : config_(config), planner_(planner), verifier_(verifier), verify_pool_(verify_pool) {}

planner::PlanOptions MissPipeline::searchOptions(const MissInputs& in) const {
  const PlanRequest& request = in.request;
  const double verify_reserve =
      in.verify ? in.remaining_s * config_.verification.budget_fraction : 0.0;
  const double search = in.remaining_s - verify_reserve;
  const auto& settings = planner_.settings();
  const bool polish = settings.polish && search >= config_.planner.polish_min_budget_s;
  // The DE checks its clock once per generation, so it may overrun its budget by one; two
  // generations (measured on earlier plans) are kept back, plus the time to build the plans.
  const double generation_s = generation_ms_.load() / 1e3;
  double de_budget =
      search - (polish ? config_.planner.polish_reserve_s : 0.0) - 2.0 * generation_s - 0.005;
  if (settings.de.time_budget_s > 0) de_budget = std::min(de_budget, settings.de.time_budget_s);

  planner::PlanOptions options;
  options.seed = in.seed;
  options.max_evaluations = maxEvaluations(request);
  options.time_budget_s = std::max(de_budget, 1e-3);
  options.threads = config_.planner.de_threads;
  options.polish = polish;
  if (in.verify) {
    const int asked = request.max_verified_candidates > 0 ? request.max_verified_candidates
                                                          : config_.verification.default_candidates;
    options.num_candidates = std::clamp(asked, 1, config_.verification.max_candidates);
  } else {
    options.num_candidates = 1;
  }
  options.cancel = in.cancel;
  if (in.warm_start.cols() > 0) options.warm_start = in.warm_start;
  return options;
}

MissPipeline::Verified MissPipeline::verifyTopK(const MissInputs& in,
                                                const planner::PlannerResult& result) const {
  // The best K distinct candidates, simulated in parallel on the verify pool. Rank 0's plan is
  // the planner's; it is queued first, so that its verification (the answer's critical path)
  // starts at once. A lower rank's worker builds its plan itself (about 1 ms of buildPlan, on
  // its own core instead of before rank 0's start).
  Verified out;
  const auto t_verify = Clock::now();
  const std::size_t n = result.candidates.size();
  auto batch = std::make_shared<VerifyBatch>(n);
  auto model = std::make_shared<const planner::JumpModel>(planner_.robot(), planner_.settings(),
                                                          in.request.task, in.request.initial);
  const planner::JumpTask task = in.request.task;
  const PlanVerifier* verifier = verifier_;
  for (std::size_t k = 0; k < n; ++k) {
    // Rank 0: the planner's plan, copied here; rank k > 0: built by its worker from its
    // candidate. A plan that cannot be built leaves its verdict unset (never chosen).
    std::optional<planner::JumpPlan> ready;
    if (k == 0) ready = result.plan;
    Task t;
    t.run = [verifier, batch, model, task, k, ready = std::move(ready),
             candidate = k == 0 ? planner::Candidate{} : result.candidates[k]]() mutable {
      std::optional<VerifierVerdict> verdict;
      planner::JumpPlan plan;
      if (!batch->abandoned) {
        try {
          plan = ready ? std::move(*ready) : model->buildPlan(candidate.u, &candidate.evaluation);
          try {
            verdict = verifier->verifyUnless(plan, task, batch->abandoned);
          } catch (const std::exception& e) {
            verdict = VerifierVerdict{};
            verdict->reasons.push_back(std::string("verifier error: ") + e.what());
          }
        } catch (const std::exception&) {
          // buildPlan failed: no verdict, so this rank is never the one answered.
        }
      }
      std::lock_guard lock(batch->mu);
      if (verdict) batch->plans[k] = std::move(plan);
      batch->verdicts[k] = std::move(verdict);
      ++batch->finished;
      batch->cv.notify_all();
    };
    t.abandon = [batch] {
      std::lock_guard lock(batch->mu);
      ++batch->finished;
      batch->cv.notify_all();
    };
    if (!verify_pool_.trySubmit(std::move(t), BoundedExecutor::Lane::Internal)) {
      std::lock_guard lock(batch->mu);
      ++batch->finished;
    }
  }
  std::vector<bool> feasible;
  for (const auto& c : result.candidates) feasible.push_back(c.evaluation.feasible);
  std::vector<std::optional<VerifierVerdict>> verdicts;
  std::optional<std::size_t> pick;
  {
    // Until every verdict is in, or the choice is final: then the lower-ranked candidates still
    // running are stopped, and only the verdicts the choice rests on (ranks 0..k) count, so
    // that the answer does not depend on which of the others happened to finish.
    std::unique_lock lock(batch->mu);
    std::optional<std::size_t> final_choice;
    while (batch->finished < batch->verdicts.size() && !*in.cancel &&
           Clock::now() < in.budget_end &&
           !(final_choice = choiceIsFinal(batch->verdicts, feasible)))
      batch->cv.wait_until(lock,
                           std::min(in.budget_end, Clock::now() + std::chrono::milliseconds(20)));
    if (!final_choice) final_choice = choiceIsFinal(batch->verdicts, feasible);
    batch->abandoned = true;
    verdicts = batch->verdicts;
    if (final_choice) verdicts.resize(*final_choice + 1);
    pick = chooseVerified(verdicts, feasible);
    if (pick) out.plan = std::move(batch->plans[*pick]);
  }
  out.verify_ms = msBetween(t_verify, Clock::now());
  if (*in.cancel) {
    out.error = ServiceError(ErrorCode::Cancelled, "the call was cancelled");
    return out;
  }
  if (!pick) {
    out.error = ServiceError(ErrorCode::DeadlineExceeded,
                             "no candidate finished its verification within the deadline (" +
                                 std::to_string(verdicts.size()) + " started)");
    return out;
  }
  int verified = 0;
  for (const auto& v : verdicts) verified += v ? 1 : 0;
  out.chosen = *pick;
  out.record(*verdicts[out.chosen], verified);
  return out;
}

void MissPipeline::Verified::record(const VerifierVerdict& v, int verified) {
  summary.status = v.passed ? VerificationStatus::Passed : VerificationStatus::Failed;
  summary.failure_reasons = v.reasons;
  summary.simulated = v.simulated;
  summary.max_envelope_ratio = v.max_envelope_ratio;
  summary.landed_upright = v.landed_upright;
  summary.candidates_verified = verified;
  summary.returned_candidate_rank = static_cast<int>(chosen);
  stored.status = summary.status;
  stored.failure_bits = v.failure_bits;
  stored.simulated = v.simulated;
  stored.max_envelope_ratio = v.max_envelope_ratio;
  stored.landed_upright = v.landed_upright;
  stored.candidates_verified = static_cast<std::uint16_t>(verified);
  stored.returned_candidate_rank = static_cast<std::uint16_t>(chosen);
  stored.verify_ms = static_cast<float>(verify_ms);
}

void MissPipeline::correctLiftOff(const MissInputs& in, planner::PlannerResult& result,
                                  Verified& v) const {
  const int rounds = config_.verification.liftoff_correction_rounds;
  // Simbody's robot took off (a verdict without a take-off has no lift-off to measure).
  const auto tookOff = [](const planner::JumpOutcome& o) { return o.takeoff.t > 0.0; };
  if (rounds <= 0 || in.request.task.isBackflip() || !tookOff(v.summary.simulated)) return;
  const double g = planner_.settings().gravity;
  const auto ratioOf = [](const planner::JumpPlan& plan, const planner::LiftOffCorrection& r) {
    return planner::liftOffResidualRatio(plan, r, planner::kLiftOffVelocityTolerance,
                                         planner::kLiftOffMomentumTolerance);
  };
  // (verified, feasible, -residual ratio): larger is better.
  using Rank = std::tuple<bool, bool, double>;
  planner::LiftOffCorrection correction = v.plan.liftoff_correction;
  planner::LiftOffCorrection residual =
      planner::liftOffResidual(v.plan, v.summary.simulated.takeoff, g);
  Rank best{v.summary.status == VerificationStatus::Passed,
            result.candidates[v.chosen].evaluation.feasible, -ratioOf(v.plan, residual)};
  Eigen::VectorXd last_u = result.candidates[v.chosen].u;
  // One round: a warm search and a verification, about as long as the first verification.
  double round_ms = v.verify_ms;
  int verified = v.summary.candidates_verified;
  for (int round = 1; round <= rounds; ++round) {
    if (std::get<0>(best) && std::get<1>(best) && -std::get<2>(best) <= 1.0) return;
    const planner::LiftOffCorrection next = planner::nextCorrection(correction, residual);
    const auto t_round = Clock::now();
    const double left_ms = msBetween(t_round, in.budget_end);
    if (!planner::withinBounds(next) || *in.cancel || left_ms < 2.0 * round_ms) return;
    planner::PlanOptions options;
    options.seed = in.seed;
    options.threads = config_.planner.de_threads;
    options.max_evaluations = maxEvaluations(in.request);
    options.time_budget_s = 0.5 * (left_ms - round_ms) / 1e3;
    options.polish = planner_.settings().polish;
    options.warm_start = last_u;
    options.liftoff_correction = next;
    options.cancel = in.cancel;
    planner::PlannerResult r;
    try {
      r = planner_.plan(in.request.task, in.request.initial, options);
    } catch (const std::exception&) {
      return;  // the correction is an improvement; the first round's answer stands
    }
    if (!r.evaluation.valid) return;
    const std::optional<VerifierVerdict> verdict =
        verifier_->verifyUnless(r.plan, in.request.task, *in.cancel);
    round_ms = msBetween(t_round, Clock::now());
    v.verify_ms += round_ms;
    if (!verdict || !tookOff(verdict->simulated)) return;
    ++verified;
    correction = next;
    residual = planner::liftOffResidual(r.plan, verdict->simulated.takeoff, g);
    const Rank rank{verdict->passed, r.evaluation.feasible, -ratioOf(r.plan, residual)};
    const bool repeated = r.u == last_u;
    last_u = r.u;
    if (rank > best) {
      best = rank;
      v.chosen = 0;
      v.plan = r.plan;
      result = std::move(r);
      v.record(*verdict, verified);
    } else {
      v.summary.candidates_verified = verified;
      v.stored.candidates_verified = static_cast<std::uint16_t>(verified);
    }
    if (repeated) return;
  }
}

std::string MissPipeline::notRunReason(const PlanRequest& request) const {
  if (!config_.verification.enabled)
    return "not run: disabled in the server configuration (verification.enabled)";
  if (!request.skip_verification)
    return "verification unavailable: this server was built without the sim component";
  return "not run: skipped by the request (budget.skip_verification)";
}

std::int64_t MissPipeline::maxEvaluations(const PlanRequest& request) const {
  const auto& de = planner_.settings().de;
  const std::int64_t asked = std::min<std::int64_t>(
      request.max_evaluations.value_or(de.max_evaluations), config_.planner.max_evaluations_cap);
  return std::max<std::int64_t>(asked, de.population_size);
}

CachedSolution MissPipeline::compactSolution(const planner::PlannerResult& result,
                                             const planner::Candidate& chosen,
                                             const PlanAnswer& answer,
                                             const StoredVerification& verification,
                                             std::uint64_t seed, bool de_complete,
                                             std::int64_t max_evaluations) const {
  CachedSolution solution;
  for (int i = 0; i < planner::kNumDecision; ++i)
    solution.u[static_cast<std::size_t>(i)] = chosen.u[i];
  solution.t1 = answer.plan.t1;
  solution.t2 = answer.plan.t2;
  solution.t3 = answer.plan.t3;
  solution.feasible = chosen.evaluation.feasible;
  solution.constraints_ok = chosen.evaluation.constraints_ok;
  solution.de_complete = de_complete;
  solution.max_evaluations = max_evaluations;
  solution.de_cost = result.de_cost;
  solution.final_cost = chosen.evaluation.cost;
  solution.seed = seed;
  solution.evaluations = result.de.evaluations;
  solution.generations = result.de.generations;
  solution.de_ms = static_cast<float>(result.de_ms);
  solution.polish_ms = static_cast<float>(result.polish_ms);
  solution.verification = verification;
  solution.liftoff_correction = answer.plan.liftoff_correction;
  solution.created_unix_ms = unixMs();
  return solution;
}

MissResult MissPipeline::run(const MissInputs& in) {
  MissResult out;
  const PlanRequest& request = in.request;
  const planner::PlanOptions options = searchOptions(in);
  planner::PlannerResult result;
  try {
    result = planner_.plan(request.task, request.initial, options);
  } catch (...) {
    out.error = classifyException(std::current_exception());
    return out;
  }
  if (result.de.generations > 0) {
    const double measured = result.de_ms / (result.de.generations + 1);
    generation_ms_.store(0.8 * generation_ms_.load() + 0.2 * measured);
  }
  if (*in.cancel) {
    out.error = ServiceError(ErrorCode::Cancelled, "the call was cancelled");
    return out;
  }
  if (Clock::now() > in.budget_end) {
    out.error =
        ServiceError(ErrorCode::DeadlineExceeded, "planning did not finish within the deadline");
    return out;
  }

  PlanAnswer answer;
  answer.stats.de_ms = result.de_ms;
  answer.stats.polish_ms = result.polish_ms;
  answer.stats.evaluations = result.de.evaluations;
  answer.stats.generations = result.de.generations;
  answer.stats.threads = *options.threads;
  answer.stats.de_cost = result.de_cost;
  answer.stats.polished_cost = result.final_cost;
  answer.stats.seed = *options.seed;
  answer.stats.cache_key = in.cache_key_hex;
  const bool de_complete = result.de.stop_reason != planner::de::StopReason::TimeBudget &&
                           result.de.stop_reason != planner::de::StopReason::Cancelled;
  if (!result.evaluation.valid) {
    // No dynamically valid trajectory at all: a normal, infeasible answer without a plan.
    answer.evaluation = result.evaluation;
    answer.binding = result.binding;
    answer.summary = result.summary;
    out.answer = std::move(answer);
    return out;
  }

  std::size_t chosen = 0;  // rank of the returned candidate
  StoredVerification stored_verification;
  if (in.verify) {
    Verified v = verifyTopK(in, result);
    answer.stats.verify_ms = v.verify_ms;
    if (v.error) {
      out.error = std::move(v.error);
      return out;
    }
    correctLiftOff(in, result, v);
    answer.stats.verify_ms = v.verify_ms;
    chosen = v.chosen;
    answer.plan = std::move(v.plan);
    answer.verification = std::move(v.summary);
    stored_verification = v.stored;
  } else {
    answer.plan = std::move(result.plan);
    answer.verification.failure_reasons.push_back(notRunReason(request));
  }
  const auto& cand = result.candidates[chosen];
  if (asKnots(request.trajectory) && answer.plan.numSamples() > 0) {
    // The verifier ran the dense references; the answer carries the same plan as knots.
    const planner::JumpModel model(planner_.robot(), planner_.settings(), request.task,
                                   request.initial, answer.plan.liftoff_correction);
    answer.plan = model.buildKnots(cand.u, &cand.evaluation);
  }
  answer.evaluation = cand.evaluation;
  if (chosen == 0) {
    answer.binding = result.binding;
    answer.summary = result.summary;
  } else {
    describeEvaluation(answer.evaluation, planner_.settings().polish_backoff, answer.binding,
                       answer.summary);
  }
  out.solution = compactSolution(result, cand, answer, stored_verification, *options.seed,
                                 de_complete, *options.max_evaluations);
  // A search cut short by the clock that found nothing feasible may do better with more time:
  // it is answered but not cached.
  out.cacheable = de_complete || out.solution->feasible;
  out.answer = std::move(answer);
  return out;
}

}  // namespace wj::server
