#pragma once
/// @file An upper bound on the backflip's rotation at touchdown over any take-off the actuators
/// allow (issue 17, item 3; docs/backflip.md, "A bound on the rotation at 42 Nm"). Each piece
/// is a separate function so that the test checks it against a closed form or the model.
///
/// Planar (sagittal) quantities, nose-up positive. The bound chains four inequalities:
///   rotation at touchdown <= theta_liftoff_max + (H + h_wheels) / I_min * T_flight + shape,
///   kinetic energy at lift-off >= 1/2 m vz^2 + H^2 / (2 I_max),
///   energy at lift-off <= run-up + actuator work + m g (z_start - z_min),
///   T_flight <= 2 vz_max / g with 1/2 m vz_max^2 = the energy left after H^2 / (2 I_max),
/// and maximises over the split of the energy between H and vz.

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "robot_model/actuator.h"
#include "robot_model/robot_model.h"

namespace wj::bound {

/// Resolution of the searches over the joint ranges.
struct BoundSettings {
  double grid_step_rad = 0.1;      ///< joint grid step of the inertia and reach searches [rad]
  double pitch_step_rad = 0.005;   ///< pitch step of the lift-off pitch search [rad]
  double stance_time_max_s = 1.1;  ///< longest take-off (the flip box: t1 + (t2 - t1)) [s]
  double need_rad = 2.0 * 3.14159265358979323846 - 0.3;  ///< the issue's full turn, less 0.3
  int strokes_per_joint_stance = 1;  ///< monotone strokes of a leg joint in the take-off
  int strokes_per_joint_flight = 2;  ///< monotone strokes of a leg joint in flight (tuck, extend)
  double friction_mu = 0.9;  ///< wheel-ground friction (Simbody's static: the stack's largest)
  /// Fastest wheel spin relative to its shank [rad/s]: the motor gives no torque past its no-load
  /// 40 rad/s, but rolling drives it further (Simbody: 48 rad/s on the 57 Nm flip).
  double wheel_speed_max_rad_s = 50.0;
};

/// Extremes of the composite pitch inertia (about the whole robot's CoM, y axis of the base)
/// over the joint ranges.
struct PitchInertiaRange {
  double i_min = 0.0;        ///< smallest found on the grid, refined [kg m^2]
  double i_min_lower = 0.0;  ///< a lower bound on the smallest (grid error accounted) [kg m^2]
  double i_max_upper = 0.0;  ///< an upper bound on the largest (min over c of a max) [kg m^2]
  double i_max_found = 0.0;  ///< largest found by coordinate ascent on the grid [kg m^2]
  Eigen::VectorXd q_min;     ///< joint positions of i_min (16, jointIndex order)
  Eigen::VectorXd q_max;     ///< joint positions of i_max_found
};

/// The composite pitch inertia I_yy about the whole robot's CoM at joint positions q (the
/// model's calcCompositeInertia, read out).
double calcPitchInertia(const model::RobotModel& robot, const Eigen::VectorXd& q);

/// Searches the joint ranges (every leg's HAA, HFE, KFE on a grid of `step_rad`; the wheels'
/// angle does not change the inertia). Uses I(q) = min over c of sum_i (I_i + m_i |r_i - c|^2),
/// which separates the legs once the point c is fixed.
PitchInertiaRange calcPitchInertiaRange(const model::RobotModel& robot, double step_rad);

/// Largest mechanical power max_w tau(w) w [W] the envelope gives (closed form).
double calcMaxPower(const model::ActuatorEnvelope& envelope);

/// Work [J] one joint can do in the take-off: min(peak torque x range x strokes, max power x
/// stance time). Wheels (continuous) get only the power term.
double calcJointWorkBound(const model::JointSpec& joint, int strokes, double stance_time_s);

/// Largest pitch [rad] at which the robot can stand on a wheel with its body box above the
/// ground, reached continuously from 0 (lift-off pitch can be no more).
double calcLiftoffPitchMax(const model::RobotModel& robot, double joint_step_rad,
                           double pitch_step_rad);

/// A lower bound [m] on the CoM's height above the ground while only the wheels may touch it:
/// every link's CoM above its lowest admissible height (the body box's half-height, the
/// wheel's radius tilted by the largest HAA, the leg boxes' half-thickness).
double calcComHeightMin(const model::RobotModel& robot);

/// The largest angular momentum [kg m^2/s] the spinning wheels can carry relative to the legs
/// (the four wheels' axial inertia x `wheel_speed_rad_s`): handed to the body when they change
/// speed in flight.
double calcWheelMomentumMax(const model::RobotModel& robot, double wheel_speed_rad_s);

/// Largest |dH/dqd_j| / I over the joint grid for each leg joint kind (HAA, HFE, KFE) [-]: the
/// body's rotation per radian of that joint's motion with zero total momentum.
std::array<double, 3> calcShapeCouplingMax(const model::RobotModel& robot, double step_rad);

/// Everything the bound is made of, for one robot and one run-up speed.
struct BoundTerms {
  double knee_peak_nm = 0.0;
  double run_up_speed_m_s = 0.0;
  double mass_kg = 0.0;
  double i_min = 0.0;  ///< [kg m^2], the lower bound
  double i_max = 0.0;  ///< [kg m^2], the upper bound
  double theta_liftoff_max_rad = 0.0;
  double z_start_m = 0.0;  ///< CoM height standing (the planner's start posture)
  double z_min_m = 0.0;
  double run_up_energy_j = 0.0;
  std::array<double, 4> work_by_kind_j{};  ///< HAA, HFE, KFE, WHEEL: all four legs
  double work_j = 0.0;
  double energy_j = 0.0;            ///< available at lift-off above z_min (sum of the above)
  double wheel_momentum_max = 0.0;  ///< [kg m^2/s]
  double momentum_at_best = 0.0;    ///< H of the maximising split [kg m^2/s]
  double vz_at_best = 0.0;          ///< [m/s]
  double flight_time_at_best_s = 0.0;
  double flight_rotation_rad = 0.0;  ///< (H + h_w) / I_min * T
  double shape_rotation_rad = 0.0;   ///< zero-momentum rotation by the legs in flight
  double bound_rad = 0.0;            ///< theta_liftoff_max + flight + shape
  double need_rad = 0.0;
  double energy_to_certify_j = 0.0;            ///< largest energy at which the bound stays <= need
  std::string loosest_term;                    ///< the largest of the three terms of the bound
  std::vector<std::string> alone_exceed_need;  ///< the terms each of which alone reaches the need
};

/// Robot-independent pieces computed once (they do not depend on the knee's torque).
struct Geometry {
  PitchInertiaRange inertia;
  double theta_liftoff_max_rad = 0.0;
  double z_min_m = 0.0;
  double z_start_m = 0.0;
  double wheel_momentum_max = 0.0;
  std::array<double, 3> shape_coupling{};
};

/// The geometric pieces of `robot` (the inertia range, the reach, the CoM heights).
Geometry calcGeometry(const model::RobotModel& robot, const BoundSettings& settings);

/// The largest flight rotation [rad] (H + h_w) / I_min * 2 vz / g over the split of `energy_j`
/// between 1/2 m vz^2 and H^2 / (2 I_max); writes the maximiser.
double maxFlightRotation(double energy_j, double mass_kg, double i_min, double i_max,
                         double wheel_momentum, double* momentum_out, double* vz_out);

/// A lift-off state (planar, nose-up positive), e.g. a plan's or Simbody's.
struct LiftoffState {
  double pitch_rad = 0.0;  ///< pitch at lift-off relative to the start
  double momentum = 0.0;   ///< whole robot's angular momentum about its CoM [kg m^2/s]
  double vz_m_s = 0.0;     ///< CoM vertical speed
  double drop_m = 0.0;     ///< CoM height at lift-off above its height at touchdown
};

/// The flight's part of the bound from a given lift-off: pitch + (H + h_w) / I_min * T + shape,
/// T the time to fall `drop_m` below the lift-off height at vz; the three terms in `terms_out`
/// (pitch, momentum's turn, shape) if not null.
double calcBoundFromLiftoff(const model::RobotModel& robot, const Geometry& geometry,
                            const BoundSettings& settings, const LiftoffState& liftoff,
                            std::array<double, 3>* terms_out);

/// The bound for `robot` (whose knee torque it reads) at run-up speed `run_up_speed_m_s`.
BoundTerms calcBound(const model::RobotModel& robot, const Geometry& geometry,
                     const BoundSettings& settings, double run_up_speed_m_s);

}  // namespace wj::bound
