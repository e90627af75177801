#include "planner/plan_report.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace wj::planner {

namespace {
constexpr const char* kKinds[kNumJointKinds] = {"haa", "hfe", "kfe", "wheel"};
}

nlohmann::json reportJson(const Scenario& sc, const PlannerResult& r) {
  using nlohmann::json;
  const Evaluation& ev = r.evaluation;
  json j;
  j["task"] = sc.name;
  j["feasible"] = ev.feasible;
  j["solve_ms"] = r.total_ms;
  j["de_ms"] = r.de_ms;
  j["polish_ms"] = r.polish_ms;
  j["evaluations"] = r.de.evaluations;
  j["generations"] = r.de.generations;
  j["stop_reason"] = std::string(de::toString(r.de.stop_reason));
  j["first_feasible_evaluations"] = r.de.first_feasible_evaluations;
  j["de_restarts"] = r.de_restarts;
  j["polish"] = {{"outcome", toString(r.polish)},     {"goal", toString(r.polish_goal)},
                 {"iterations", r.polish_iterations}, {"de_cost", r.de_cost},
                 {"final_cost", r.final_cost},        {"gain", r.de_cost - r.final_cost}};
  const auto& t = sc.task.target;
  j["target"] = {{"dx", t.dx},
                 {"z", t.height},
                 {"pitch", t.pitch_change},
                 {"event", t.event == TargetEvent::Apex ? "apex" : "touchdown"},
                 {"v0", sc.initial.v0},
                 {"mode", sc.task.mode == TakeoffMode::TwoStep ? "two_step" : "simultaneous"}};
  if (sc.task.obstacle)
    j["target"]["obstacle"] = {sc.task.obstacle->x_min, sc.task.obstacle->x_max,
                               sc.task.obstacle->height};
  const auto& p = ev.predicted;
  const PlanarState& at = t.event == TargetEvent::Apex ? p.apex.state : p.touchdown.state;
  j["predicted"] = {
      {"apex_z", p.apex.state.z},
      {"apex_base_z", p.apex.base_z},
      {"dx", at.x},
      {"pitch", at.pitch},
      {"touchdown_dx", p.touchdown.state.x},
      {"touchdown_pitch", p.touchdown.state.pitch},
      {"takeoff_vx", p.takeoff.state.vx},
      {"takeoff_vz", p.takeoff.state.vz},
      {"min_obstacle_clearance",
       std::isfinite(p.min_obstacle_clearance) ? json(p.min_obstacle_clearance) : json(nullptr)}};
  j["target_error"] = {{"dx", ev.err_dx},
                       {"z", ev.err_height},
                       {"pitch", ev.err_pitch},
                       {"landing_pitch", ev.err_landing_pitch}};
  j["phase_times"] = {{"t1", r.plan.t1}, {"t2", r.plan.t2}, {"t3", r.plan.t3}};
  j["energy_j"] = ev.energy_j;
  for (int k = 0; k < kNumJointKinds; ++k) {
    j["max_abs_torque_nm"][kKinds[k]] = ev.max_abs_torque_nm[k];
    j["max_abs_speed_rad_s"][kKinds[k]] = ev.max_abs_speed_rad_s[k];
  }
  json violations = json::array();
  for (int i = 0; i < kNumConstraintClasses; ++i) {
    const auto c = static_cast<ConstraintClass>(i);
    const auto& m = ev.margins[i];
    if (!std::isfinite(m.worst)) continue;
    j["worst_margin"][toString(c)] = {{"margin", m.worst}, {"unit", unitOf(c)}, {"t", m.t}};
    if (m.worst < 0.0) violations.push_back(toString(c));
  }
  j["violations"] = violations;
  json binding = json::array();
  for (const auto c : r.binding) binding.push_back(toString(c));
  j["binding"] = binding;
  j["summary"] = r.summary;
  return j;
}

std::string reportText(const Scenario& sc, const PlannerResult& r) {
  const Evaluation& ev = r.evaluation;
  std::ostringstream ss;
  ss << std::fixed << std::setprecision(3);
  ss << "task " << sc.name << ": " << r.summary << "\n";
  ss << "  solve " << r.total_ms << " ms (DE " << r.de_ms << " ms, " << r.de.evaluations
     << " evaluations, " << r.de.generations << " generations; polish " << toString(r.polish) << " "
     << r.polish_ms << " ms, cost " << r.de_cost << " -> " << r.final_cost << ")\n";
  ss << "  phases t1 " << r.plan.t1 << " s, t2 " << r.plan.t2 << " s, t3 " << r.plan.t3 << " s\n";
  const auto& p = ev.predicted;
  ss << "  apex CoM z " << p.apex.state.z << " m (base " << p.apex.base_z << " m), touchdown dx "
     << p.touchdown.state.x << " m, pitch " << p.touchdown.state.pitch << " rad\n";
  ss << "  max |tau| [Nm]  haa " << ev.max_abs_torque_nm[0] << "  hfe " << ev.max_abs_torque_nm[1]
     << "  kfe " << ev.max_abs_torque_nm[2] << "  wheel " << ev.max_abs_torque_nm[3] << "\n";
  ss << "  max |qd| [rad/s] hfe " << ev.max_abs_speed_rad_s[1] << "  kfe "
     << ev.max_abs_speed_rad_s[2] << "  wheel " << ev.max_abs_speed_rad_s[3] << "\n";
  ss << "  worst margins:";
  for (int i = 0; i < kNumConstraintClasses; ++i) {
    const auto c = static_cast<ConstraintClass>(i);
    if (std::isfinite(ev.margins[i].worst))
      ss << " " << toString(c) << "=" << ev.margins[i].worst << unitOf(c);
  }
  ss << "\n";
  return ss.str();
}

}  // namespace wj::planner
