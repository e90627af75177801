#include "server/plan_types.h"

#include "planner/jump_planner.h"

namespace wj::server {

const char* toString(PlanSource source) {
  switch (source) {
    case PlanSource::CacheHit:
      return "cache_hit";
    case PlanSource::CacheMiss:
      return "cache_miss";
    case PlanSource::WarmStart:
      return "warm_start";
    case PlanSource::Coalesced:
      return "coalesced";
  }
  return "?";
}

void describeEvaluation(const planner::Evaluation& ev, double backoff,
                        std::vector<planner::ConstraintClass>& binding, std::string& summary) {
  binding = planner::findBindingClasses(ev, backoff);
  summary = planner::summarizeEvaluation(ev, binding);
}

}  // namespace wj::server
