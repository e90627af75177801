#pragma once
/// @file The centroidal model of the NMPC (paper Sec. II-A) on the URDF's kinematics: a single
/// rigid body with the robot's composite inertia at a nominal posture (paper Eq. 2 with the
/// centroidal inertia frozen, see docs/nmpc.md), driven by the four wheel contact forces, plus
/// the leg joints integrated from the joint velocity inputs. Contact positions and velocities
/// come from the exact leg kinematics.
///
/// Immutable model, per-evaluation data (Pinocchio style): CentroidalModel is cheap to share
/// between threads; every caller owns its ModelData.

#include <Eigen/Geometry>
#include <array>

#include "nmpc/types.h"
#include "robot_model/robot_model.h"

namespace wj::nmpc {

/// Settings of the centroidal model.
struct CentroidalModelSettings {
  /// Base height above flat ground of the nominal posture (legs straight under the hips, knees
  /// back) whose composite inertia and centre of mass the model freezes [m].
  double nominal_base_height_m = 0.36;
  double gravity_m_s2 = 9.81;  ///< magnitude of gravity, along -z of W [m/s^2]

  /// Throws std::invalid_argument naming the field when a value is out of range.
  void validate() const;
};

/// Wheel-centre kinematics of one leg in the base frame B, with derivatives.
struct LegKinematics {
  Eigen::Vector3d p_B = Eigen::Vector3d::Zero();           ///< wheel centre in B [m]
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();             ///< d p_B / d q_leg [m/rad]
  std::array<Eigen::Matrix3d, kLegDofs> dJ{};              ///< dJ / dq_leg[k]
  Eigen::Vector3d axis_B = Eigen::Vector3d::UnitY();       ///< wheel spin axis in B (unit)
  Eigen::Matrix3d d_axis = Eigen::Matrix3d::Zero();        ///< d axis_B / d q_leg
  Eigen::Matrix3d joint_axes_B = Eigen::Matrix3d::Zero();  ///< HAA, HFE, KFE axes in B (columns)
};

/// Everything the model computes once per evaluation point (x) and reuses: rotation, its
/// derivatives and the kinematics of the four legs. One per thread.
struct ModelData {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  ///< R_WB
  std::array<Eigen::Matrix3d, 3> dR{};              ///< dR_WB / dtheta_k
  std::array<LegKinematics, kNumLegs> legs{};       ///< per leg
  /// Wheel centre relative to the CoM point, in B: p_B - c_B [m].
  std::array<Eigen::Vector3d, kNumLegs> s_B{};
};

/// Velocity of one wheel centre in W with its derivatives.
struct WheelVelocity {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();                    ///< [m/s]
  Eigen::Matrix<double, 3, kStateDim> dx = decltype(dx)::Zero();  ///< d v / d x
  /// d v / d (joint velocities of this leg); the other inputs do not enter.
  Eigen::Matrix3d dqd = Eigen::Matrix3d::Zero();
};

/// The centroidal model (see the file comment). State and input layout: nmpc/types.h.
class CentroidalModel {
 public:
  /// Takes the numbers of the robot from `robot`; throws std::invalid_argument on bad settings
  /// or when the nominal posture is out of the legs' reach.
  CentroidalModel(const model::RobotModel& robot, const CentroidalModelSettings& settings = {});

  /// The settings the model was built with.
  const CentroidalModelSettings& settings() const { return settings_; }
  /// Total mass of the robot [kg].
  double mass() const { return mass_; }
  /// Composite rotational inertia about the CoM, in B, at the nominal posture [kg m^2].
  const Eigen::Matrix3d& inertia() const { return inertia_; }
  /// Composite CoM in B at the nominal posture: the body point the state's p follows [m].
  const Eigen::Vector3d& comOffset() const { return c_B_; }
  /// Gravity vector in W [m/s^2].
  Eigen::Vector3d gravity() const { return {0.0, 0.0, -settings_.gravity_m_s2}; }
  /// Wheel radius from the URDF [m].
  double wheelRadius() const { return wheel_radius_; }
  /// Leg joint positions of the nominal posture [rad].
  const LegJointVector& nominalJoints() const { return q_nominal_; }
  /// Lower position limits of the 12 leg joints [rad].
  const LegJointVector& jointLower() const { return q_lower_; }
  /// Upper position limits of the 12 leg joints [rad].
  const LegJointVector& jointUpper() const { return q_upper_; }
  /// No-load speed of the 12 leg joints [rad/s].
  const LegJointVector& jointSpeedLimit() const { return qd_max_; }

