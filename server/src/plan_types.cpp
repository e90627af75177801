#include "server/plan_types.h"

#include <algorithm>
#include <sstream>

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

void describeEvaluation(const planner::Evaluation& ev,
                        std::vector<planner::ConstraintClass>& binding, std::string& summary) {
  using planner::ConstraintClass;
  using planner::JumpModel;
  std::vector<std::pair<int, ConstraintClass>> v;
  for (int i = 0; i < planner::kNumConstraintClasses; ++i) {
    const auto c = static_cast<ConstraintClass>(i);
    if (ev.margins[i].worst < 0.0) v.emplace_back(JumpModel::classPriority(c), c);
  }
  if (v.empty() && !ev.target_ok) {
    for (int i = 0; i < planner::kNumConstraintClasses; ++i) {
      const auto c = static_cast<ConstraintClass>(i);
      if (ev.margins[i].worst / JumpModel::classScale(c) < 0.05)
        v.emplace_back(JumpModel::classPriority(c), c);
    }
  }
  std::stable_sort(v.begin(), v.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  binding.clear();
  for (const auto& [priority, c] : v) binding.push_back(c);

  std::ostringstream ss;
  if (ev.feasible) {
    summary = "feasible: all constraints hold and the target is met";
    return;
  }
  if (!ev.valid) {
    summary = "infeasible: no valid trajectory found";
    return;
  }
  ss << "infeasible: ";
  if (!ev.constraints_ok) {
    ss << "violated";
  } else {
    ss << "target missed (dx " << ev.err_dx << " m, height " << ev.err_height << " m, pitch "
       << ev.err_pitch << " rad); binding";
  }
  for (std::size_t i = 0; i < binding.size(); ++i) {
    const auto& m = ev.margins[static_cast<int>(binding[i])];
    ss << (i ? ", " : " ") << planner::toString(binding[i]) << " (margin " << m.worst << " "
       << planner::unitOf(binding[i]) << " at t=" << m.t << " s)";
  }
  summary = ss.str();
}

}  // namespace wj::server
