#pragma once
/// @file How the simulated robot differs from the model that the planner, the NMPC and the
/// estimator assume (issue 18): a payload, link masses, friction, drive strength and speed,
/// bus latency, IMU biases, where the wall really is and the take-off ground. Only the
/// simulation is perturbed. Plain data, nominal by default; parsePlantSettings() reads the
/// strict YAML of `--plant FILE` (every key optional, unknown keys refused). Simbody-free and
/// C++17-compatible: the Simbody translation unit includes it.

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <string_view>

#include "robot_model/robot_model.h"

namespace wj::sim {

/// A rigid mass fixed to the base.
struct Payload {
  double mass_kg = 0.0;  ///< [kg], 0 = none
  Eigen::Vector3d offset_m =
      Eigen::Vector3d::Zero();  ///< its centre from the base origin, in B [m]
};

/// See the file comment. Ranges (validate()) in brackets.
struct PlantSettings {
  Payload payload;               ///< mass [0, 10] kg, offset within +-1 m per axis
  double link_mass_scale = 1.0;  ///< every link's mass and inertia [0.5, 1.5]
  /// Wheel-ground Coulomb (dynamic) coefficient [0.1, 2]; the static coefficient keeps the
  /// nominal ratio mu_s / mu_d of the contact settings (0.9 / 0.7).
  double friction = 0.7;
  double torque_scale = 1.0;        ///< every drive's peak torque [0.1, 2]
  double corner_speed_scale = 1.0;  ///< every drive's corner (and no-load) speed [0.1, 2]
  double motor_latency_s = 0.0;     ///< command written -> torque applied [0, 0.05] s
  Eigen::Vector3d imu_gyro_bias_rad_s = Eigen::Vector3d::Zero();  ///< [-0.5, 0.5] per axis
  Eigen::Vector3d imu_accel_bias_m_s2 = Eigen::Vector3d::Zero();  ///< [-2, 2] per axis
  /// Where the obstacles really are along x against where the configuration says [-1, 1] m
  /// (positive: farther). The range sensor measures the real obstacles.
  double wall_position_error_m = 0.0;
  /// Constant error of every range reading (the forward range sensor's bias) [-1, 1] m. A wall
  /// error the sensor does not see: range_bias_m = -wall_position_error_m.
  double range_bias_m = 0.0;
  /// Height of the ground the robot starts on and takes off from above the ground beyond the
  /// obstacles (the landing side), [-0.2, 0.2] m; without obstacles the whole ground.
  double ground_height_m = 0.0;

  /// True when nothing differs from the model.
  bool nominal() const;
  /// Throws std::invalid_argument naming the key and its range when a value is out of range
  /// or not finite.
  void validate() const;
};

/// Parses the YAML of a plant file (every key optional); `origin` names it in errors. Throws
/// std::runtime_error on unknown keys or wrong types, std::invalid_argument on bad values.
PlantSettings parsePlantSettings(std::string_view yaml_text, const std::string& origin = "<text>");
/// Reads and parses a file.
PlantSettings loadPlantSettings(const std::filesystem::path& yaml_file);
/// The plant as YAML that parsePlantSettings() reads back to the same values (a campaign's
/// failures are replayed from it).
std::string toYaml(const PlantSettings& plant);

/// Mass properties of a link with every mass and inertia scaled by `scale`.
model::Inertia scaleInertia(const model::Inertia& link, double scale);
/// Mass properties of `body` with a point mass `payload` rigidly added (parallel-axis sum).
model::Inertia addPointMass(const model::Inertia& body, const Payload& payload);
/// An envelope with its peak torque scaled by `torque_scale` and its corner and no-load speeds
/// by `speed_scale`.
model::ActuatorEnvelope scaleEnvelope(const model::ActuatorEnvelope& envelope, double torque_scale,
                                      double speed_scale);

}  // namespace wj::sim
