#include "planner/planner_settings.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <functional>
#include <map>
#include <sstream>
#include <stdexcept>

namespace wj::planner {

const char* toString(PolishSolver s) {
  switch (s) {
    case PolishSolver::Sqp:
      return "sqp";
    case PolishSolver::Ipopt:
      return "ipopt";
  }
  return "?";
}

const char* toString(ActuatorModel m) {
  switch (m) {
    case ActuatorModel::Envelope:
      return "envelope";
    case ActuatorModel::ConstantTorque:
      return "constant_torque";
  }
  return "?";
}

const char* toString(ConstraintClass c) {
  switch (c) {
    case ConstraintClass::NormalForce:
      return "normal_force";
    case ConstraintClass::FrictionCone:
      return "friction_cone";
    case ConstraintClass::JointPosition:
      return "joint_position";
    case ConstraintClass::JointSpeed:
      return "joint_speed";
    case ConstraintClass::JointTorque:
      return "joint_torque";
    case ConstraintClass::ActuatorEnvelope:
      return "actuator_envelope";
    case ConstraintClass::BodyHeight:
      return "body_height";
    case ConstraintClass::ObstacleClearance:
      return "obstacle_clearance";
    case ConstraintClass::WheelTraction:
      return "wheel_traction";
    case ConstraintClass::WheelSpeed:
      return "wheel_speed";
  }
  return "?";
}

const char* unitOf(ConstraintClass c) {
  switch (c) {
    case ConstraintClass::NormalForce:
    case ConstraintClass::FrictionCone:
      return "N";
    case ConstraintClass::JointPosition:
      return "rad";
    case ConstraintClass::JointSpeed:
    case ConstraintClass::WheelSpeed:
      return "rad/s";
    case ConstraintClass::JointTorque:
    case ConstraintClass::ActuatorEnvelope:
    case ConstraintClass::WheelTraction:
      return "Nm";
    case ConstraintClass::BodyHeight:
    case ConstraintClass::ObstacleClearance:
      return "m";
  }
  return "?";
}

PlannerSettings::PlannerSettings() {
  // Planner defaults for the DE (the generic solver's defaults are problem-agnostic).
  de.population_size = 32;
  de.strategy = de::Strategy::CurrentToPBest1Bin;
  de.adaptation = de::Adaptation::JDE;
  de.initialization = de::Initialization::LatinHypercube;
  de.max_generations = 1000;
  de.max_evaluations = 12000;
  de.stagnation_generations = 20;
  // Progress is a 0.1 % drop of the best cost within those generations: an unreachable target
  // otherwise creeps on by tiny amounts until the budget is spent.
  de.stagnation_tolerance = 1e-3;
  // Stop once a feasible candidate is within about one tolerance of the target: the Ipopt
  // polish then meets the target exactly at lower energy.
  de.target_cost = 1.0;
  de.threads = 2;
  de.seed = 1;
  de.keep_log = true;
}

namespace {

void check(bool ok, const std::string& field, const std::string& range, double value) {
  if (!ok || !std::isfinite(value)) {
    std::ostringstream ss;
    ss << "planner settings: " << field << " must be " << range << ", got " << value;
    throw std::invalid_argument(ss.str());
  }
}

void checkInterval(const std::array<double, 2>& b, const std::string& field) {
  check(b[0] <= b[1] && std::isfinite(b[0]), field, "an interval [lo, hi] with lo <= hi", b[1]);
}

}  // namespace

void PlannerSettings::validate() const {
  check(gravity > 0, "physics.gravity", "> 0", gravity);
  check(friction_mu > 0 && friction_mu <= 2, "physics.friction_mu", "in (0, 2]", friction_mu);
  check(min_normal_force_n >= 0, "physics.min_normal_force_n", ">= 0", min_normal_force_n);
  check(min_body_clearance_m >= 0, "physics.min_body_clearance_m", ">= 0", min_body_clearance_m);
  check(obstacle_margin_m >= 0, "physics.obstacle_margin_m", ">= 0", obstacle_margin_m);
  check(platform_margin_m >= 0, "physics.platform_margin_m", ">= 0", platform_margin_m);
  check(actuator_torque_scale > 0 && actuator_torque_scale <= 10, "physics.actuator_torque_scale",
        "in (0, 10]", actuator_torque_scale);
  check(takeoff_unload_s >= 0 && takeoff_unload_s <= 0.02, "physics.takeoff_unload_s",
        "in [0, 0.02]", takeoff_unload_s);
  check(tyre_rolling_radius_ratio >= 0.8 && tyre_rolling_radius_ratio <= 1.2,
        "physics.tyre_rolling_radius_ratio", "in [0.8, 1.2]", tyre_rolling_radius_ratio);
  check(tyre_slip_stiffness_n_s_m > 0, "physics.tyre_slip_stiffness_n_s_m", "> 0",
        tyre_slip_stiffness_n_s_m);
  check(tyre_contact_modulus_pa == 0 ||
            (tyre_contact_modulus_pa >= 1e5 && tyre_contact_modulus_pa <= 1e10),
        "physics.tyre_contact_modulus_pa", "0 (rigid) or in [1e5, 1e10]", tyre_contact_modulus_pa);
  check(tuck_end_fraction > 0 && tuck_end_fraction < extend_start_fraction,
        "postures.tuck_end_fraction", "in (0, extend_start_fraction)", tuck_end_fraction);
  check(extend_start_fraction < extend_end_fraction && extend_end_fraction <= 1,
        "postures.extend_end_fraction", "in (extend_start_fraction, 1]", extend_end_fraction);
  check(wall_extend_start_fraction > tuck_end_fraction &&
            wall_extend_start_fraction < extend_end_fraction,
        "postures.wall_extend_start_fraction", "in (tuck_end_fraction, extend_end_fraction)",
        wall_extend_start_fraction);
  check(samples_phase1 >= 4 && samples_phase1 <= 1000, "sampling.samples_phase1", "in [4, 1000]",
        samples_phase1);
  check(samples_phase2 >= 4 && samples_phase2 <= 1000, "sampling.samples_phase2", "in [4, 1000]",
        samples_phase2);
  check(samples_flight >= 4 && samples_flight <= 256, "sampling.samples_flight", "in [4, 256]",
        samples_flight);
  check(output_dt_s > 0 && output_dt_s <= 0.002, "sampling.output_dt_s", "in (0, 0.002]",
        output_dt_s);
  check(knot_dt_s >= 0.002 && knot_dt_s <= 0.1, "sampling.knot_dt_s", "in [0.002, 0.1] s",
        knot_dt_s);
  check(t1_s[0] > 0.01, "bounds.t1_s[0]", "> 0.01 s", t1_s[0]);
  check(t2_minus_t1_s[0] > 0.01, "bounds.t2_minus_t1_s[0]", "> 0.01 s", t2_minus_t1_s[0]);
  check(takeoff_vz_m_s[0] > 0, "bounds.takeoff_vz_m_s[0]", "> 0 (the robot must leave the ground)",
        takeoff_vz_m_s[0]);
  for (const auto& [b, name] :
       {std::pair{t1_s, "bounds.t1_s"},
        {t2_minus_t1_s, "bounds.t2_minus_t1_s"},
        {mid_dx_m, "bounds.mid_dx_m"},
        {mid_dz_m, "bounds.mid_dz_m"},
        {mid_dpitch_rad, "bounds.mid_dpitch_rad"},
        {takeoff_dx_m, "bounds.takeoff_dx_m"},
        {takeoff_dz_m, "bounds.takeoff_dz_m"},
        {takeoff_dpitch_rad, "bounds.takeoff_dpitch_rad"},
        {takeoff_dvx_m_s, "bounds.takeoff_dvx_m_s"},
        {takeoff_vz_m_s, "bounds.takeoff_vz_m_s"},
        {takeoff_pitch_rate_rad_s, "bounds.takeoff_pitch_rate_rad_s"},
        {two_step_takeoff_dpitch_rad, "bounds.two_step_takeoff_dpitch_rad"},
        {two_step_takeoff_pitch_rate_rad_s, "bounds.two_step_takeoff_pitch_rate_rad_s"},
        {flip_t1_s, "flip.t1_s"},
        {flip_t2_minus_t1_s, "flip.t2_minus_t1_s"},
        {flip_takeoff_dpitch_rad, "flip.takeoff_dpitch_rad"},
        {flip_takeoff_pitch_rate_rad_s, "flip.takeoff_pitch_rate_rad_s"},
        {flip_takeoff_vz_m_s, "flip.takeoff_vz_m_s"}})
    checkInterval(b, name);
  check(flip_t1_s[0] > 0.01, "flip.t1_s[0]", "> 0.01 s", flip_t1_s[0]);
  check(flip_t2_minus_t1_s[0] > 0.01, "flip.t2_minus_t1_s[0]", "> 0.01 s", flip_t2_minus_t1_s[0]);
  check(flip_takeoff_vz_m_s[0] > 0, "flip.takeoff_vz_m_s[0]",
        "> 0 (the robot must leave the ground)", flip_takeoff_vz_m_s[0]);
  if (!flip_initial_guess.empty() && flip_initial_guess.size() != 11)
    throw std::invalid_argument(
        "planner settings: flip.initial_guess must be empty or have 11 entries (the search "
        "vector), got " +
        std::to_string(flip_initial_guess.size()));
  check(flip_hind_knee_clearance_rad >= 0.0 && flip_hind_knee_clearance_rad <= 1.0,
        "flip.hind_knee_clearance_rad", "in [0, 1] rad", flip_hind_knee_clearance_rad);
  check(flip_front_brake_share > 0.0 && flip_front_brake_share <= 1.0, "flip.front_brake_share",
        "in (0, 1]", flip_front_brake_share);
  for (std::size_t i = 0; i < flip_initial_guess.size(); ++i)
    check(std::isfinite(flip_initial_guess[i]), "flip.initial_guess[" + std::to_string(i) + "]",
          "finite", flip_initial_guess[i]);
  for (int i = 0; i < kNumConstraintClasses; ++i)
    check(class_weight[i] > 0,
          std::string("cost.class_weight.") + toString(static_cast<ConstraintClass>(i)), "> 0",
          class_weight[i]);
  check(energy_weight >= 0, "cost.energy_weight", ">= 0", energy_weight);
  check(tolerance_dx_m > 0, "cost.tolerance_dx_m", "> 0", tolerance_dx_m);
  check(tolerance_height_m > 0, "cost.tolerance_height_m", "> 0", tolerance_height_m);
  check(tolerance_pitch_rad > 0, "cost.tolerance_pitch_rad", "> 0", tolerance_pitch_rad);
  check(landing_pitch_tolerance_rad > 0, "cost.landing_pitch_tolerance_rad", "> 0",
        landing_pitch_tolerance_rad);
  check(de_restarts >= 0 && de_restarts <= 100, "de.restarts", "in [0, 100]", de_restarts);
  check(polish_max_iterations >= 0, "polish.max_iterations", ">= 0", polish_max_iterations);
  check(polish_warm_max_iterations >= 0, "polish.warm_max_iterations", ">= 0 (0 = as cold)",
        polish_warm_max_iterations);
  check(polish_tolerance > 0, "polish.tolerance", "> 0", polish_tolerance);
  check(polish_retries >= 0 && polish_retries <= 16, "polish.retries", "in [0, 16]",
        polish_retries);
  check(polish_stall_iterations >= 0, "polish.stall_iterations", ">= 0", polish_stall_iterations);
  if (contact_chain != ContactChain::FromStart && contact_chain != ContactChain::FromTakeoff)
    throw std::invalid_argument(
        "planner settings: sampling.contact_chain must be one of from_start, from_takeoff, got " +
        std::to_string(static_cast<int>(contact_chain)));
  if (actuator_model != ActuatorModel::Envelope && actuator_model != ActuatorModel::ConstantTorque)
    throw std::invalid_argument(
        "planner settings: physics.actuator_model must be one of envelope, constant_torque, got " +
        std::to_string(static_cast<int>(actuator_model)));
  if (polish_solver != PolishSolver::Sqp && polish_solver != PolishSolver::Ipopt)
    throw std::invalid_argument("planner settings: polish.solver must be one of sqp, ipopt, got " +
                                std::to_string(static_cast<int>(polish_solver)));
  check(warm_start_cloud >= 0 && warm_start_cloud <= 1000, "de.warm_start_cloud", "in [0, 1000]",
        warm_start_cloud);
  check(warm_start_spread >= 0 && warm_start_spread <= 0.5, "de.warm_start_spread", "in [0, 0.5]",
        warm_start_spread);
  check(polish_backoff >= 0 && polish_backoff <= 0.5, "polish.backoff", "in [0, 0.5]",
        polish_backoff);
  de.validate();
}

namespace {

// A strict reader: each section maps keys to setters; any key left unknown is an error.
using Setter = std::function<void(const YAML::Node&)>;

void readSection(const YAML::Node& node, const std::string& section,
                 const std::map<std::string, Setter>& setters) {
  if (!node.IsMap()) throw std::runtime_error("planner settings: '" + section + "' must be a map");
  for (const auto& kv : node) {
    const auto key = kv.first.as<std::string>();
    const auto it = setters.find(key);
    if (it == setters.end()) {
      std::string allowed;
      for (const auto& [k, _] : setters) allowed += (allowed.empty() ? "" : ", ") + k;
      throw std::runtime_error("planner settings: unknown key '" + section + "." + key +
                               "' (allowed: " + allowed + ")");
    }
    try {
      it->second(kv.second);
    } catch (const YAML::Exception& e) {
      throw std::runtime_error("planner settings: bad value for '" + section + "." + key +
                               "': " + e.what());
    }
  }
}

Setter number(double& target) {
  return [&target](const YAML::Node& n) { target = n.as<double>(); };
}
Setter integer(int& target) {
  return [&target](const YAML::Node& n) { target = n.as<int>(); };
}
Setter interval(std::array<double, 2>& target) {
  return [&target](const YAML::Node& n) {
    if (!n.IsSequence() || n.size() != 2) throw YAML::Exception(n.Mark(), "expected [lo, hi]");
    target = {n[0].as<double>(), n[1].as<double>()};
  };
}

template <typename Enum>
Setter choice(Enum& target, const std::map<std::string, Enum>& names) {
  return [&target, names](const YAML::Node& n) {
    const auto s = n.as<std::string>();
    const auto it = names.find(s);
    if (it == names.end()) {
      std::string allowed;
      for (const auto& [k, _] : names) allowed += (allowed.empty() ? "" : ", ") + k;
      throw YAML::Exception(n.Mark(), "'" + s + "' is not one of " + allowed);
    }
    target = it->second;
  };
}

// The "de" section: the solver's settings and the planner's restarts and warm-start cloud.
void readDe(const YAML::Node& n, PlannerSettings& s) {
  auto& d = s.de;
  readSection(
      n, "de",
      {{"population_size", integer(d.population_size)},
       {"strategy", choice(d.strategy,
                           std::map<std::string, de::Strategy>{
                               {"rand1bin", de::Strategy::Rand1Bin},
                               {"best1bin", de::Strategy::Best1Bin},
                               {"current_to_best1bin", de::Strategy::CurrentToBest1Bin},
                               {"rand2bin", de::Strategy::Rand2Bin},
                               {"current_to_pbest1bin", de::Strategy::CurrentToPBest1Bin}})},
       {"adaptation",
        choice(d.adaptation,
               std::map<std::string, de::Adaptation>{{"none", de::Adaptation::None},
                                                     {"jde", de::Adaptation::JDE},
                                                     {"shade", de::Adaptation::SHADE}})},
       {"initialization",
        choice(d.initialization,
               std::map<std::string, de::Initialization>{
                   {"uniform", de::Initialization::Uniform},
                   {"latin_hypercube", de::Initialization::LatinHypercube},
                   {"opposition_based", de::Initialization::OppositionBased}})},
       {"F", number(d.F)},
       {"CR", number(d.CR)},
       {"p_best", number(d.p_best)},
       {"max_generations", integer(d.max_generations)},
       {"max_evaluations", [&](const YAML::Node& v) { d.max_evaluations = v.as<std::int64_t>(); }},
       {"time_budget_s", number(d.time_budget_s)},
       {"tolerance", number(d.tolerance)},
       {"stagnation_generations", integer(d.stagnation_generations)},
       {"stagnation_tolerance", number(d.stagnation_tolerance)},
       {"target_cost", number(d.target_cost)},
       {"bounded_trials", [&](const YAML::Node& v) { d.bounded_trials = v.as<bool>(); }},
       {"restarts", integer(s.de_restarts)},
       {"restart_while_budget",
        [&](const YAML::Node& v) { s.de_restart_while_budget = v.as<bool>(); }},
       {"warm_start_cloud", integer(s.warm_start_cloud)},
       {"warm_start_spread", number(s.warm_start_spread)},
       {"threads", integer(d.threads)},
       {"seed", [&](const YAML::Node& v) { d.seed = v.as<std::uint64_t>(); }}});
}

PlannerSettings parse(const YAML::Node& root) {
  PlannerSettings s;
  if (!root || root.IsNull()) return s;
  std::map<std::string, Setter> weights;
  for (int i = 0; i < kNumConstraintClasses; ++i)
    weights[toString(static_cast<ConstraintClass>(i))] = number(s.class_weight[i]);
  const std::map<std::string, Setter> top = {
      {"physics",
       [&](const YAML::Node& n) {
         readSection(
             n, "physics",
             {{"gravity", number(s.gravity)},
              {"friction_mu", number(s.friction_mu)},
              {"min_normal_force_n", number(s.min_normal_force_n)},
              {"min_body_clearance_m", number(s.min_body_clearance_m)},
              {"obstacle_margin_m", number(s.obstacle_margin_m)},
              {"platform_margin_m", number(s.platform_margin_m)},
              {"actuator_torque_scale", number(s.actuator_torque_scale)},
              {"takeoff_unload_s", number(s.takeoff_unload_s)},
              {"tyre_rolling_radius_ratio", number(s.tyre_rolling_radius_ratio)},
              {"tyre_slip_stiffness_n_s_m", number(s.tyre_slip_stiffness_n_s_m)},
              {"tyre_contact_modulus_pa", number(s.tyre_contact_modulus_pa)},
              {"balanced_stance", [&](const YAML::Node& v) { s.balanced_stance = v.as<bool>(); }},
              {"flight_feedforward",
               [&](const YAML::Node& v) { s.flight_feedforward = v.as<bool>(); }},
              {"stance_momentum", [&](const YAML::Node& v) { s.stance_momentum = v.as<bool>(); }},
              {"actuator_model",
               choice(s.actuator_model, std::map<std::string, ActuatorModel>{
                                            {"envelope", ActuatorModel::Envelope},
                                            {"constant_torque", ActuatorModel::ConstantTorque}})}});
       }},
      {"postures",
       [&](const YAML::Node& n) {
         readSection(n, "postures",
                     {{"stand_hfe_rad", number(s.stand_hfe_rad)},
                      {"stand_kfe_rad", number(s.stand_kfe_rad)},
                      {"landing_hfe_rad", number(s.landing_hfe_rad)},
                      {"landing_kfe_rad", number(s.landing_kfe_rad)},
                      {"tuck_hfe_rad", number(s.tuck_hfe_rad)},
                      {"tuck_kfe_rad", number(s.tuck_kfe_rad)},
                      {"tuck_end_fraction", number(s.tuck_end_fraction)},
                      {"drive_limited_tuck",
                       [&](const YAML::Node& v) { s.drive_limited_tuck = v.as<bool>(); }},
                      {"extend_start_fraction", number(s.extend_start_fraction)},
                      {"extend_end_fraction", number(s.extend_end_fraction)},
                      {"wall_extend_start_fraction", number(s.wall_extend_start_fraction)}});
       }},
      {"sampling",
       [&](const YAML::Node& n) {
         readSection(n, "sampling",
                     {{"samples_phase1", integer(s.samples_phase1)},
                      {"samples_phase2", integer(s.samples_phase2)},
                      {"samples_flight", integer(s.samples_flight)},
                      {"output_dt_s", number(s.output_dt_s)},
                      {"knot_dt_s", number(s.knot_dt_s)},
                      {"contact_chain",
                       choice(s.contact_chain, std::map<std::string, ContactChain>{
                                                   {"from_start", ContactChain::FromStart},
                                                   {"from_takeoff", ContactChain::FromTakeoff}})}});
       }},
      {"bounds",
       [&](const YAML::Node& n) {
         readSection(n, "bounds",
                     {{"t1_s", interval(s.t1_s)},
                      {"t2_minus_t1_s", interval(s.t2_minus_t1_s)},
                      {"mid_dx_m", interval(s.mid_dx_m)},
                      {"mid_dz_m", interval(s.mid_dz_m)},
                      {"mid_dpitch_rad", interval(s.mid_dpitch_rad)},
                      {"takeoff_dx_m", interval(s.takeoff_dx_m)},
                      {"takeoff_dz_m", interval(s.takeoff_dz_m)},
                      {"takeoff_dpitch_rad", interval(s.takeoff_dpitch_rad)},
                      {"takeoff_dvx_m_s", interval(s.takeoff_dvx_m_s)},
                      {"takeoff_vz_m_s", interval(s.takeoff_vz_m_s)},
                      {"takeoff_pitch_rate_rad_s", interval(s.takeoff_pitch_rate_rad_s)},
                      {"two_step_takeoff_dpitch_rad", interval(s.two_step_takeoff_dpitch_rad)},
                      {"two_step_takeoff_pitch_rate_rad_s",
                       interval(s.two_step_takeoff_pitch_rate_rad_s)}});
       }},
      {"flip",
       [&](const YAML::Node& n) {
         readSection(n, "flip",
                     {{"t1_s", interval(s.flip_t1_s)},
                      {"t2_minus_t1_s", interval(s.flip_t2_minus_t1_s)},
                      {"takeoff_dpitch_rad", interval(s.flip_takeoff_dpitch_rad)},
                      {"takeoff_pitch_rate_rad_s", interval(s.flip_takeoff_pitch_rate_rad_s)},
                      {"takeoff_vz_m_s", interval(s.flip_takeoff_vz_m_s)},
                      {"hind_knee_clearance_rad", number(s.flip_hind_knee_clearance_rad)},
                      {"front_brake_share", number(s.flip_front_brake_share)},
                      {"initial_guess", [&](const YAML::Node& g) {
                         if (!g.IsSequence())
                           throw YAML::Exception(g.Mark(), "expected a list of 11 numbers or []");
                         s.flip_initial_guess.clear();
                         for (const auto& v : g) s.flip_initial_guess.push_back(v.as<double>());
                       }}});
       }},
      {"cost",
       [&](const YAML::Node& n) {
         readSection(n, "cost",
                     {{"class_weight",
                       [&](const YAML::Node& w) { readSection(w, "cost.class_weight", weights); }},
                      {"energy_weight", number(s.energy_weight)},
                      {"tolerance_dx_m", number(s.tolerance_dx_m)},
                      {"tolerance_height_m", number(s.tolerance_height_m)},
                      {"tolerance_pitch_rad", number(s.tolerance_pitch_rad)},
                      {"landing_pitch_tolerance_rad", number(s.landing_pitch_tolerance_rad)}});
       }},
      {"de", [&](const YAML::Node& n) { readDe(n, s); }},
      {"polish",
       [&](const YAML::Node& n) {
         readSection(
             n, "polish",
             {{"enabled", [&](const YAML::Node& v) { s.polish = v.as<bool>(); }},
              {"solver", choice(s.polish_solver,
                                std::map<std::string, PolishSolver>{
                                    {"sqp", PolishSolver::Sqp}, {"ipopt", PolishSolver::Ipopt}})},
              {"max_iterations", integer(s.polish_max_iterations)},
              {"warm_max_iterations", integer(s.polish_warm_max_iterations)},
              {"tolerance", number(s.polish_tolerance)},
              {"retries", integer(s.polish_retries)},
              {"between_attempts",
               [&](const YAML::Node& v) { s.polish_between_attempts = v.as<bool>(); }},
              {"stall_iterations", integer(s.polish_stall_iterations)},
              {"backoff", number(s.polish_backoff)}});
       }},
  };
  readSection(root, "", top);
  try {
    s.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  return s;
}

}  // namespace

PlannerSettings PlannerSettings::fromYamlString(const std::string& text) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(std::string("planner settings: cannot parse YAML: ") + e.what());
  }
  return parse(root);
}

PlannerSettings PlannerSettings::fromYaml(const std::filesystem::path& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path.string());
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("planner settings " + path.string() + ": " + e.what());
  }
  return parse(root);
}

}  // namespace wj::planner
