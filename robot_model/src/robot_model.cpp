#include "robot_model/robot_model.h"

#include <yaml-cpp/yaml.h>

#include <urdf_parser/urdf_parser.h>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

namespace wj::model {

namespace {

[[noreturn]] void fail(const std::filesystem::path& file, const std::string& what) {
  throw std::runtime_error("robot model " + file.string() + ": " + what);
}

std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("robot model: cannot open " + path.string());
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// FNV-1a, 64 bit: stable across platforms and runs (std::hash is not).
std::uint64_t fnv1a(std::string_view text, std::uint64_t h = 1469598103934665603ULL) {
  for (const unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  return h;
}

Eigen::Isometry3d toIsometry(const urdf::Pose& pose) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  X.linear() =
      Eigen::Quaterniond(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z)
          .normalized()
          .toRotationMatrix();
  return X;
}

Inertia toInertia(const urdf::Link& link) {
  Inertia I;
  if (!link.inertial) return I;
  const auto& in = *link.inertial;
  const Eigen::Isometry3d X = toIsometry(in.origin);
  Eigen::Matrix3d Ic;
  Ic << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  I.mass = in.mass;
  I.com = X.translation();
  I.inertia_com = X.linear() * Ic * X.linear().transpose();
  return I;
}

// The <collision> elements of a link that are boxes, cylinders or spheres (meshes are skipped:
// nothing in the stack reads them).
std::vector<LinkShape> toShapes(const urdf::Link& link) {
  std::vector<LinkShape> shapes;
  for (const auto& c : link.collision_array) {
    if (!c || !c->geometry) continue;
    LinkShape s;
    s.X_LS = toIsometry(c->origin);
    switch (c->geometry->type) {
      case urdf::Geometry::BOX: {
        const auto& b = static_cast<const urdf::Box&>(*c->geometry);
        s.kind = LinkShape::Kind::Box;
        s.size = Eigen::Vector3d(b.dim.x, b.dim.y, b.dim.z);
        break;
      }
      case urdf::Geometry::CYLINDER: {
        const auto& cy = static_cast<const urdf::Cylinder&>(*c->geometry);
        s.kind = LinkShape::Kind::Cylinder;
        s.size = Eigen::Vector3d(cy.radius, cy.radius, cy.length);
        break;
      }
      case urdf::Geometry::SPHERE: {
        const auto& sp = static_cast<const urdf::Sphere&>(*c->geometry);
        s.kind = LinkShape::Kind::Sphere;
        s.size = Eigen::Vector3d::Constant(sp.radius);
        break;
      }
      default:
        continue;
    }
    shapes.push_back(s);
  }
  return shapes;
}

JointKind parseKind(const std::filesystem::path& file, const std::string& suffix) {
  if (suffix == "HAA") return JointKind::HAA;
  if (suffix == "HFE") return JointKind::HFE;
  if (suffix == "KFE") return JointKind::KFE;
  if (suffix == "WHEEL") return JointKind::Wheel;
  fail(file, "joint kind '" + suffix + "' is not one of HAA, HFE, KFE, WHEEL");
}

Leg parseLeg(const std::filesystem::path& file, const std::string& prefix) {
  for (const Leg leg : kLegs)
    if (prefix == toString(leg)) return leg;
  fail(file, "leg '" + prefix + "' is not one of LF, RF, LH, RH");
}

// What an actuator file says about one joint kind: gear ratio and corner speed, and the peak
// torque when the file overrides the URDF's <limit effort> (0 = keep the URDF's).
struct ActuatorEntry {
  double gear_ratio = 0.0;
  double corner_speed_rad_s = 0.0;
  double peak_torque_override_nm = 0.0;
  Braking braking = Braking::Peak;
};

// Largest peak torque an actuator file may set [Nm]: ten times the paper's 42 Nm, far above any
// quasi-direct-drive leg actuator of this size; a larger figure is a typing error.
constexpr double kMaxPeakTorqueOverrideNm = 420.0;

// Reads `peak_torque_override_nm`: a map from joint kind to the peak output torque [Nm] that
// replaces the URDF's <limit effort> for every joint of that kind (what-if robots with stronger
// motors, e.g. models/actuators-57nm.yaml). Fails on an unknown kind, a kind listed twice, a
// value that is not a number in (0, 420] Nm.
void readPeakTorqueOverrides(const std::filesystem::path& file, const YAML::Node& node,
                             std::map<JointKind, double>& overrides) {
  if (!node.IsMap())
    fail(file,
         "peak_torque_override_nm must be a map from joint kind (HAA, HFE, KFE, WHEEL) to Nm");
  for (const auto& kv : node) {
    const JointKind kind = parseKind(file, kv.first.as<std::string>());
    if (overrides.count(kind))
      fail(file,
           "peak_torque_override_nm: joint kind " + std::string(toString(kind)) + " listed twice");
    double value = 0.0;
    try {
      value = kv.second.as<double>();
    } catch (const YAML::Exception&) {
      fail(file, "peak_torque_override_nm." + std::string(toString(kind)) + " must be a number");
    }
    if (!std::isfinite(value) || !(value > 0.0) || value > kMaxPeakTorqueOverrideNm) {
      std::ostringstream msg;
      msg << "peak_torque_override_nm." << toString(kind) << " must lie in (0, "
          << kMaxPeakTorqueOverrideNm << "] Nm, got " << value;
      fail(file, msg.str());
    }
    overrides[kind] = value;
  }
}

// Reads the actuator table: a map from joint kind to {gear ratio, corner speed, peak torque
// override}. Fails on unknown or missing keys, and on a joint kind listed twice or not at all.
std::map<JointKind, ActuatorEntry> loadActuatorTable(const std::filesystem::path& file) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(file.string());
  } catch (const std::exception& e) {
    fail(file, std::string("cannot parse YAML: ") + e.what());
  }
  if (!root.IsMap()) fail(file, "expected a map with actuator_types");
  for (const auto& kv : root) {
    const auto key = kv.first.as<std::string>();
    if (key != "actuator_types" && key != "peak_torque_override_nm")
      fail(file, "unknown key '" + key + "' (allowed: actuator_types, peak_torque_override_nm)");
  }
  if (!root["actuator_types"] || !root["actuator_types"].IsMap())
    fail(file, "missing map 'actuator_types'");
  std::map<JointKind, ActuatorEntry> table;
  for (const auto& type : root["actuator_types"]) {
    const auto type_name = type.first.as<std::string>();
    const YAML::Node& node = type.second;
    const std::set<std::string> allowed = {"joint_kinds", "gear_ratio", "corner_speed_rad_s",
                                           "braking"};
    for (const auto& kv : node) {
      const auto key = kv.first.as<std::string>();
      if (!allowed.count(key))
        fail(file, "actuator_types." + type_name + ": unknown key '" + key +
                       "' (allowed: joint_kinds, gear_ratio, corner_speed_rad_s, braking)");
    }
    for (const auto& key : allowed)
      if (!node[key]) fail(file, "actuator_types." + type_name + ": missing key '" + key + "'");
    const double gear = node["gear_ratio"].as<double>();
    const double corner = node["corner_speed_rad_s"].as<double>();
    const auto braking_name = node["braking"].as<std::string>();
    if (braking_name != "peak" && braking_name != "envelope")
      fail(file, "actuator_types." + type_name + ".braking: '" + braking_name +
                     "' is not one of peak, envelope");
    const Braking braking = braking_name == "peak" ? Braking::Peak : Braking::Envelope;
    for (const auto& kind_node : node["joint_kinds"]) {
      const JointKind kind = parseKind(file, kind_node.as<std::string>());
      if (table.count(kind))
        fail(file, "joint kind " + std::string(toString(kind)) + " listed in two actuator types");
      table[kind] = {gear, corner, 0.0, braking};
    }
  }
  for (const JointKind kind : kJointKinds)
    if (!table.count(kind))
      fail(file, "joint kind " + std::string(toString(kind)) + " has no actuator type");
  if (const YAML::Node overrides_node = root["peak_torque_override_nm"]) {
    std::map<JointKind, double> overrides;
    readPeakTorqueOverrides(file, overrides_node, overrides);
    for (const auto& [kind, nm] : overrides) table[kind].peak_torque_override_nm = nm;
  }
  return table;
}

