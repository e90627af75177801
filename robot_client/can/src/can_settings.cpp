#include "can/can_settings.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <set>
#include <sstream>
#include <stdexcept>

namespace wj::can {
namespace {

using model::JointKind;
using model::kJointsPerLeg;
using model::kNumJoints;
using model::kNumLegs;

std::string jointName(int j) {
  return std::string(model::toString(model::kLegs[j / kJointsPerLeg])) + "_" +
         std::string(model::toString(model::kJointKinds[j % kJointsPerLeg]));
}

// Strict YAML access: every key required, unknown keys refused.
class Reader {
 public:
  explicit Reader(std::string origin) : origin_(std::move(origin)) {}

  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw std::runtime_error(origin_ + ": " + (path.empty() ? "" : path + ": ") + what);
  }

  void expectKeys(const YAML::Node& node, const std::string& path,
                  std::initializer_list<const char*> keys) const {
    if (!node.IsMap()) fail(path, "expected a map");
    std::set<std::string> allowed(keys.begin(), keys.end());
    std::string list;
    for (const char* k : keys) list += std::string(list.empty() ? "" : ", ") + k;
    for (const auto& kv : node) {
      const auto key = kv.first.as<std::string>();
      if (!allowed.count(key)) fail(path, "unknown key '" + key + "' (allowed: " + list + ")");
    }
    for (const char* k : keys)
      if (!node[k]) fail(path, std::string("missing key '") + k + "'");
  }

  template <typename T>
  T get(const YAML::Node& node, const std::string& path, const char* key) const {
    try {
      return node[key].as<T>();
    } catch (const YAML::Exception&) {
      fail(path.empty() ? key : path + "." + key, "has the wrong type");
    }
  }

 private:
  std::string origin_;
};

MitLimits readLimits(const Reader& r, const YAML::Node& n, const std::string& path) {
  r.expectKeys(n, path,
               {"p_min", "p_max", "v_min", "v_max", "kp_min", "kp_max", "kd_min", "kd_max", "t_min",
                "t_max"});
  MitLimits l;
  l.p_min = r.get<double>(n, path, "p_min");
  l.p_max = r.get<double>(n, path, "p_max");
  l.v_min = r.get<double>(n, path, "v_min");
  l.v_max = r.get<double>(n, path, "v_max");
  l.kp_min = r.get<double>(n, path, "kp_min");
  l.kp_max = r.get<double>(n, path, "kp_max");
  l.kd_min = r.get<double>(n, path, "kd_min");
  l.kd_max = r.get<double>(n, path, "kd_max");
  l.t_min = r.get<double>(n, path, "t_min");
  l.t_max = r.get<double>(n, path, "t_max");
  return l;
}

}  // namespace

std::array<MotorMapEntry, kNumJoints> CanRobotSettings::defaultMotors() {
  std::array<MotorMapEntry, kNumJoints> m{};
  for (int j = 0; j < kNumJoints; ++j)
    m[j].can_id = static_cast<std::uint32_t>(j % kJointsPerLeg + 1);
  return m;
}

void CanRobotSettings::validate() const {
  const auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (!(control_period_s > 0.0 && control_period_s <= 0.1))
    bad("CanRobotSettings.control_period_s must lie in (0, 0.1] s, got " +
        std::to_string(control_period_s));
  if (host_can_id > kMaxStandardId)
    bad("CanRobotSettings.host_can_id must lie in [0, 2047], got " + std::to_string(host_can_id));
  if (reply_timeout_periods < 1 || reply_timeout_periods > 1000)
    bad("CanRobotSettings.reply_timeout_periods must lie in [1, 1000], got " +
        std::to_string(reply_timeout_periods));
  std::set<std::string> names;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const std::string& n = interfaces[leg];
    if (n.empty() || n.size() > 15)
      bad("CanRobotSettings.interfaces[" + std::to_string(leg) +
          "] must have 1 to 15 characters, got '" + n + "'");
    if (!names.insert(n).second)
      bad("CanRobotSettings.interfaces: '" + n + "' is used by two legs (one bus per leg)");
  }
  for (int k = 0; k < kJointsPerLeg; ++k) {
    try {
      limits[k].validate();
    } catch (const std::invalid_argument& e) {
      bad("CanRobotSettings.limits[" + std::string(model::toString(model::kJointKinds[k])) +
          "]: " + e.what());
    }
  }
  for (int j = 0; j < kNumJoints; ++j) {
    const MotorMapEntry& m = motors[j];
    const std::string field = "CanRobotSettings.motors[" + jointName(j) + "]";
    if (m.can_id < 1 || m.can_id > 0xFF)
      bad(field + ".can_id must lie in [1, 255], got " + std::to_string(m.can_id));
    if (m.can_id == host_can_id)
      bad(field + ".can_id must differ from host_can_id " + std::to_string(host_can_id));
    if (m.direction != 1.0 && m.direction != -1.0)
      bad(field + ".direction must be +1 or -1, got " + std::to_string(m.direction));
    if (!std::isfinite(m.offset_rad))
      bad(field + ".offset_rad must be finite, got " + std::to_string(m.offset_rad));
    const int leg0 = j - j % kJointsPerLeg;
    for (int i = leg0; i < j; ++i)
      if (motors[i].can_id == m.can_id)
        bad(field + ".can_id " + std::to_string(m.can_id) + " is also used by " + jointName(i) +
            " on the same bus");
  }
}

