#pragma once
/// @file The robot description, read once from the URDF (urdfdom) and the actuator table.
/// Every component takes its numbers from here; no figure of the robot is repeated in code.

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "robot_model/actuator.h"

namespace wj::model {

/// Legs, in the order used by every joint vector of the stack.
enum class Leg : std::uint8_t { LF = 0, RF = 1, LH = 2, RH = 3 };
/// Joints of one leg, in order from the body to the wheel.
enum class JointKind : std::uint8_t { HAA = 0, HFE = 1, KFE = 2, Wheel = 3 };

inline constexpr int kNumLegs = 4;
inline constexpr int kJointsPerLeg = 4;
inline constexpr int kNumJoints = kNumLegs * kJointsPerLeg;  ///< 16 actuated joints
inline constexpr std::array<Leg, kNumLegs> kLegs = {Leg::LF, Leg::RF, Leg::LH, Leg::RH};
inline constexpr std::array<JointKind, kJointsPerLeg> kJointKinds = {
    JointKind::HAA, JointKind::HFE, JointKind::KFE, JointKind::Wheel};

/// "LF", "RF", "LH", "RH".
std::string_view toString(Leg leg);
/// "HAA", "HFE", "KFE", "WHEEL" (as in the URDF joint names).
std::string_view toString(JointKind kind);
/// Index of a joint in the stack's 16-vectors: leg-major, kind-minor.
constexpr int jointIndex(Leg leg, JointKind kind) {
  return static_cast<int>(leg) * kJointsPerLeg + static_cast<int>(kind);
}
/// True for the wheel joint of a leg, by its index in jointIndex() order.
constexpr bool isWheel(int joint) {
  return joint % kJointsPerLeg == static_cast<int>(JointKind::Wheel);
}

/// True for the front legs (LF, RF).
constexpr bool isFront(Leg leg) {
  return leg == Leg::LF || leg == Leg::RF;
}
/// +1 for the left legs, -1 for the right legs (the sign of their y offsets).
constexpr double lateralSign(Leg leg) {
  return (leg == Leg::LF || leg == Leg::LH) ? 1.0 : -1.0;
}

/// Spatial inertia of a rigid body: mass, centre of mass and rotational inertia about the CoM,
/// both expressed in the frame that owns it.
struct Inertia {
  double mass = 0.0;                                      ///< [kg]
  Eigen::Vector3d com = Eigen::Vector3d::Zero();          ///< [m]
  Eigen::Matrix3d inertia_com = Eigen::Matrix3d::Zero();  ///< about the CoM [kg m^2]
};

/// One collision element of a link, as the URDF gives it (drawn by the viewers in viz/).
struct LinkShape {
  enum class Kind : std::uint8_t { Box, Cylinder, Sphere };
  Kind kind = Kind::Box;
  Eigen::Isometry3d X_LS = Eigen::Isometry3d::Identity();  ///< shape frame in the link frame
  /// Box: full side lengths along x, y, z of S; cylinder: (radius, radius, length along z of S);
  /// sphere: (radius, radius, radius) [m].
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
};

/// One link of the tree.
struct LinkSpec {
  std::string name;
  Inertia inertia;                ///< in the link frame
  int parent_joint = -1;          ///< index into joints(), -1 for the base
  std::vector<LinkShape> shapes;  ///< the link's <collision> boxes, cylinders and spheres
};

/// One actuated joint.
struct JointSpec {
  std::string name;  ///< URDF name, e.g. "LF_HFE"
  Leg leg = Leg::LF;
  JointKind kind = JointKind::HAA;
  int parent_link = -1;                                    ///< index into links()
  int child_link = -1;                                     ///< index into links()
  Eigen::Isometry3d X_PJ = Eigen::Isometry3d::Identity();  ///< joint frame in the parent link
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();         ///< unit axis in the joint frame
  bool continuous = false;                                 ///< no position limits (wheels)
  double lower_rad = 0.0;                                  ///< position limit (-inf if continuous)
  double upper_rad = 0.0;                                  ///< position limit (+inf if continuous)
  ActuatorEnvelope actuator;                               ///< torque-speed envelope at the output
};

/// Planar geometry of one leg in its sagittal plane, derived from the URDF.
struct LegGeometry {
  Eigen::Vector3d p_BH = Eigen::Vector3d::Zero();  ///< HAA axis origin in the base frame [m]
  Eigen::Vector3d p_HT = Eigen::Vector3d::Zero();  ///< HFE origin relative to HAA, zero angles [m]
  double thigh_length = 0.0;                       ///< HFE to KFE [m]
  double shank_length = 0.0;                       ///< KFE to wheel axle [m]
  double wheel_lateral_offset = 0.0;  ///< wheel plane offset from the shank, signed y [m]
};

/// Name of the project's actuator file in the models folder (the real robot: every peak torque
/// from the URDF). Others, such as actuators-57nm.yaml, override the peak torque of a joint kind.
inline constexpr const char* kDefaultActuatorsFile = "actuators.yaml";

/// Immutable robot description. Cheap to copy; safe to share between threads.
class RobotModel {
 public:
  /// Reads `urdf` with urdfdom and the actuator table `actuators_yaml`. Throws
  /// std::runtime_error naming the file and the element at fault when the description does not
  /// have the expected structure (4 legs x HAA/HFE/KFE/WHEEL) or a figure is out of range.
  static RobotModel load(const std::filesystem::path& urdf,
                         const std::filesystem::path& actuators_yaml);
  /// The project's robot: models/wheeljump.urdf and an actuator file (models/actuators.yaml by
  /// default; e.g. "actuators-57nm.yaml" for the what-if robot with a 57 Nm knee), from the
  /// folder in the WJ_MODELS_DIR environment variable if set, else defaultModelsDir(). A
  /// relative `actuators_file` is read from that folder, an absolute one as it is. Throws
  /// std::invalid_argument naming the file when it does not exist.
  static RobotModel loadDefault(
      const std::filesystem::path& actuators_file = kDefaultActuatorsFile);
  /// Folder used by loadDefault(), the first that holds wheeljump.urdf of: $WJ_MODELS_DIR;
  /// `<exe>/../share/wheeljump/models` (an installed binary, wherever the tree was unpacked);
  /// the source tree's models/ (a binary in the build tree);
  /// `<install prefix>/share/wheeljump/models`.
  static std::filesystem::path defaultModelsDir();

