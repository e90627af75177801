#pragma once
/// @file The output of the jump planner: what the verifier, the service and the robot client
/// consume. Plain data, no behaviour beyond evaluation helpers.

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "robot_model/robot_model.h"

namespace wj::planner {

/// How the wheels leave the ground (paper, Eq. 11: gamma = 0 or 1).
enum class TakeoffMode { Simultaneous, TwoStep };
/// Which instant of the jump the target describes.
enum class TargetEvent { Apex, Touchdown };

/// Planar state of the single rigid body in the jump frame J (x forward, z up, origin on the
/// ground below the CoM at t = 0). Pitch is positive nose-up (rotation about -y of the base).
struct PlanarState {
  double x = 0.0;           ///< CoM x [m]
  double z = 0.0;           ///< CoM height [m]
  double pitch = 0.0;       ///< [rad], nose-up positive
  double vx = 0.0;          ///< [m/s]
  double vz = 0.0;          ///< [m/s]
  double pitch_rate = 0.0;  ///< [rad/s]
};

/// The state of the jump at one instant.
struct JumpEvent {
  double t = 0.0;  ///< from the start of take-off [s]
  PlanarState state;
  double base_z = 0.0;  ///< height of the base frame origin [m]
  /// The whole robot's angular momentum about its CoM, nose-up, with the wheels as point masses
  /// on their axles (a free wheel keeps its own spin in flight: model::WheelSpin) [kg m^2/s]:
  /// the planner's is the flight's (take-off only; zero at the other events), the verifier's
  /// Simbody's at the take-off and the touchdown.
  double momentum = 0.0;
};

/// What the multibody simulation's lift-off differs by from the take-off model's, added to the
/// model's flight as an impulse at t2: to the CoM velocity and to the whole robot's angular
/// momentum about its CoM (docs/planner.md, "The lift-off correction"). Zero: the model alone.
/// sim::planWithLiftOffCorrection and the service measure it by verifying the plan in Simbody;
/// planner/liftoff_correction.h has the arithmetic.
struct LiftOffCorrection {
  double vx = 0.0;        ///< [m/s]
  double vz = 0.0;        ///< [m/s]
  double momentum = 0.0;  ///< nose-up [kg m^2/s]
  bool isZero() const { return vx == 0.0 && vz == 0.0 && momentum == 0.0; }
  /// Throws std::invalid_argument naming the field unless each entry is finite and within its
  /// bound: |vx|, |vz| <= kMaxVelocity, |momentum| <= kMaxMomentum.
  void validate() const;
  static constexpr double kMaxVelocity = 1.0;  ///< [m/s]
  static constexpr double kMaxMomentum = 2.0;  ///< [kg m^2/s]
};

/// What a jump does: predicted by the planar model or measured in simulation.
struct JumpOutcome {
  JumpEvent takeoff;    ///< t2: the last wheel leaves the ground
  JumpEvent apex;       ///< highest CoM point in flight
  JumpEvent touchdown;  ///< first wheel contact after flight
  double min_obstacle_clearance = std::numeric_limits<double>::infinity();  ///< [m]
};

/// c[0] + c[1] tau + c[2] tau^2 + ... in the phase-local time tau [s].
struct Polynomial {
  std::vector<double> c;
  /// Value at tau (Horner).
  double operator()(double tau) const {
    double v = 0.0;
    for (auto it = c.rbegin(); it != c.rend(); ++it) v = v * tau + *it;
    return v;
  }
};

/// Force of one wheel pair (left + right together) in J [N].
struct PairForce {
  Polynomial fx;  ///< along the rolling direction
  Polynomial fz;  ///< normal to the ground
};

/// Ground forces over one contact phase.
struct ForcePhase {
  double t_start = 0.0;  ///< [s]
  double t_end = 0.0;    ///< [s]
  PairForce hind;
  PairForce front;  ///< zero once the front pair has lifted
};

/// The trajectory as knots of piecewise cubics (the contract's TrajectoryKnots). Every contact
/// phase and the flight has its own knots, so a phase boundary appears twice: first with the
/// values of the phase that ends, then with those of the phase that starts. densify() says
/// how the values between knots follow.
struct PlanKnots {
  std::vector<double> t;                ///< K knot times [s], non-decreasing, 0 to t3
  std::vector<PlanarState> centroidal;  ///< K CoM states
  Eigen::MatrixXd q;                    ///< K x 16 joint positions [rad]
  Eigen::MatrixXd qd;                   ///< K x 16 joint velocities [rad/s]
  Eigen::MatrixXd tau;                  ///< K x 16 feedforward torques [Nm]; zero in flight

  int size() const { return static_cast<int>(t.size()); }
};

/// A complete jump plan, sampled densely for execution.
struct JumpPlan {
  TakeoffMode mode = TakeoffMode::Simultaneous;
  double t1 = 0.0;  ///< end of four-wheel contact [s]
  double t2 = 0.0;  ///< take-off: end of hind-wheel contact [s]
  double t3 = 0.0;  ///< touchdown: end of flight [s]
  std::vector<ForcePhase> force_phases;

  /// Initial CoM state at t = 0 (x = 0 by definition of J; vx is the run-up speed v0).
  PlanarState initial;
  /// Initial joint positions [rad] (jointIndex order); the robot starts in this posture.
  Eigen::Matrix<double, model::kNumJoints, 1> q_initial =
      Eigen::Matrix<double, model::kNumJoints, 1>::Zero();
  /// Posture the legs move to in flight and hold at landing [rad].
  Eigen::Matrix<double, model::kNumJoints, 1> q_landing =
      Eigen::Matrix<double, model::kNumJoints, 1>::Zero();

  /// Uniform sample period of the dense references [s] (<= 0.002).
  double dt = 0.001;
  /// Dense references from t = 0 to t3, one row per sample k at time k * dt.
  std::vector<PlanarState> centroidal;
  Eigen::MatrixXd q;    ///< N x 16 joint positions [rad]
  Eigen::MatrixXd qd;   ///< N x 16 joint velocities [rad/s]
  Eigen::MatrixXd tau;  ///< N x 16 feedforward torques [Nm]; zero in flight

  /// The trajectory as knots (JumpModel::buildKnots); empty in a dense plan.
  PlanKnots knots;

  /// The optimizer's decision vector D = [s(t1/2), s(t2), s(t3), t1, t2, t3], s = (x, z, pitch).
  Eigen::VectorXd decision;
  /// What the planar model predicts.
  JumpOutcome predicted;
  /// The lift-off correction the model's flight starts with (zero: the model alone).
  LiftOffCorrection liftoff_correction;

  /// Number of dense samples.
  int numSamples() const { return static_cast<int>(centroidal.size()); }
};

}  // namespace wj::planner
