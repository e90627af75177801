#pragma once
/// @file The compact solution the cache stores instead of a trajectory: the search vector u, the
/// phase times, the outcome of the search and a summary of the verification. A hit regenerates
/// the dense plan with JumpModel::buildPlan(u). Encoded into a versioned little-endian payload
/// that SQLite stores next to a CRC-32 of key and payload.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "planner/jump_model.h"
#include "server/plan_types.h"

namespace wj::server {

/// The verification part of a cached solution.
struct StoredVerification {
  VerificationStatus status = VerificationStatus::NotRun;
  std::uint32_t failure_bits = 0;  ///< the verifier's reason codes (PlanVerifier::failureNames)
  planner::JumpOutcome simulated;
  double max_envelope_ratio = 0.0;
  bool landed_upright = false;
  std::uint16_t candidates_verified = 0;
  std::uint16_t returned_candidate_rank = 0;
  float verify_ms = 0.0f;
};

/// One cache entry's value (well under 1 KB in memory; see tests/server).
struct CachedSolution {
  std::array<double, planner::kNumDecision> u{};  ///< search vector of the returned candidate
  double t1 = 0.0, t2 = 0.0, t3 = 0.0;            ///< phase times [s]
  bool feasible = false;                          ///< at the state it was computed for
  /// Every constraint margin >= 0 there: a feasible plan, or a closest approach to a target out
  /// of reach (a hit that loses it at the caller's state is planned instead: PlanningCore).
  bool constraints_ok = false;
  bool de_complete = false;  ///< the DE stopped on its own criterion (not time or cancel)
  /// The evaluation budget the search was given (budget.max_evaluations or the settings', capped):
  /// an infeasible answer is not the last word for a caller who allows more (findHit).
  std::int64_t max_evaluations = 0;
  double de_cost = 0.0, final_cost = 0.0;
  std::uint64_t seed = 0;
  std::int64_t evaluations = 0;
  std::int32_t generations = 0;
  float de_ms = 0.0f, polish_ms = 0.0f;
  StoredVerification verification;
  std::int64_t created_unix_ms = 0;
  /// The lift-off correction the plan was made with (zero: none); a hit rebuilds the plan with
  /// it (docs/planner.md, "The lift-off correction").
  planner::LiftOffCorrection liftoff_correction;
};

/// The payload bytes (format version 4: version 3 and the lift-off correction; version 3:
/// version 2 and constraints_ok; version 2: version 1 and max_evaluations). Older payloads are
/// still read, with no correction, constraints_ok = feasible and, for version 1,
/// max_evaluations = evaluations.
std::string encodeSolution(const CachedSolution& s);
/// Parses a payload; nullopt if its version, length or any value is malformed (non-finite u).
std::optional<CachedSolution> decodeSolution(std::string_view payload);
/// CRC-32 (IEEE) over the key bytes followed by the payload bytes.
std::uint32_t rowChecksum(std::string_view key_bytes, std::string_view payload);

/// Whether replacing `current` by `candidate` improves the entry: verified and passing beats
/// verified and failing beats unverified; then feasible beats infeasible; then lower final cost;
/// then a larger evaluation budget (a search given a larger budget that found no better answer
/// replaces the smaller one's, so that the larger budget is not asked for again).
bool isBetterSolution(const CachedSolution& candidate, const CachedSolution& current);

}  // namespace wj::server
