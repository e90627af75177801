#pragma once
/// @file The contract's CompactKnots (TRAJECTORY_FORMAT_COMPACT_KNOTS): a plan's knots with each
/// distinct joint column sent once, and back, bit for bit. The server compacts, the robot
/// expands and interpolates the TrajectoryKnots as before. Depends on the contract only.

#include <string>

#include "wheeljump/planner/v1/jump_planner.pb.h"

namespace wj::client {

/// `knots` in the compact form: a joint column constant over the plan is sent as one number, a
/// column equal to an earlier joint's, or to its negation (the right legs of a symmetric jump),
/// refers to it; columns are compared bit for bit, so expandKnots() gives `knots` back exactly.
/// `knots` must have consistent sizes (K times, K x 6 and K x 16 values; std::invalid_argument
/// otherwise).
void compactKnots(const wheeljump::planner::v1::TrajectoryKnots& knots,
                  wheeljump::planner::v1::CompactKnots* out);

/// The TrajectoryKnots that `compact` describes, into `out` (cleared first); "" or what is
/// wrong with `compact` (sizes, sources out of range, a non-finite constant), naming the field.
std::string expandKnots(const wheeljump::planner::v1::CompactKnots& compact,
                        wheeljump::planner::v1::TrajectoryKnots* out);

}  // namespace wj::client
