#pragma once
/// @file The verification step behind a small interface, so that the planning core does not
/// depend on the simulator. The real implementation wraps wj::sim::Verifier (Simbody); servers
/// built without the sim component have none and report verification as NOT_RUN.

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "planner/jump_plan.h"
#include "planner/jump_task.h"
#include "robot_model/robot_model.h"
#include "server/config.h"

namespace wj::server {

/// What one verification found.
struct VerifierVerdict {
  bool passed = false;
  std::uint32_t failure_bits = 0;    ///< reason codes, see PlanVerifier::failureNames()
  std::vector<std::string> reasons;  ///< one sentence per failure
  planner::JumpOutcome simulated;
  double max_envelope_ratio = 0.0;
  bool landed_upright = false;
};

/// Checks a plan in simulation. verify() is const and safe to call from several threads at
/// once (the pool verifies the best K candidates in parallel).
class PlanVerifier {
 public:
  virtual ~PlanVerifier() = default;
  /// A short description for logs, e.g. "simbody (wj::sim::Verifier)".
  virtual std::string name() const = 0;
  /// Simulates `plan` (which starts at its own initial state) in the world of `task` (flat
  /// ground, and the task's obstacle as a wall). Cannot be interrupted.
  virtual VerifierVerdict verify(const planner::JumpPlan& plan,
                                 const planner::JumpTask& task) const = 0;
  /// As verify(), but may give up once `stop` is set: nullopt then. By default it cannot be
  /// interrupted and runs to the end.
  virtual std::optional<VerifierVerdict> verifyUnless(const planner::JumpPlan& plan,
                                                      const planner::JumpTask& task,
                                                      const std::atomic<bool>& stop) const {
    (void)stop;
    return verify(plan, task);
  }
  /// Stable names of the reason codes in `bits`, e.g. "torque_limit".
  virtual std::vector<std::string> failureNames(std::uint32_t bits) const = 0;
  /// Hash of everything that decides a verdict (settings, acceptance), for the cache key.
  virtual std::uint64_t settingsHash() const = 0;
};

/// True if this build has the Simbody verifier (the sim component was built).
bool simVerifierAvailable();
/// The Simbody verifier with the configured settings and acceptance bounds; nullptr if the
/// build has none. Throws std::runtime_error if the sim settings or jump executor file is
/// unreadable or invalid (std::invalid_argument for an executor value out of range).
std::unique_ptr<PlanVerifier> makeSimVerifier(const model::RobotModel& robot,
                                              const VerificationConfig& config);

}  // namespace wj::server
