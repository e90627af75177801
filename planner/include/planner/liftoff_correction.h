#pragma once
/// @file The lift-off correction's arithmetic (docs/planner.md, "The lift-off correction"): the
/// residual of a plan's lift-off against a measured one, and its size against tolerances. The
/// iteration that plans with it is sim::planWithLiftOffCorrection (sim_jump, the benches) and
/// the service's miss pipeline (server::MissPipeline); both use these.

#include "planner/jump_plan.h"

namespace wj::planner {

/// The iteration's default tolerances: the lift-off CoM velocity within this fraction of the
/// plan's lift-off speed, and its flight momentum within this [kg m^2/s].
inline constexpr double kLiftOffVelocityTolerance = 0.005;
inline constexpr double kLiftOffMomentumTolerance = 0.01;

/// The measured lift-off less the plan's flight at the measured instant (some milliseconds after
/// the plan's t2): the CoM velocity (the plan's vz falls ballistically from its t2) and the
/// flight's angular momentum (JumpEvent::momentum, which the flight conserves).
LiftOffCorrection liftOffResidual(const JumpPlan& plan, const JumpEvent& measured_takeoff,
                                  double gravity);

/// max(|dv| / (velocity_tolerance x the plan's lift-off speed, at least 0.1 m/s),
/// |dH| / momentum_tolerance): <= 1 when the residual is within both.
double liftOffResidualRatio(const JumpPlan& plan, const LiftOffCorrection& residual,
                            double velocity_tolerance, double momentum_tolerance);

/// The next round's correction: `correction` plus `residual`, entry by entry.
LiftOffCorrection nextCorrection(const LiftOffCorrection& correction,
                                 const LiftOffCorrection& residual);

/// Within LiftOffCorrection's bounds (validate() would not throw).
bool withinBounds(const LiftOffCorrection& c);

}  // namespace wj::planner
