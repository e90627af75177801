#pragma once
/// @file A plan sent as knots (JumpPlan::knots) back to dense references: the interpolation
/// the contract's TrajectoryKnots prescribes.

#include <string>

#include "planner/jump_plan.h"

namespace wj::planner {

/// What is wrong with plan.knots for a plan ending at plan.t3, or "" if nothing: at least two
/// knots; finite, non-decreasing times from 0 to t3 (a time at most twice: a phase boundary);
/// at least two distinct times per phase; K x 16 joint arrays and K CoM states, all finite.
std::string checkKnots(const JumpPlan& plan);

/// The torque slopes densify() uses at each knot [Nm/s]: second-order finite differences over
/// three knots of the same phase (one-sided at the phase's ends, the chord with two knots).
Eigen::MatrixXd knotTorqueSlopes(const PlanKnots& knots);

/// Fills plan.centroidal, q, qd and tau at the period dt (samples at min(k dt, t3), the last
/// at t3) and sets plan.dt, from plan.knots: between two knots of one phase, positions follow
/// the cubic Hermite curve with the knots' velocities as slopes and velocities its derivative;
/// torques the cubic Hermite curve with second-order finite-difference slopes of the phase's
/// knots. At a phase boundary the dense sample takes the ending phase's value. Throws
/// std::invalid_argument (with checkKnots' reason) if the knots are malformed or dt is not in
/// (0, 0.002].
void densify(JumpPlan& plan, double dt);

}  // namespace wj::planner
