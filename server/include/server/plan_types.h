#pragma once
/// @file The service's requests and answers in domain terms (no gRPC, no protobuf): what the
/// RPC layer converts to and from the wheeljump.planner.v1 messages.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "planner/jump_model.h"
#include "planner/jump_plan.h"
#include "planner/jump_task.h"
#include "planner/planner_settings.h"

namespace wj::server {

/// Where an answer came from (the proto's PlanSource).
enum class PlanSource { CacheHit, CacheMiss, WarmStart, Coalesced };
/// "cache_hit", "cache_miss", "warm_start", "coalesced" (also the latency path names).
const char* toString(PlanSource source);
inline constexpr int kNumPlanSources = 4;

/// Outcome of the multibody check of a plan (the proto's VerificationStatus).
enum class VerificationStatus : std::uint8_t { NotRun = 0, Passed = 1, Failed = 2 };

/// A validated PlanJump request.
/// How the answer's trajectory travels (the contract's TrajectoryFormat).
enum class TrajectoryFormat {
  Dense,         ///< uniform samples (planner settings' output_dt_s)
  Knots,         ///< knots of piecewise cubics (JumpModel::buildKnots)
  CompactKnots,  ///< the same knots, compact on the wire (planner_client/compact_knots.h)
};

/// Whether the answer's plan is built as knots (JumpModel::buildKnots), in either form.
inline bool asKnots(TrajectoryFormat f) {
  return f != TrajectoryFormat::Dense;
}

struct PlanRequest {
  planner::JumpTask task;
  planner::InitialState initial;
  std::optional<std::int64_t> max_evaluations;  ///< DE evaluation budget; none = settings
  int max_verified_candidates = 0;              ///< 0 = the server's default
  bool skip_verification = false;
  std::uint64_t seed = 0;  ///< 0 = the planner settings' seed
  TrajectoryFormat trajectory = TrajectoryFormat::Dense;
  std::string request_id;
};

/// A validated WarmCache request: one task over a grid of run-up speeds.
struct WarmRequest {
  planner::JumpTask task;
  std::vector<double> v0_grid;  ///< the grid points [m/s], at most 1000
};

/// What the multibody verification found for the returned plan.
struct VerificationSummary {
  VerificationStatus status = VerificationStatus::NotRun;
  std::vector<std::string> failure_reasons;  ///< one sentence or name each
  planner::JumpOutcome simulated;
  double max_envelope_ratio = 0.0;
  bool landed_upright = false;
  int candidates_verified = 0;
  int returned_candidate_rank = 0;
};

/// Where the time of a request went and how much search it took (the proto's SolveStats).
struct SolveStats {
  double de_ms = 0.0, polish_ms = 0.0, verify_ms = 0.0, total_ms = 0.0;
  std::int64_t evaluations = 0;
  int generations = 0;
  int threads = 0;
  double de_cost = 0.0;
  double polished_cost = 0.0;
  std::uint64_t seed = 0;
  std::string cache_key;  ///< hex
};

/// A successful PlanJump answer. The plan always belongs to the request's own initial state.
struct PlanAnswer {
  planner::JumpPlan plan;
  planner::Evaluation evaluation;  ///< of `plan` at the request's state
  std::vector<planner::ConstraintClass> binding;
  std::string summary;
  VerificationSummary verification;
  PlanSource source = PlanSource::CacheMiss;
  SolveStats stats;
};

/// The binding constraint classes of an evaluation (violated ones by priority, or, when the
/// constraints hold but the target is missed, the nearly active ones) and a one-sentence
/// summary of a re-evaluated cached solution, by the planner's own rule
/// (planner::findBindingClasses, planner::summarizeEvaluation).
/// `backoff`: the planner settings' polish.backoff.
void describeEvaluation(const planner::Evaluation& ev, double backoff,
                        std::vector<planner::ConstraintClass>& binding, std::string& summary);

}  // namespace wj::server
