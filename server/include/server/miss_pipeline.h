#pragma once
/// @file What a cache miss does, free of gRPC and of the cache: the deadline's remainder split
/// into search and verification budgets, the search (DE, polish) for the best K candidates, the
/// verification of those candidates in parallel, the choice of the best verified one, the
/// fallback when verification does not run, and the answer with the compact solution to cache.
/// PlanningCore keeps the cache, the coalescing of identical misses, the lanes, the deadlines and
/// the warm-up; it hands one leader's request here and shares what comes back.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "planner/jump_planner.h"
#include "server/cached_solution.h"
#include "server/config.h"
#include "server/executor.h"
#include "server/plan_types.h"
#include "server/plan_verifier.h"
#include "server/service_error.h"

namespace wj::server {

using Clock = std::chrono::steady_clock;

/// One miss to compute: the leader's request and what the core decided around it.
struct MissInputs {
  PlanRequest request;                        ///< the leader's (validated) request
  std::string cache_key_hex;                  ///< reported in the answer's statistics
  std::uint64_t seed = 0;                     ///< the effective DE seed (never 0)
  bool verify = false;                        ///< verify the top K (a verifier is present)
  Eigen::MatrixXd warm_start;                 ///< decision vectors (columns) of cached neighbours
  Clock::time_point budget_end;               ///< the deadline minus the reply margin
  double remaining_s = 0.0;                   ///< until budget_end, measured once by the caller
  const std::atomic<bool>* cancel = nullptr;  ///< set when every caller gave up
};

/// What a miss produced: an error, or an answer and (when it has a trajectory) its compact form.
struct MissResult {
  std::optional<ServiceError> error;       ///< set when there is no answer
  std::optional<PlanAnswer> answer;        ///< the leader's answer
  std::optional<CachedSolution> solution;  ///< none when no valid trajectory was found
  bool cacheable = false;  ///< the DE ended on its own criterion or found a feasible plan
};

/// Best verified candidate: passed and feasible, then passed, then the best-ranked one
/// simulated; nullopt when no verdict arrived. `feasible[k]` is candidate k's feasibility.
std::optional<std::size_t> chooseVerified(
    const std::vector<std::optional<VerifierVerdict>>& verdicts, const std::vector<bool>& feasible);
/// The rank chooseVerified() takes whatever the verdicts still missing say: the first k whose
/// verdict passed on a feasible candidate with every rank above it in; nullopt until then. The
/// miss stops waiting for the lower ranks there.
std::optional<std::size_t> choiceIsFinal(
    const std::vector<std::optional<VerifierVerdict>>& verdicts, const std::vector<bool>& feasible);

/// The pipeline of a miss. Immutable after construction except for the running estimate of one
/// DE generation's wall time; run() is safe to call from several threads at once.
class MissPipeline {
 public:
  /// `verifier` may be null (no verification); `verify_pool` runs the simulations.
  MissPipeline(const ServerConfig& config, const planner::JumpPlanner& planner,
               const PlanVerifier* verifier, BoundedExecutor& verify_pool);

  /// Plans, verifies the top K, chooses, falls back. Never throws: failures are the result's
  /// error (Cancelled, DeadlineExceeded, or the planner's exception classified).
  MissResult run(const MissInputs& in);

  /// Running estimate of one DE generation's wall time [ms] (the DE's clock granularity).
  double generationMs() const { return generation_ms_.load(); }
  /// The evaluation budget of `request`'s search: budget.max_evaluations or the settings', at
  /// most planner.max_evaluations_cap, at least one population.
  std::int64_t maxEvaluations(const PlanRequest& request) const;

 private:
  struct Verified;
  /// The search options: the remaining time split between DE, polish and verification.
  planner::PlanOptions searchOptions(const MissInputs& in) const;
  /// Simulates the top K of `result` on the verify pool; the chosen candidate's plan and
  /// verdict, or the error that replaces them.
  Verified verifyTopK(const MissInputs& in, const planner::PlannerResult& result) const;
  /// The lift-off correction (ServerConfig::verification.liftoff_correction_rounds; docs/
  /// planner.md, "The lift-off correction"): while rounds and time remain, plans again from the
  /// chosen candidate with the flight started from the lift-off its verification measured,
  /// verifies that plan on this thread, and keeps it (as `result`, rank 0) if it ranks better by
  /// (verified, feasible, smaller residual). Stops once a verified, feasible plan is within the
  /// tolerances. Never for a backflip.
  void correctLiftOff(const MissInputs& in, planner::PlannerResult& result, Verified& v) const;
  /// The sentence that says why verification did not run.
  std::string notRunReason(const PlanRequest& request) const;
  /// The compact cache entry of the returned candidate.
  CachedSolution compactSolution(const planner::PlannerResult& result,
                                 const planner::Candidate& chosen, const PlanAnswer& answer,
                                 const StoredVerification& verification, std::uint64_t seed,
                                 bool de_complete, std::int64_t max_evaluations) const;

  const ServerConfig& config_;
  const planner::JumpPlanner& planner_;
  const PlanVerifier* verifier_;
  BoundedExecutor& verify_pool_;
  std::atomic<double> generation_ms_{20.0};
};

}  // namespace wj::server