Eigen::Isometry3d jointMotion(const JointSpec& j, double q) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::AngleAxisd(q, j.axis).toRotationMatrix();
  return X;
}

}  // namespace

std::string_view toString(Leg leg) {
  switch (leg) {
    case Leg::LF:
      return "LF";
    case Leg::RF:
      return "RF";
    case Leg::LH:
      return "LH";
    case Leg::RH:
      return "RH";
  }
  return "?";
}

std::string_view toString(JointKind kind) {
  switch (kind) {
    case JointKind::HAA:
      return "HAA";
    case JointKind::HFE:
      return "HFE";
    case JointKind::KFE:
      return "KFE";
    case JointKind::Wheel:
      return "WHEEL";
  }
  return "?";
}

std::filesystem::path RobotModel::defaultModelsDir() {
  if (const char* env = std::getenv("WJ_MODELS_DIR"); env && *env) return env;
  const auto has_model = [](const std::filesystem::path& dir) {
    std::error_code ec;
    return std::filesystem::exists(dir / "wheeljump.urdf", ec);
  };
  // An installed binary (<prefix>/bin/x) finds <prefix>/share/wheeljump/models next to it, also
  // when the tree was unpacked somewhere else (dpkg --root, a staging directory).
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto beside = exe.parent_path().parent_path() / "share" / "wheeljump" / "models";
    if (has_model(beside)) return beside;
  }
  // A binary in the build tree reads the source tree, so that edits to models/ apply at once.
  if (has_model(WJ_SOURCE_MODELS_DIR)) return WJ_SOURCE_MODELS_DIR;
  return WJ_INSTALLED_MODELS_DIR;
}