  /// Leg joint posture with HAA = 0 and the wheel centre `x_offset_m` ahead of the HFE axis,
  /// `base_height_m` above level ground (knees back; planar two-link inverse kinematics).
  /// Throws std::invalid_argument when out of reach.
  LegJointVector calcStandingJoints(double base_height_m, double x_offset_m = 0.0) const;
  /// Joints (HAA = 0, HFE, KFE) of `leg` that put its wheel centre `x_offset_m` ahead of the
  /// HFE axis with the base `base_height_m` above level ground; false when out of reach or out
  /// of the joint ranges (q untouched).
  bool calcLegJoints(int leg, double base_height_m, double x_offset_m, Eigen::Vector3d& q) const;

  /// Wheel-centre kinematics of `leg` at leg joint positions q_leg (HAA, HFE, KFE).
  void calcLegKinematics(int leg, const Eigen::Vector3d& q_leg, LegKinematics& out) const;
  /// Fills `data` at state x (rotation, its derivatives, leg kinematics).
  void updateData(const State& x, ModelData& data) const;

  /// Flow map xdot = f(x, u) of the centroidal model; `n` is the ground normal in W, which
  /// places the contact point a wheel radius below the wheel centre.
  void calcFlowMap(const State& x, const Input& u, const Eigen::Vector3d& n, const ModelData& data,
                   State& xdot) const;
  /// Flow map and its Jacobians A = df/dx, B = df/du (analytic).
  void calcFlowMapJacobians(const State& x, const Input& u, const Eigen::Vector3d& n,
                            const ModelData& data, State& xdot, StateMatrix& A,
                            StateInputMatrix& B) const;

  /// Velocity of the wheel centre of `leg` in W: v + omega x R s + R J qd.
  Eigen::Vector3d calcWheelVelocity(int leg, const State& x, const Input& u,
                                    const ModelData& data) const;
  /// Same with the derivatives.
  void calcWheelVelocityJacobians(int leg, const State& x, const Input& u, const ModelData& data,
                                  WheelVelocity& out) const;
  /// Wheel centre of `leg` in W [m].
  Eigen::Vector3d calcWheelCenter(int leg, const State& x, const ModelData& data) const;
  /// Wheel spin axis of `leg` in W (unit).
  Eigen::Vector3d calcWheelAxis(int leg, const ModelData& data) const;
  /// d(axis in W)/dx (3 x 24; only theta and this leg's joints are non-zero).
  Eigen::Matrix<double, 3, kStateDim> calcWheelAxisJacobian(int leg, const ModelData& data) const;

  /// NMPC state of the robot with base pose X_WB, base-origin velocity v_WB and angular
  /// velocity w_WB (both in W) and joint positions q (16, model::jointIndex order); yaw is
  /// unwrapped near `yaw_near`.
  State calcStateFromBase(const Eigen::Isometry3d& X_WB, const Eigen::Vector3d& v_WB,
                          const Eigen::Vector3d& w_WB,
                          const Eigen::Matrix<double, model::kNumJoints, 1>& q,
                          double yaw_near = 0.0) const;
  /// Base pose of state x.
  Eigen::Isometry3d calcBasePose(const State& x) const;
  /// Velocity of the base origin in W of state x.
  Eigen::Vector3d calcBaseVelocity(const State& x) const;

 private:
  struct Chain {
    std::array<Eigen::Isometry3d, kLegDofs + 1> X_PJ;  // HAA, HFE, KFE, WHEEL
    std::array<Eigen::Vector3d, kLegDofs + 1> axis;
  };

  CentroidalModelSettings settings_;
  std::array<Chain, kNumLegs> chains_{};
  std::array<model::LegGeometry, kNumLegs> geometry_{};
  double mass_ = 0.0;
  double wheel_radius_ = 0.0;
  Eigen::Matrix3d inertia_ = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d inertia_inv_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d c_B_ = Eigen::Vector3d::Zero();
  LegJointVector q_nominal_ = LegJointVector::Zero();
  LegJointVector q_lower_ = LegJointVector::Zero();
  LegJointVector q_upper_ = LegJointVector::Zero();
  LegJointVector qd_max_ = LegJointVector::Zero();
};

}  // namespace wj::nmpc
