#include "robot_client/client_settings.h"

#include <array>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "robot_model/strict_yaml.h"

namespace wj::robot_client {

namespace {

void require(bool ok, const std::string& field, const std::string& range, double value) {
  if (!ok || !std::isfinite(value)) {
    std::ostringstream m;
    m << "robot client settings: " << field << " must be " << range << ", got " << value;
    throw std::invalid_argument(m.str());
  }
}

void inRange(double v, double lo, double hi, const std::string& field) {
  std::ostringstream range;
  range << "in [" << lo << ", " << hi << "]";
  require(v >= lo && v <= hi, field, range.str(), v);
}

// The fastest backward run-up [m/s]: the planner's lowest initial speed (InitialState::validate,
// -1 m/s; a request measured past it is clamped to it, ControlLoop); the backflips planned
// rolling backward start at 0.5-1 m/s (docs/backflip.md).
constexpr double kMaxBackwardRunUp = -kPlannerLowestSpeedMS;

void validateScenario(const ScenarioSettings& s, const std::string& p) {
  inRange(s.stand_s, 0.0, 60.0, p + "stand_s");
  // Negative: rolling backward into the jump (the backflip's run-up, docs/backflip.md); walls
  // stand ahead, so a backward run-up has none.
  inRange(s.run_up_speed_m_s, -kMaxBackwardRunUp, 5.0, p + "run_up_speed_m_s");
  // The plan is requested at the measured speed, within speed_tolerance_m_s of the run-up's,
  // clamped to the planner's lowest (ControlLoop::postPlanRequest).
  if (s.run_up_speed_m_s < 0.0 && s.has_wall)
    throw std::invalid_argument("robot client settings: " + p +
                                "run_up_speed_m_s < 0 (a backward run-up) needs wall.enabled "
                                "false: the walls stand ahead of the robot");
  inRange(s.acceleration_m_s2, 0.1, 5.0, p + "acceleration_m_s2");
  if (s.wall_x_m.empty())
    throw std::invalid_argument("robot client settings: " + p +
                                "wall.x_m must name at least one wall (a number or a list)");
  for (std::size_t i = 0; i < s.wall_x_m.size(); ++i) {
    const std::string key =
        p + "wall.x_m" + (s.wall_x_m.size() > 1 ? "[" + std::to_string(i) + "]" : "");
    inRange(s.wall_x_m[i], 0.5, 1000.0, key);
    // The next wall's run-up starts where the previous jump's landing and roll-on end.
    if (i > 0)
      inRange(s.wall_x_m[i], s.wall_x_m[i - 1] + s.wall_thickness_m + 2.0, 1000.0,
              key + " (beyond the previous wall's far face + 2 m)");
  }
  if (s.wall_x_m.size() > 1 && (s.landsOnWall() || s.after_landing != AfterLanding::RollOn))
    throw std::invalid_argument("robot client settings: " + p +
                                "wall.x_m lists several walls: a course needs after_landing.mode "
                                "roll_on and jumps over walls (not onto a platform)");
  inRange(s.wall_thickness_m, 0.01, 20.0, p + "wall.thickness_m");
  inRange(s.wall_height_m, 0.01, 1.0, p + "wall.height_m");
  inRange(s.takeoff_to_wall_m, 0.3, 3.0, p + "takeoff_to_wall_m");
  inRange(s.takeoff_lead_m, -0.2, 0.2, p + "takeoff_lead_m");
  inRange(s.nmpc_base_height_m, 0.2, 0.45, p + "nmpc_base_height_m");
  if (s.has_takeoff_posture) {
    inRange(s.takeoff_hfe_rad, -0.5, 2.5, p + "takeoff_posture.hfe_rad");
    inRange(s.takeoff_kfe_rad, -2.7, -0.5, p + "takeoff_posture.kfe_rad");
    inRange(s.takeoff_posture_max_offset_rad, 0.001, 0.1, p + "takeoff_posture.max_offset_rad");
  }
  inRange(s.decision_margin_m, 0.0, 10.0, p + "decision_margin_m");
  inRange(s.target_dx_m, -3.0, 5.0, p + "target.dx_m");
  inRange(s.target_com_height_m, 0.1, 1.5, p + "target.com_height_m");
  inRange(s.speed_tolerance_m_s, 0.005, 0.5, p + "speed_tolerance_m_s");
  inRange(s.target_pitch_change_rad, -7.0, 7.0, p + "target.pitch_change_rad");
  inRange(s.plan_timeout_s, 0.05, 60.0, p + "plan_timeout_s");
  inRange(s.duration_s, 1.0, 600.0, p + "duration_s");
  inRange(s.roll_on_speed_m_s, 0.0, 5.0, p + "after_landing.speed_m_s");
  inRange(s.roll_on_s, 0.0, 600.0, p + "after_landing.roll_s");
  inRange(s.edge_margin_m, 0.0, 10.0, p + "after_landing.edge_margin_m");
  if (s.landsOnWall())
    inRange(s.target_com_height_m, s.wall_height_m + 0.05, 1.5,
            p + "target.com_height_m (landing on the wall: CoM above its top)");
  if (s.actuators_file.empty())
    throw std::invalid_argument("robot client settings: " + p +
                                "actuators_file must name a file in the models folder (e.g. "
                                "actuators.yaml)");
  if (s.has_wall && s.run_up_speed_m_s > 0.0) {
    // The run-up must fit before the decision point.
    const double run_up = s.run_up_speed_m_s * s.run_up_speed_m_s / (2.0 * s.acceleration_m_s2);
    const double room = s.wallX(0) - s.takeoff_to_wall_m - s.decision_margin_m;
    require(room > run_up, p + "wall.x_m",
            "beyond the run-up distance + takeoff_to_wall_m + decision_margin_m (" +
                std::to_string(run_up + s.takeoff_to_wall_m + s.decision_margin_m) + " m)",
            s.wallX(0));
  }
}

ScenarioSettings parseScenario(StrictYamlMap m, const std::string& name) {
  ScenarioSettings s;
  s.name = name;
  s.stand_s = m.number("stand_s");
  s.run_up_speed_m_s = m.number("run_up_speed_m_s");
  s.acceleration_m_s2 = m.number("acceleration_m_s2");
  s.speed_tolerance_m_s = m.number("speed_tolerance_m_s");
  StrictYamlMap wall = m.map("wall");
  s.has_wall = wall.flag("enabled");
  if (const YAML::Node x = wall.node("x_m"); x.IsSequence()) {
    s.wall_x_m.clear();
    try {
      for (const YAML::Node& v : x) s.wall_x_m.push_back(v.as<double>());
    } catch (const YAML::Exception&) {
      wall.fail("key '" + name + ".wall.x_m' has the wrong type (a number or a list of numbers)");
    }
  } else {
    s.wall_x_m = {wall.number("x_m")};
  }
  s.wall_thickness_m = wall.number("thickness_m");
  s.wall_height_m = wall.number("height_m");
  wall.finish();
  s.takeoff_to_wall_m = m.number("takeoff_to_wall_m");
  if (m.has("takeoff_lead_m")) s.takeoff_lead_m = m.number("takeoff_lead_m");
  if (m.has("takeoff_posture")) {
    StrictYamlMap tp = m.map("takeoff_posture");
    s.has_takeoff_posture = true;
    s.takeoff_hfe_rad = tp.number("hfe_rad");
    s.takeoff_kfe_rad = tp.number("kfe_rad");
    s.takeoff_posture_max_offset_rad = tp.number("max_offset_rad");
    tp.finish();
  }
  s.nmpc_base_height_m = m.number("nmpc_base_height_m");
  s.decision_margin_m = m.number("decision_margin_m");
  StrictYamlMap target = m.map("target");
  s.target_dx_m = target.number("dx_m");
  s.target_com_height_m = target.number("com_height_m");
  s.target_pitch_change_rad = target.number("pitch_change_rad");
  const std::string event = target.text("event");
  if (event == "apex")
    s.event = planner::TargetEvent::Apex;
  else if (event == "touchdown")
    s.event = planner::TargetEvent::Touchdown;
  else
    target.fail("key '" + name + ".target.event': '" + event + "' is not one of apex, touchdown");
  const std::string mode = target.text("takeoff_mode");
  if (mode == "simultaneous")
    s.mode = planner::TakeoffMode::Simultaneous;
  else if (mode == "two_step")
    s.mode = planner::TakeoffMode::TwoStep;
  else
    target.fail("key '" + name + ".target.takeoff_mode': '" + mode +
                "' is not one of simultaneous, two_step");
  s.accept_closest_approach = target.flag("accept_closest_approach");
  target.finish();
  s.plan_timeout_s = m.number("plan_timeout_s");
  s.duration_s = m.number("duration_s");
  StrictYamlMap after = m.map("after_landing");
  s.after_landing = after.choice("mode", std::array{AfterLanding::Stop, AfterLanding::RollOn});
  s.roll_on_speed_m_s = after.number("speed_m_s");
  s.roll_on_s = after.number("roll_s");
  if (after.has("edge_margin_m")) s.edge_margin_m = after.number("edge_margin_m");
  after.finish();
  if (m.has("actuators_file")) s.actuators_file = m.text("actuators_file");
  m.finish();
  return s;
}

}  // namespace

std::string_view toString(AfterLanding after) {
  switch (after) {
    case AfterLanding::Stop:
      return "stop";
    case AfterLanding::RollOn:
      return "roll_on";
  }
  return "?";
}

const ScenarioSettings& ClientSettings::scenario(std::string_view name) const {
  std::string names;
  for (const ScenarioSettings& s : scenarios) {
    if (s.name == name) return s;
    names += (names.empty() ? "" : ", ") + s.name;
  }
  throw std::invalid_argument("scenario '" + std::string(name) + "' is not one of " + names);
}

void ClientSettings::validate() const {
  inRange(loop.period_s, 1e-4, 0.01, "loop.period_s");
  inRange(loop.mpc_period_s, loop.period_s, 0.1, "loop.mpc_period_s");
  inRange(loop.rt_priority, 1, 99, "loop.rt_priority");
  inRange(loop.cpu, -1, 1023, "loop.cpu");
  inRange(loop.watchdog_timeout_s, 2.0 * loop.period_s, 1.0, "loop.watchdog_timeout_s");
  inRange(loop.telemetry_decimation, 1, 1000, "loop.telemetry_decimation");
  inRange(loop.spin_us, 0.0, 0.9e6 * loop.period_s, "loop.spin_us");
  inRange(safety.max_roll_rad, 0.05, 1.5, "safety.max_roll_rad");
  inRange(safety.max_pitch_rad, 0.05, 1.5, "safety.max_pitch_rad");
  inRange(safety.damping_kd, 0.0, 20.0, "safety.damping_kd");
  inRange(safety.brake_decel_m_s2, 0.2, 8.0, "safety.brake_decel_m_s2");
  inRange(safety.stopped_speed_m_s, 0.001, 1.0, "safety.stopped_speed_m_s");
  inRange(contact.force_threshold_n, 1.0, 500.0, "contact.force_threshold_n");
  inRange(contact.max_wheel_clearance_m, 0.001, 0.2, "contact.max_wheel_clearance_m");
  inRange(contact.max_rise_speed_m_s, 0.05, 5.0, "contact.max_rise_speed_m_s");
  inRange(contact.settle_s, 0.0, 1.0, "contact.settle_s");
  inRange(contact.traction_mu, 0.05, 2.0, "contact.traction_mu");
  try {
    posture_integral.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("robot client settings: nmpc.") + e.what());
  }
  inRange(route.lateral_gain_rad_per_m, 0.0, 5.0, "nmpc.route.lateral_gain_rad_per_m");
  inRange(route.max_heading_offset_rad, 0.0, 0.5, "nmpc.route.max_heading_offset_rad");
  inRange(route.min_speed_m_s, 0.0, 5.0, "nmpc.route.min_speed_m_s");
  inRange(planner.deadline_s, 0.01, 60.0, "planner.deadline_s");
  inRange(planner.retries, 0.0, 5.0, "planner.retries");
  inRange(static_cast<double>(planner.max_evaluations), 0.0, 1e7, "planner.max_evaluations");
  if (planner.tls && planner.tls_root_ca_file.empty())
    throw std::invalid_argument(
        "robot client settings: planner.tls.root_ca_file must name the CA file when "
        "planner.tls.enabled is true");
  if (planner.tls_cert_file.empty() != planner.tls_key_file.empty())
    throw std::invalid_argument(
        "robot client settings: planner.tls.cert_file and planner.tls.key_file go together");
  executor.validate();
  if (scenarios.empty())
    throw std::invalid_argument("robot client settings: scenarios must name at least one scenario");
  for (const ScenarioSettings& s : scenarios) validateScenario(s, "scenarios." + s.name + ".");
}

