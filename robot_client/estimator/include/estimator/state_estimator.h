#pragma once
/// @file State estimator of the floating base: a linear Kalman filter of the base position and
/// velocity in W, predicted with the IMU's specific force rotated to W plus gravity, corrected
/// by the leg and wheel odometry of every wheel the caller declares in contact (docs/estimator.md
/// has the equations, the assumptions and the measured errors). Orientation and angular rate are
/// taken from the IMU as they are.

#include <Eigen/Geometry>
#include <array>
#include <cstdint>

#include "estimator/estimator_settings.h"
#include "robot_model/robot_interface.h"
#include "robot_model/robot_model.h"

namespace wj::estimation {

/// Why the estimator declared itself diverged.
enum class Divergence : std::uint8_t {
  None,                 ///< healthy
  NonFiniteInput,       ///< NaN or infinity in the IMU, a contact leg's joints or dt
  NonFiniteState,       ///< NaN or infinity in the state or the covariance
  CovarianceBlowUp,     ///< a velocity standard deviation above max_velocity_std_m_s
  InnovationsRejected,  ///< every wheel rejected for max_consecutive_rejections updates
  SpeedLimit,           ///< estimated speed above max_speed_m_s
};

/// "none", "non_finite_input", "non_finite_state", "covariance_blow_up",
/// "innovations_rejected", "speed_limit".
const char* toString(Divergence reason);

/// The estimate after the last update().
struct EstimatedState {
  double t = 0.0;                                            ///< sensor time of the update [s]
  Eigen::Vector3d p_WB = Eigen::Vector3d::Zero();            ///< base origin in W [m]
  Eigen::Vector3d v_WB = Eigen::Vector3d::Zero();            ///< its velocity in W [m/s]
  Eigen::Quaterniond q_WB = Eigen::Quaterniond::Identity();  ///< base orientation (the IMU's)
  Eigen::Vector3d omega_W = Eigen::Vector3d::Zero();         ///< base angular velocity in W
  Eigen::Vector3d omega_B = Eigen::Vector3d::Zero();         ///< the same in B (the gyro)
  /// Variances of [p_WB (3) [m^2], v_WB (3) [m^2/s^2]], the covariance diagonal.
  Eigen::Matrix<double, 6, 1> covariance_diagonal = Eigen::Matrix<double, 6, 1>::Zero();
  /// Per leg: the wheel's velocity measurement was used in the last update.
  std::array<bool, model::kNumLegs> velocity_used{};
  /// Per leg: base velocity in W implied by the wheel's kinematics in the last update (valid
  /// where the leg was in contact) [m/s].
  std::array<Eigen::Vector3d, model::kNumLegs> wheel_velocity_W{};
};

/// See the file comment. Built once from an immutable RobotModel; update() is allocation-free,
/// lock-free and does not throw. One instance per thread.
class StateEstimator {
 public:
  /// Throws std::invalid_argument if the settings are out of range or a leg of `model` is not
  /// a chain base - HAA - HFE - KFE - WHEEL.
  StateEstimator(const model::RobotModel& model, const EstimatorSettings& settings);

  /// Sets the base position `p_WB` [m] and velocity `v_WB` [m/s] in W, the covariance to the
  /// initial one of the settings, and clears the divergence flag.
  void reset(const Eigen::Vector3d& p_WB, const Eigen::Vector3d& v_WB);

  /// One filter step over `dt` [s] (the time since the previous update): prediction with the
  /// IMU, then per wheel with wheel_contact[leg] (leg order LF, RF, LH, RH) a velocity and a
  /// height measurement. Contacts are the caller's belief (contact schedule, jump phase).
  /// dt <= 0 skips the prediction. Once diverged, update() only refreshes orientation and rate.
  void update(const model::SensorData& sensors,
              const std::array<bool, model::kNumLegs>& wheel_contact, double dt);

  /// A measurement of the base position along W's x axis, `x_meas` [m] with standard deviation
  /// `std_m` [m] (e.g. a known wall's x minus the range to it): a Kalman update of the
  /// position, and through the covariance of the velocity. No gate: the caller associates the
  /// measurement. Returns the innovation [m]. Allocation-free; ignored once diverged.
  double correctPositionX(double x_meas, double std_m);

  /// Height of the flat ground under the wheels, in W [m] (e.g. the top of a box landed on).
  void setGroundHeight(double z_m) { ground_height_m_ = z_m; }
  double groundHeight() const { return ground_height_m_; }

  /// The estimate after the last update().
  const EstimatedState& state() const { return state_; }
  /// True once the filter diverged (latched until reset()).
  bool diverged() const { return divergence_ != Divergence::None; }
  /// Why it diverged (None while healthy).
  Divergence divergence() const { return divergence_; }
  /// Wheel velocity measurements rejected by the gate since reset().
  std::uint64_t rejectedMeasurements() const { return rejected_; }
  /// The settings.
  const EstimatorSettings& settings() const { return settings_; }

  /// Wheel centre p_BW [m] and velocity relative to the base, in B [m/s], and the wheel axis in B
  /// (unit) of leg `leg` at the given joint measurements (forward kinematics of the leg chain).
  void calcWheelKinematics(model::Leg leg, const model::JointMeasurements& joints,
                           Eigen::Vector3d& p_BW, Eigen::Vector3d& v_BW_rel,
                           Eigen::Vector3d& axis_B, Eigen::Vector3d& omega_rel_B) const;

 private:
  using Vector6 = Eigen::Matrix<double, 6, 1>;
  using Matrix6 = Eigen::Matrix<double, 6, 6>;

  // Joint frames of one leg: HAA, HFE, KFE, WHEEL.
  struct LegChain {
    std::array<Eigen::Isometry3d, model::kJointsPerLeg> X_PJ;
    std::array<Eigen::Vector3d, model::kJointsPerLeg> axis;
  };

  void predict(const Eigen::Matrix3d& R_WB, const Eigen::Vector3d& accel_B, double dt);
  bool correctVelocity(const Eigen::Vector3d& v_meas);
  void correctHeight(double z_meas);
  void checkHealth();

  EstimatorSettings settings_;
  std::array<LegChain, model::kNumLegs> legs_{};
  double wheel_radius_ = 0.0;
  double ground_height_m_ = 0.0;
  Vector6 x_ = Vector6::Zero();  // [p_WB; v_WB]
  Matrix6 P_ = Matrix6::Zero();
  EstimatedState state_;
  Divergence divergence_ = Divergence::None;
  int consecutive_rejections_ = 0;
  std::uint64_t rejected_ = 0;
};

}  // namespace wj::estimation