RobotModel RobotModel::loadDefault(const std::filesystem::path& actuators_file) {
  const auto dir = defaultModelsDir();
  if (actuators_file.empty())
    throw std::invalid_argument("robot model: the actuator file name is empty (default: " +
                                std::string(kDefaultActuatorsFile) + ")");
  const std::filesystem::path actuators =
      actuators_file.is_absolute() ? actuators_file : dir / actuators_file;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(actuators, ec))
    throw std::invalid_argument("robot model: actuator file '" + actuators_file.string() +
                                "' not found (looked for " + actuators.string() +
                                "; a relative name is read from the models folder " + dir.string() +
                                ")");
  return load(dir / "wheeljump.urdf", actuators);
}

RobotModel RobotModel::load(const std::filesystem::path& urdf_path,
                            const std::filesystem::path& actuators_yaml) {
  const std::string xml = readFile(urdf_path);
  const urdf::ModelInterfaceSharedPtr urdf_model = urdf::parseURDF(xml);
  if (!urdf_model) fail(urdf_path, "urdfdom could not parse the file");
  const auto actuator_table = loadActuatorTable(actuators_yaml);

  RobotModel m;
  m.name_ = urdf_model->getName();
  m.content_hash_ = fnv1a(readFile(actuators_yaml), fnv1a(xml));

  const urdf::LinkConstSharedPtr root = urdf_model->getRoot();
  if (!root) fail(urdf_path, "no root link");
  m.links_.push_back({root->name, toInertia(*root), -1, toShapes(*root)});
  for (const auto& c : root->collision_array)
    if (c && c->geometry && c->geometry->type == urdf::Geometry::BOX) {
      const auto& box = static_cast<const urdf::Box&>(*c->geometry);
      m.base_box_size_ = Eigen::Vector3d(box.dim.x, box.dim.y, box.dim.z);
    }
  if (m.base_box_size_.minCoeff() <= 0.0) fail(urdf_path, "base link needs a box collision");

  // Walk the tree depth-first from the root; every non-fixed joint must be LEG_KIND.
  m.joints_.resize(kNumJoints);
  std::vector<bool> seen(kNumJoints, false);
  std::vector<std::pair<urdf::LinkConstSharedPtr, int>> stack = {{root, 0}};
  while (!stack.empty()) {
    const auto [link, link_index] = stack.back();
    stack.pop_back();
    for (const auto& uj : link->child_joints) {
      if (uj->type != urdf::Joint::REVOLUTE && uj->type != urdf::Joint::CONTINUOUS)
        fail(urdf_path, "joint '" + uj->name + "' must be revolute or continuous");
      const auto us = uj->name.find('_');
      if (us == std::string::npos)
        fail(urdf_path, "joint '" + uj->name + "' is not named LEG_KIND (e.g. LF_HFE)");
      const Leg leg = parseLeg(urdf_path, uj->name.substr(0, us));
      const JointKind kind = parseKind(urdf_path, uj->name.substr(us + 1));
      const int index = jointIndex(leg, kind);
      if (seen[index]) fail(urdf_path, "joint '" + uj->name + "' appears twice");
      seen[index] = true;

      JointSpec& j = m.joints_[index];
      j.name = uj->name;
      j.leg = leg;
      j.kind = kind;
      j.parent_link = link_index;
      j.X_PJ = toIsometry(uj->parent_to_joint_origin_transform);
      j.axis = Eigen::Vector3d(uj->axis.x, uj->axis.y, uj->axis.z);
      if (std::abs(j.axis.norm() - 1.0) > 1e-9) fail(urdf_path, uj->name + ": axis is not unit");
      j.continuous = uj->type == urdf::Joint::CONTINUOUS;
      if (!uj->limits) fail(urdf_path, uj->name + ": missing <limit effort velocity>");
      j.lower_rad = j.continuous ? -std::numeric_limits<double>::infinity() : uj->limits->lower;
      j.upper_rad = j.continuous ? std::numeric_limits<double>::infinity() : uj->limits->upper;
      if (!j.continuous && !(j.lower_rad < j.upper_rad))
        fail(urdf_path, uj->name + ": lower limit must be below upper limit");
      const ActuatorEntry& entry = actuator_table.at(kind);
      const double peak =
          entry.peak_torque_override_nm > 0.0 ? entry.peak_torque_override_nm : uj->limits->effort;
      j.actuator = ActuatorEnvelope{peak, entry.corner_speed_rad_s, uj->limits->velocity,
                                    entry.gear_ratio, entry.braking};
      try {
        j.actuator.validate(j.name);
      } catch (const std::invalid_argument& e) {
        fail(entry.peak_torque_override_nm > 0.0 ? actuators_yaml : urdf_path, e.what());
      }

      const urdf::LinkConstSharedPtr child = urdf_model->getLink(uj->child_link_name);
      if (!child) fail(urdf_path, uj->name + ": child link missing");
      j.child_link = static_cast<int>(m.links_.size());
      m.links_.push_back({child->name, toInertia(*child), index, toShapes(*child)});
      if (kind == JointKind::Wheel) {
        for (const auto& c : child->collision_array)
          if (c && c->geometry && c->geometry->type == urdf::Geometry::CYLINDER) {
            const auto& cyl = static_cast<const urdf::Cylinder&>(*c->geometry);
            if (m.wheel_radius_ > 0.0 && std::abs(m.wheel_radius_ - cyl.radius) > 1e-12)
              fail(urdf_path, "wheels must all have the same radius");
            m.wheel_radius_ = cyl.radius;
            m.wheel_width_ = cyl.length;
          }
      }
      stack.emplace_back(child, j.child_link);
    }
  }
  for (int i = 0; i < kNumJoints; ++i)
    if (!seen[i])
      fail(urdf_path, "missing joint " + std::string(toString(kLegs[i / kJointsPerLeg])) + "_" +
                          std::string(toString(kJointKinds[i % kJointsPerLeg])));
  if (!(m.wheel_radius_ > 0.0)) fail(urdf_path, "wheel links need a cylinder collision");

  // Each leg must be a chain base -> HAA -> HFE -> KFE -> WHEEL with parallel HFE/KFE/WHEEL
  // axes along y: the planar planner relies on it.
  for (const Leg leg : kLegs) {
    const JointSpec& haa = m.joint(leg, JointKind::HAA);
    const JointSpec& hfe = m.joint(leg, JointKind::HFE);
    const JointSpec& kfe = m.joint(leg, JointKind::KFE);
    const JointSpec& wheel = m.joint(leg, JointKind::Wheel);
    if (haa.parent_link != 0 || hfe.parent_link != haa.child_link ||
        kfe.parent_link != hfe.child_link || wheel.parent_link != kfe.child_link)
      fail(urdf_path, "leg " + std::string(toString(leg)) + " is not a HAA-HFE-KFE-WHEEL chain");
    for (const JointSpec* j : {&hfe, &kfe, &wheel})
      if (!j->axis.isApprox(Eigen::Vector3d::UnitY()) || !j->X_PJ.linear().isIdentity(1e-12))
        fail(urdf_path, j->name + ": sagittal joints need axis 0 1 0 and no rotation");
    if (!haa.axis.isApprox(Eigen::Vector3d::UnitX())) fail(urdf_path, haa.name + ": axis 1 0 0");
    LegGeometry& g = m.legs_[static_cast<int>(leg)];
    g.p_BH = haa.X_PJ.translation();
    g.p_HT = hfe.X_PJ.translation();
    g.thigh_length = kfe.X_PJ.translation().norm();
    g.shank_length = std::abs(wheel.X_PJ.translation().z());
    g.wheel_lateral_offset = wheel.X_PJ.translation().y();
    if (std::abs(kfe.X_PJ.translation().x()) > 1e-12 ||
        std::abs(kfe.X_PJ.translation().y()) > 1e-12 ||
        std::abs(wheel.X_PJ.translation().x()) > 1e-12)
      fail(urdf_path, "leg " + std::string(toString(leg)) + ": thigh and shank must hang along -z");
  }

  for (const auto& link : m.links_) m.total_mass_ += link.inertia.mass;
  return m;
}

