#pragma once
/// @file Reference generation: from a speed command and the terrain plane, the state
/// trajectory that the NMPC tracks over its horizon (base level with the terrain at the
/// commanded height, moving along the heading at the commanded speed, legs at the nominal
/// posture).

#include "nmpc/centroidal_model.h"
#include "nmpc/problem.h"

namespace wj::nmpc {

/// Forward speed command: a ramp from `v_start_m_s` at `t_start_s` towards `v_target_m_s` at
/// `acceleration_m_s2`, then held.
struct SpeedCommand {
  double t_start_s = 0.0;          ///< start of the ramp [s]
  double v_start_m_s = 0.0;        ///< speed before and at the start of the ramp [m/s]
  double v_target_m_s = 0.0;       ///< speed at the end of the ramp [m/s]
  double acceleration_m_s2 = 1.0;  ///< |slope| of the ramp [m/s^2]
  double yaw_rad = 0.0;            ///< heading [rad]

  /// Speed at time t [m/s].
  double speedAt(double t) const;
  /// Distance covered between t0 and t1 >= t0 [m].
  double distance(double t0, double t1) const;
};

/// Settings of the reference generator.
struct ReferenceSettings {
  double base_height_m = 0.36;  ///< base origin above the terrain, along its normal [m]
  int samples = 21;             ///< reference samples over the horizon (linear in between)

  /// Throws std::invalid_argument naming the field when a value is out of range.
  void validate() const;
};

/// Builds ReferenceTrajectory for one MPC cycle (see the file comment). Immutable.
class ReferenceGenerator {
 public:
  /// Throws std::invalid_argument on bad settings.
  ReferenceGenerator(const CentroidalModel& model, const ReferenceSettings& settings);

  /// Reference from t0 over `horizon_s` for a robot at x0 on `terrain` under `command`. The
  /// position starts at x0's projected onto the plane at the reference height, so that only
  /// the height is pulled back, never the progress along the ground. Allocation-free when `out`
  /// already has `samples` entries.
  void update(double t0, const State& x0, const SpeedCommand& command, const TerrainPlane& terrain,
              double horizon_s, ReferenceTrajectory& out) const;

  /// Reference orientation on `terrain` with heading `yaw_rad`: base x along the ground's
  /// steepest line under the heading, z along the normal (roll, pitch, yaw).
  static Eigen::Vector3d calcTerrainAlignedEuler(const TerrainPlane& terrain, double yaw_rad);

  /// Height and sampling of the reference.
  const ReferenceSettings& settings() const { return settings_; }

 private:
  CentroidalModel model_;
  ReferenceSettings settings_;
};

}  // namespace wj::nmpc