  /// A copy whose joints of `kind` have the peak torque `peak_torque_nm` (what-if robots, e.g.
  /// the knee-torque sweep of bench_planner; an actuator file's peak_torque_override_nm does
  /// the same from configuration). The content hash changes with it. Throws
  /// std::invalid_argument unless the torque lies in (0, 420] Nm.
  RobotModel withPeakTorque(JointKind kind, double peak_torque_nm) const;

  const std::string& name() const { return name_; }
  const std::vector<LinkSpec>& links() const { return links_; }
  /// The 16 actuated joints, ordered by jointIndex().
  const std::vector<JointSpec>& joints() const { return joints_; }
  const JointSpec& joint(Leg leg, JointKind kind) const { return joints_[jointIndex(leg, kind)]; }
  const LinkSpec& base() const { return links_[0]; }

  double totalMass() const { return total_mass_; }
  double wheelRadius() const { return wheel_radius_; }
  double wheelWidth() const { return wheel_width_; }
  /// Collision box of the base, full side lengths [m].
  const Eigen::Vector3d& baseBoxSize() const { return base_box_size_; }
  const LegGeometry& legGeometry(Leg leg) const { return legs_[static_cast<int>(leg)]; }

  /// Pose of every link in the base frame for joint positions q (16-vector, jointIndex order).
  std::vector<Eigen::Isometry3d> calcLinkPoses(const Eigen::VectorXd& q) const;
  /// The same into `X_BL`, which allocates only if its size is not links().size() (a control
  /// loop keeps it sized).
  void calcLinkPoses(const Eigen::VectorXd& q, std::vector<Eigen::Isometry3d>& X_BL) const;
  /// Whole-robot inertia in the base frame at joint positions q: total mass, CoM and the
  /// rotational inertia about that CoM (parallel-axis sum over all links).
  Inertia calcCompositeInertia(const Eigen::VectorXd& q) const;

  /// Stable 64-bit content hash of the URDF and actuator files, for cache keys.
  std::uint64_t contentHash() const { return content_hash_; }

 private:
  std::string name_;
  std::vector<LinkSpec> links_;
  std::vector<JointSpec> joints_;
  std::array<LegGeometry, kNumLegs> legs_{};
  double total_mass_ = 0.0;
  double wheel_radius_ = 0.0;
  double wheel_width_ = 0.0;
  Eigen::Vector3d base_box_size_ = Eigen::Vector3d::Zero();
  std::uint64_t content_hash_ = 0;
};

}  // namespace wj::model