RobotModel RobotModel::withPeakTorque(JointKind kind, double peak_torque_nm) const {
  if (!std::isfinite(peak_torque_nm) || !(peak_torque_nm > 0.0) ||
      peak_torque_nm > kMaxPeakTorqueOverrideNm) {
    std::ostringstream msg;
    msg << "RobotModel::withPeakTorque: the peak torque of " << toString(kind)
        << " must lie in (0, " << kMaxPeakTorqueOverrideNm << "] Nm, got " << peak_torque_nm;
    throw std::invalid_argument(msg.str());
  }
  RobotModel m = *this;
  for (JointSpec& j : m.joints_)
    if (j.kind == kind) j.actuator.peak_torque_nm = peak_torque_nm;
  std::ostringstream tag;
  tag.precision(17);
  tag << "peak_torque " << toString(kind) << " " << peak_torque_nm;
  m.content_hash_ = fnv1a(tag.str(), content_hash_);
  return m;
}

std::vector<Eigen::Isometry3d> RobotModel::calcLinkPoses(const Eigen::VectorXd& q) const {
  std::vector<Eigen::Isometry3d> X_BL;
  calcLinkPoses(q, X_BL);
  return X_BL;
}

void RobotModel::calcLinkPoses(const Eigen::VectorXd& q,
                               std::vector<Eigen::Isometry3d>& X_BL) const {
  if (q.size() != kNumJoints)
    throw std::invalid_argument("calcLinkPoses: q must have 16 entries, got " +
                                std::to_string(q.size()));
  X_BL.resize(links_.size());
  X_BL[0] = Eigen::Isometry3d::Identity();
  // Links were appended parent-before-child, so one forward sweep suffices.
  for (std::size_t i = 1; i < links_.size(); ++i) {
    const JointSpec& j = joints_[links_[i].parent_joint];
    const int qi = jointIndex(j.leg, j.kind);
    X_BL[i] = X_BL[j.parent_link] * j.X_PJ * jointMotion(j, q[qi]);
  }
}

Inertia RobotModel::calcCompositeInertia(const Eigen::VectorXd& q) const {
  const auto X_BL = calcLinkPoses(q);
  Inertia total;
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < links_.size(); ++i) {
    total.mass += links_[i].inertia.mass;
    first_moment += links_[i].inertia.mass * (X_BL[i] * links_[i].inertia.com);
  }
  total.com = first_moment / total.mass;
  for (std::size_t i = 0; i < links_.size(); ++i) {
    const Inertia& li = links_[i].inertia;
    const Eigen::Matrix3d R = X_BL[i].linear();
    const Eigen::Vector3d d = X_BL[i] * li.com - total.com;
    total.inertia_com +=
        R * li.inertia_com * R.transpose() +
        li.mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  }
  return total;
}

}  // namespace wj::model
