// The golden messages of the wheeljump.planner.v1 contract: realistic values, built in code so
// that tests/contract/golden/ can be regenerated (make_golden) and checked against this source.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <google/protobuf/message.h>

#include "wheeljump/planner/v1/jump_planner.pb.h"

namespace wj::contract {

/// A request of a robot rolling at 3 m/s that asks to jump forward over a 0.25 m wall.
wheeljump::planner::v1::PlanJumpRequest makeGoldenPlanJumpRequest();

/// A verified two-step plan answering makeGoldenPlanJumpRequest(), shortened for size.
wheeljump::planner::v1::PlanJumpResponse makeGoldenPlanJumpResponse();

/// Counters and latency percentiles of a server that has run for a day.
wheeljump::planner::v1::GetStatsResponse makeGoldenGetStatsResponse();

/// One progress message of a WarmCache stream, part way through its grid.
wheeljump::planner::v1::WarmCacheProgress makeGoldenWarmCacheProgress();

/// One golden: its file stem in golden/ (<stem>.binpb and <stem>.json) and its builder.
struct GoldenCase {
  std::string_view stem;                                              // e.g. "plan_jump_request"
  std::function<std::unique_ptr<google::protobuf::Message>()> build;  // the message as built here
};

/// Every golden of the contract, in a fixed order.
const std::vector<GoldenCase>& goldenCases();

/// The message in binary wire form, serialized deterministically.
std::string serializeDeterministic(const google::protobuf::Message& message);

/// The message in the proto3 JSON mapping as committed in golden/ (lowerCamelCase names,
/// default values omitted, indented). Throws std::runtime_error if printing fails.
std::string printGoldenJson(const google::protobuf::Message& message);

}  // namespace wj::contract
