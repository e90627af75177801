#pragma once
/// @file Time series of a simulated run, for plots and CSV files.

#include <Eigen/Geometry>
#include <array>
#include <functional>
#include <iosfwd>
#include <vector>

#include "robot_model/robot_model.h"
#include "sim/plan_executor.h"

namespace wj::sim {

/// One control instant of a run: ground truth plus what the drives applied.
struct TelemetrySample {
  double t = 0.0;                                            ///< [s]
  JumpPhase phase = JumpPhase::Takeoff;                      ///< executor phase
  Eigen::Vector3d p_WB = Eigen::Vector3d::Zero();            ///< base origin [m]
  Eigen::Quaterniond q_WB = Eigen::Quaterniond::Identity();  ///< base orientation
  Eigen::Vector3d v_WB = Eigen::Vector3d::Zero();            ///< base origin velocity [m/s]
  Eigen::Vector3d w_WB = Eigen::Vector3d::Zero();  ///< base angular velocity, in W [rad/s]
  Eigen::Vector3d p_WC = Eigen::Vector3d::Zero();  ///< centre of mass [m]
  Eigen::Vector3d v_WC = Eigen::Vector3d::Zero();  ///< centre-of-mass velocity [m/s]
  std::array<double, model::kNumJoints> q{};       ///< [rad]
  std::array<double, model::kNumJoints> qd{};      ///< [rad/s]
  std::array<double, model::kNumJoints> tau{};     ///< applied torque [Nm]
  std::array<Eigen::Vector3d, model::kNumLegs> wheel_force_W{};  ///< terrain on wheel [N]
  double obstacle_clearance_m = 0.0;                             ///< see GroundTruth
};

/// Called once per control period by the verifier.
using TelemetryCallback = std::function<void(const TelemetrySample&)>;

/// Writes the CSV header line matching writeTelemetryCsvRow().
void writeTelemetryCsvHeader(std::ostream& out);
/// Writes one sample as a CSV line (full double precision).
void writeTelemetryCsvRow(std::ostream& out, const TelemetrySample& sample);

/// Collects every sample of a run in memory.
class TelemetryRecorder {
 public:
  /// A callback appending to this recorder (which must outlive it).
  TelemetryCallback callback();
  /// The recorded samples, in time order.
  const std::vector<TelemetrySample>& samples() const { return samples_; }
  /// Header and all rows.
  void writeCsv(std::ostream& out) const;

 private:
  std::vector<TelemetrySample> samples_;
};

}  // namespace wj::sim