ClientSettings parseClientSettings(std::string_view yaml_text, const std::string& origin) {
  YAML::Node root_node;
  try {
    root_node = YAML::Load(std::string(yaml_text));
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("robot client settings " + origin +
                             ": cannot parse YAML: " + e.what());
  }
  ClientSettings s;
  StrictYamlMap root(root_node, "", "robot client settings " + origin);
  {
    StrictYamlMap m = root.map("loop");
    s.loop.period_s = m.number("period_s");
    s.loop.mpc_period_s = m.number("mpc_period_s");
    s.loop.rt_priority = m.integer("rt_priority");
    s.loop.lock_memory = m.flag("lock_memory");
    s.loop.cpu = m.integer("cpu");
    s.loop.watchdog_timeout_s = m.number("watchdog_timeout_s");
    s.loop.telemetry_decimation = m.integer("telemetry_decimation");
    s.loop.spin_us = m.number("spin_us");
    m.finish();
  }
  {
    StrictYamlMap m = root.map("safety");
    s.safety.max_roll_rad = m.number("max_roll_rad");
    s.safety.max_pitch_rad = m.number("max_pitch_rad");
    s.safety.damping_kd = m.number("damping_kd");
    s.safety.brake_decel_m_s2 = m.number("brake_decel_m_s2");
    s.safety.stopped_speed_m_s = m.number("stopped_speed_m_s");
    m.finish();
  }
  {
    StrictYamlMap m = root.map("contact");
    s.contact.force_threshold_n = m.number("force_threshold_n");
    s.contact.max_wheel_clearance_m = m.number("max_wheel_clearance_m");
    s.contact.max_rise_speed_m_s = m.number("max_rise_speed_m_s");
    s.contact.settle_s = m.number("settle_s");
    s.contact.traction_mu = m.number("traction_mu");
    m.finish();
  }
  {
    StrictYamlMap m = root.map("planner");
    s.planner.deadline_s = m.number("deadline_s");
    s.planner.max_evaluations = static_cast<std::uint32_t>(m.unsignedInt("max_evaluations"));
    s.planner.seed = m.unsignedInt("seed");
    s.planner.retries = static_cast<int>(std::min<std::uint64_t>(m.unsignedInt("retries"), 1000));
    s.planner.skip_verification = m.flag("skip_verification");
    const std::string format = m.text("trajectory_format");
    using Format = PlannerConnection::Format;
    if (format == "compact_knots")
      s.planner.format = Format::CompactKnots;
    else if (format == "knots")
      s.planner.format = Format::Knots;
    else if (format == "dense")
      s.planner.format = Format::Dense;
    else
      throw std::invalid_argument("robot client settings " + origin +
                                  ": planner.trajectory_format must be 'compact_knots', 'knots' "
                                  "or 'dense', got '" +
                                  format + "'");
    s.planner.round_robin = m.flag("round_robin");
    StrictYamlMap tls = m.map("tls");
    s.planner.tls = tls.flag("enabled");
    s.planner.tls_root_ca_file = tls.text("root_ca_file");
    s.planner.tls_cert_file = tls.text("cert_file");
    s.planner.tls_key_file = tls.text("key_file");
    s.planner.tls_server_name = tls.text("server_name");
    tls.finish();
    m.finish();
  }
  {
    StrictYamlMap m = root.map("nmpc");
    StrictYamlMap pi = m.map("posture_integral");
    nmpc::PostureIntegralSettings& p = s.posture_integral;
    p.gain_n_per_m_s = pi.number("gain_n_per_m_s");
    p.max_force_n = pi.number("max_force_n");
    p.band_m = pi.number("band_m");
    p.max_step_s = pi.number("max_step_s");
    pi.finish();
    s.jump_leg_support = m.flag("jump_leg_support");
    StrictYamlMap route = m.map("route");
    s.route.lateral_gain_rad_per_m = route.number("lateral_gain_rad_per_m");
    s.route.max_heading_offset_rad = route.number("max_heading_offset_rad");
    s.route.min_speed_m_s = route.number("min_speed_m_s");
    route.finish();
    m.finish();
  }
  // The executor's gains are a file of their own, which the planning service's verifier reads
  // too (config/jump_executor.yaml); a relative path is beside this configuration.
  {
    std::filesystem::path file = root.text("executor_file");
    if (file.is_relative()) file = std::filesystem::path(origin).parent_path() / file;
    s.executor_file = file.lexically_normal().string();
    s.executor = sim::loadExecutorSettings(s.executor_file);
  }
  {
    StrictYamlMap m = root.map("scenarios");
    for (const std::string& name : m.keys())
      s.scenarios.push_back(parseScenario(m.map(name), name));
    m.finish();
  }
  root.finish();
  s.validate();
  return s;
}

ClientSettings loadClientSettings(const std::filesystem::path& yaml_file) {
  const std::optional<std::string> text = readSettingsText(yaml_file);
  if (!text) throw std::runtime_error("cannot read robot client settings " + yaml_file.string());
  return parseClientSettings(*text, yaml_file.string());
}

}  // namespace wj::robot_client