void CanRobotSettings::validateAgainst(const model::RobotModel& model) const {
  validate();
  for (int j = 0; j < kNumJoints; ++j) {
    const model::JointSpec& spec = model.joints()[j];
    const MitLimits& l = limitsOf(j);
    const std::string field =
        "CanRobotSettings.limits[" + std::string(model::toString(spec.kind)) + "] for " + spec.name;
    const double peak = spec.actuator.peak_torque_nm;
    const double speed = spec.actuator.no_load_speed_rad_s;
    if (l.t_min > -peak || l.t_max < peak)
      throw std::invalid_argument(field + ": torque range [" + std::to_string(l.t_min) + ", " +
                                  std::to_string(l.t_max) + "] Nm must cover the peak torque +-" +
                                  std::to_string(peak) + " Nm");
    if (l.v_min > -speed || l.v_max < speed)
      throw std::invalid_argument(
          field + ": velocity range [" + std::to_string(l.v_min) + ", " + std::to_string(l.v_max) +
          "] rad/s must cover the no-load speed +-" + std::to_string(speed) + " rad/s");
    if (spec.continuous) continue;
    const MotorMapEntry& m = motors[j];
    for (const double q : {spec.lower_rad, spec.upper_rad}) {
      const double p = m.direction * (q - m.offset_rad);
      if (p < l.p_min || p > l.p_max)
        throw std::invalid_argument(field + ": joint limit " + std::to_string(q) +
                                    " rad maps to motor position " + std::to_string(p) +
                                    " rad, outside [" + std::to_string(l.p_min) + ", " +
                                    std::to_string(l.p_max) + "] (check offset_rad)");
    }
  }
}

CanRobotSettings parseCanRobotSettings(std::string_view yaml_text, const std::string& origin) {
  const Reader r(origin);
  YAML::Node root;
  try {
    root = YAML::Load(std::string(yaml_text));
  } catch (const YAML::Exception& e) {
    r.fail("", std::string("cannot parse YAML: ") + e.what());
  }
  r.expectKeys(root, "",
               {"control_period_s", "interfaces", "host_can_id", "reply_timeout_periods", "limits",
                "motors"});
  CanRobotSettings s;
  s.control_period_s = r.get<double>(root, "", "control_period_s");
  s.host_can_id = r.get<std::uint32_t>(root, "", "host_can_id");
  s.reply_timeout_periods = r.get<int>(root, "", "reply_timeout_periods");

  const YAML::Node ifaces = root["interfaces"];
  r.expectKeys(ifaces, "interfaces", {"LF", "RF", "LH", "RH"});
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const std::string name(model::toString(model::kLegs[leg]));
    s.interfaces[leg] = r.get<std::string>(ifaces, "interfaces", name.c_str());
  }

  const YAML::Node limits = root["limits"];
  r.expectKeys(limits, "limits", {"HAA", "HFE", "KFE", "WHEEL"});
  for (int k = 0; k < kJointsPerLeg; ++k) {
    const std::string name(model::toString(model::kJointKinds[k]));
    s.limits[k] = readLimits(r, limits[name], "limits." + name);
  }

  const YAML::Node motors = root["motors"];
  if (!motors.IsMap()) r.fail("motors", "expected a map");
  std::set<std::string> names;
  for (int j = 0; j < kNumJoints; ++j) names.insert(jointName(j));
  for (const auto& kv : motors) {
    const auto key = kv.first.as<std::string>();
    if (!names.count(key))
      r.fail("motors", "unknown key '" + key + "' (allowed: joint names such as LF_HAA)");
  }
  for (int j = 0; j < kNumJoints; ++j) {
    const std::string name = jointName(j);
    const std::string path = "motors." + name;
    if (!motors[name]) r.fail("motors", "missing key '" + name + "'");
    const YAML::Node m = motors[name];
    r.expectKeys(m, path, {"can_id", "direction", "offset_rad"});
    s.motors[j].can_id = r.get<std::uint32_t>(m, path, "can_id");
    s.motors[j].direction = r.get<double>(m, path, "direction");
    s.motors[j].offset_rad = r.get<double>(m, path, "offset_rad");
  }
  s.validate();
  return s;
}

CanRobotSettings loadCanRobotSettings(const std::filesystem::path& yaml_file) {
  std::ifstream in(yaml_file);
  if (!in) throw std::runtime_error(yaml_file.string() + ": cannot open the file");
  std::stringstream text;
  text << in.rdbuf();
  return parseCanRobotSettings(text.str(), yaml_file.string());
}

std::filesystem::path defaultCanConfigFile() {
  if (const char* dir = std::getenv("WJ_CONFIG_DIR"); dir != nullptr && *dir != '\0')
    return std::filesystem::path(dir) / "can.yaml";
  return std::filesystem::path(WJ_CAN_CONFIG_DIR) / "can.yaml";
}

}  // namespace wj::can
