#pragma once
/// @file The lift-off correction: plan a jump, verify it in the multibody simulation, and plan
/// it again with the take-off model's flight started from the lift-off Simbody measured
/// (docs/planner.md, "The lift-off correction").
///
/// The planner's take-off model leaves out what the joints' tracking, the tyres' compliance and
/// the contact's unloading do to the lift-off (docs/takeoff-fidelity.md): its lift-off velocity
/// and angular momentum differ from Simbody's by a few percent, and the flight planned from
/// them lands elsewhere. The residual changes little from one plan to a neighbouring one, so it
/// is measured on the plan, added to the model's flight (planner::LiftOffCorrection) and the
/// jump planned again from the last plan, until the plan's lift-off is Simbody's within the
/// tolerances: a fixed-point iteration, correction += residual.
///
/// Usage:
///   wj::sim::CorrectedPlan c = wj::sim::planWithLiftOffCorrection(
///       planner, [&](const wj::planner::JumpPlan& p) { return verifier.verify(p, scenario); },
///       task, initial, options, {});
///   c.result.plan, c.report: the chosen round's plan and its verification.
#include <functional>
#include <vector>

#include "planner/jump_planner.h"
#include "planner/liftoff_correction.h"
#include "sim/verifier.h"

namespace wj::sim {

/// How the correction iterates. Strict in its ranges (validate()).
struct LiftOffCorrectionSettings {
  /// Plans after the first one, each with the correction so far plus the last residual; 0:
  /// the model alone (the first plan, verified). In [0, 10].
  int max_rounds = 2;
  /// Done when Simbody's lift-off CoM velocity is within this fraction of the plan's lift-off
  /// speed ... (0, 1)
  double velocity_tolerance = planner::kLiftOffVelocityTolerance;
  /// ... and its angular momentum about the CoM within this [kg m^2/s], (0, 1].
  double momentum_tolerance = planner::kLiftOffMomentumTolerance;
  /// Throws std::invalid_argument naming the field and its range.
  void validate() const;
};

/// Simbody's lift-off less the plan's flight at the same instant (Simbody's lift-off, some
/// milliseconds after the plan's t2): the CoM velocity (the plan's ballistic from its t2) and
/// the whole robot's angular momentum about its CoM (the flight's, which it conserves).
planner::LiftOffCorrection measureLiftOffResidual(const planner::JumpPlan& plan,
                                                  const VerificationReport& report, double gravity);

/// One plan of the iteration and what Simbody made of it.
struct CorrectionRound {
  planner::LiftOffCorrection correction;  ///< what the plan's flight started with
  planner::LiftOffCorrection residual;    ///< Simbody's lift-off less the plan's
  bool feasible = false;                  ///< the plan met its constraints and target
  bool passed = false;                    ///< Simbody verified it
  std::vector<std::string> reasons;       ///< ... or why not (VerificationReport::reasons)
  /// max(|dv| / (velocity_tolerance x speed), |dH| / momentum_tolerance): <= 1 within both.
  double residual_ratio = 0.0;
  double solve_ms = 0.0, verify_ms = 0.0;
};

/// The chosen round's plan and verification, and every round.
struct CorrectedPlan {
  planner::PlannerResult result;
  VerificationReport report;
  std::vector<CorrectionRound> rounds;  ///< round 0: the model alone
  int chosen = 0;                       ///< index into rounds
};

/// How the caller verifies a plan: its scenario, Simbody's initial state, its plant.
using VerifyPlan = std::function<VerificationReport(const planner::JumpPlan&)>;

/// Plans `task` from `initial` with `options` (its liftoff_correction is the first round's),
/// verifies each plan with `verify`, and plans again with the
/// correction plus the residual until a verified, feasible plan's lift-off is within the
/// tolerances, after settings.max_rounds, when the search returns the last round's candidate
/// again, or when no residual can be measured (Simbody's robot
/// did not take off) or the next correction leaves planner::LiftOffCorrection's bounds. Each
/// later round warm-starts the planner from the last plan (options.warm_start). Chosen: the
/// best round by (verified, feasible, smaller residual_ratio), the first of equals. Throws what
/// JumpPlanner::plan throws for bad input.
CorrectedPlan planWithLiftOffCorrection(const planner::JumpPlanner& planner,
                                        const VerifyPlan& verify, const planner::JumpTask& task,
                                        const planner::InitialState& initial,
                                        planner::PlanOptions options,
                                        const LiftOffCorrectionSettings& settings);

}  // namespace wj::sim
