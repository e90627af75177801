#pragma once
/// @file Settings of the state estimator (docs/estimator.md): noise of the process and of the
/// measurements, the innovation gate and the divergence thresholds. Plain data with documented
/// defaults, tuned on the Simbody robot with its default sensor noise.

#include <filesystem>
#include <string>
#include <string_view>

namespace wj::estimation {

/// See the file comment. Standard deviations are of independent Gaussian noise per axis.
struct EstimatorSettings {
  // Process noise -----------------------------------------------------------------------------
  /// White acceleration noise density driving the velocity: accelerometer noise, orientation
  /// error times g, and the model error of a rigid base [m/s^2/sqrt(Hz)], > 0.
  double accel_noise_density = 0.3;
  /// White velocity noise density driving the position (model error) [m/s/sqrt(Hz)], >= 0.
  double position_noise_density = 0.005;

  // Measurements ------------------------------------------------------------------------------
  /// Base velocity implied by one rolling wheel's kinematics: joint and gyro noise through the
  /// lever arms, the wheel's Hertz sink, small slip [m/s], > 0.
  double wheel_velocity_std_m_s = 0.05;
  /// Base height implied by one wheel on the ground [m], > 0.
  double wheel_height_std_m = 0.01;
  /// Height of the flat ground the wheels stand on, in W [m] (setGroundHeight() changes it).
  double ground_height_m = 0.0;

  // Initial covariance (reset()) --------------------------------------------------------------
  double initial_position_std_m = 0.01;    ///< [m], > 0
  double initial_velocity_std_m_s = 0.05;  ///< [m/s], > 0

  // Outliers and divergence -------------------------------------------------------------------
  /// A wheel's velocity measurement is rejected (slip, wrong contact flag) when its squared
  /// Mahalanobis distance (3 dof) exceeds this [-], > 0. 30 is far beyond chi2(3) at 1e-6.
  double velocity_gate_chi2 = 30.0;
  /// A wheel's height measurement is rejected when its squared Mahalanobis distance (1 dof)
  /// exceeds this [-], > 0.
  double height_gate_chi2 = 30.0;
  /// Diverged when, for this many consecutive updates with a wheel in contact, every wheel's
  /// velocity measurement was rejected [updates], >= 1 (50 = 50 ms at 1 kHz).
  int max_consecutive_rejections = 50;
  /// Diverged when the velocity standard deviation of any axis exceeds this [m/s], > 0.
  double max_velocity_std_m_s = 2.0;
  /// Diverged when the estimated speed exceeds this [m/s], > 0.
  double max_speed_m_s = 15.0;
  /// Gravity along -z of W [m/s^2], > 0.
  double gravity_m_s2 = 9.81;

  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

/// Reads EstimatorSettings from YAML text (a map with every field above as a key; layout in
/// docs/estimator.md). Missing or unknown keys and out-of-range values are errors: throws
/// std::runtime_error naming `origin` and the key.
EstimatorSettings parseEstimatorSettings(std::string_view yaml_text,
                                         const std::string& origin = "<text>");
/// Same as parseEstimatorSettings() from a file.
EstimatorSettings loadEstimatorSettings(const std::filesystem::path& yaml_file);

}  // namespace wj::estimation
