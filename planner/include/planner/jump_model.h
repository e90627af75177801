#pragma once
/// @file The planar single-rigid-body jump model (paper, Sec. III) made exact: from a decision
/// vector to force polynomials (a linear solve), the CoM/pitch trajectory in closed form, the
/// sampled kinodynamic constraints, the prioritized penalty cost and the dense plan.
///
/// The model is immutable once built and evaluate() is allocation-free and const, so one
/// JumpModel is shared by all DE threads (Pinocchio's model/data split; the per-thread data is
/// the Evaluation the caller owns). The mathematics is written down in docs/planner.md.

#include <Eigen/Core>
#include <array>
#include <limits>

#include "planner/jump_plan.h"
#include "planner/jump_task.h"
#include "planner/leg_kinematics.h"
#include "planner/planner_settings.h"
#include "robot_model/robot_model.h"

namespace wj::planner {

/// Entries of the search vector u (docs/planner.md, "Decision variables"). u is a
/// reparametrisation of the paper's D = [s(t1/2), s(t2), s(t3), t1, t2, t3] in which the box
/// bounds keep t1 < t2 < t3 and t3 is the touchdown by construction.
enum DecisionIndex : int {
  kMidDx = 0,          ///< x(t1/2) - v0 t1/2 [m]            (two-step only)
  kMidDz = 1,          ///< z(t1/2) - z0 [m]                 (two-step only)
  kMidDpitch = 2,      ///< pitch(t1/2) - pitch0 [rad]       (two-step only)
  kTakeoffDx = 3,      ///< x(t2) - v0 t2 [m]
  kTakeoffDz = 4,      ///< z(t2) - z0 [m]
  kTakeoffDpitch = 5,  ///< pitch(t2) - pitch0 [rad]
  kTakeoffDvx = 6,     ///< vx(t2) - v0 [m/s]
  kTakeoffVz = 7,      ///< vz(t2) [m/s]
  kTakeoffRate = 8,    ///< pitch rate at t2 [rad/s]
  kT1 = 9,             ///< t1 [s]
  kT2MinusT1 = 10,     ///< t2 - t1 [s]                      (two-step only; 0 otherwise)
  kNumDecision = 11,
};

/// The control period of the executors that run the plans [s]: sim::PlanExecutor at the
/// simulator's control_period_s and the robot client at its period_s, both 1 kHz. Not the
/// plan's sample period (output_dt_s), which tests and benches change: a simultaneous
/// take-off with the unloading tail ends half-way between two of its instants (t = 0 on one).
inline constexpr double kExecutorControlPeriod = 0.001;

/// The lift-off's unloading tail of a simultaneous take-off that ends at t2 [s]: how long the
/// ground force at t2 acts on after t2, as an impulse F(t2) times this (docs/planner.md, "The
/// lift-off's unloading tail"). The executor holds the push's references until its first
/// control instant after t2 (on the plan's grid of control_dt from t = 0; the row at t2 itself
/// is the push's), and the contact then unloads linearly over unload_s: the hold plus
/// unload_s / 2. Zero when unload_s is zero (no tail).
double unloadingTailWeight(double t2, double control_dt, double unload_s);

/// Worst margin of one constraint class over a trajectory.
struct ClassMargin {
  double worst = std::numeric_limits<double>::infinity();  ///< smallest margin (unit: unitOf)
  double t = 0.0;                                          ///< when [s]
  int location = -1;  ///< joint index (0..15), or -1 hind pair, -2 front pair, -3 body
};

/// Which joint-kind maxima are tracked: HAA, HFE, KFE, WHEEL.
inline constexpr int kNumJointKinds = 4;

/// Everything evaluate() computes about one candidate. Owned by the caller (one per thread).
struct Evaluation {
  bool valid = false;  ///< the linear solves succeeded and the flight reaches the ground
  /// evaluate() stopped at its cut-off: `cost` is only a lower bound (> the cut-off), and the
  /// margins, target errors, energy and maxima are partial.
  bool cut_off = false;
  double cost = std::numeric_limits<double>::infinity();
  double penalty = 0.0;      ///< prioritized constraint penalty (paper Eq. 10)
  double target_cost = 0.0;  ///< sum of squared target errors over their tolerances
  double energy_j = 0.0;     ///< take-off mechanical energy, integral of sum |tau qd| [J]
  std::array<ClassMargin, kNumConstraintClasses> margins{};
  double err_dx = 0.0, err_height = 0.0, err_pitch = 0.0, err_landing_pitch = 0.0;
  bool constraints_ok = false;  ///< every margin >= 0
  bool target_ok = false;       ///< every target error within its tolerance
  bool feasible = false;        ///< constraints_ok && target_ok
  JumpOutcome predicted;
  std::array<double, kNumJointKinds> max_abs_torque_nm{};  ///< over the take-off
  std::array<double, kNumJointKinds> max_abs_speed_rad_s{};
};

namespace detail {

/// Sagittal mass geometry of one leg pair (left leg; the right one mirrors it).
struct PairGeometry {
  Eigen::Vector2d hfe_b = Eigen::Vector2d::Zero();  ///< HFE axis in the base frame, x-z [m]
  double haa_lever = 0.0;  ///< lateral offset HAA axis -> wheel plane, left leg [m]
  double m_thigh = 0.0;    ///< thigh mass of one leg [kg]
  Eigen::Vector2d c_thigh = Eigen::Vector2d::Zero();  ///< its CoM in the thigh frame, x-z
  double m_lower = 0.0;                               ///< shank + wheel mass of one leg [kg]
  Eigen::Vector2d c_lower = Eigen::Vector2d::Zero();  ///< their CoM in the shank frame, x-z
  double i_thigh = 0.0;  ///< thigh pitch inertia about its CoM [kg m^2]
  double i_lower = 0.0;  ///< shank + wheel (point mass) pitch inertia about their CoM
  double i_wheel = 0.0;  ///< the wheel's inertia about its axle (its spin) [kg m^2]
};

/// What a JumpModel derives from the robot, the settings, the task and the initial state, once,
/// in its constructor: the immutable half of the model (the per-evaluation half is the
/// caller's Evaluation and the solver's workspace). Read by the model's own translation units
/// (planner/src/jump_model_*.cpp) through JumpModel::constants().
struct JumpModelConstants {
  model::RobotModel robot;
  PlannerSettings settings;
  JumpTask task;
  InitialState init_input;               ///< the initial state as given
  LiftOffCorrection liftoff_correction;  ///< added to the flight's start (addUnloadingTail)
  PlanarState initial;                   ///< the CoM state at t = 0 (x = 0)
  PlanarLeg leg;
  PairGeometry hind, front;
  double mass = 0.0, inertia = 0.0, wheel_radius = 0.0;
  double d_hind = 0.0, d_front = 0.0;  ///< wheel axle x offsets from the CoM at t = 0 [m]
  double z_land = 0.0;                 ///< CoM height at touchdown, landing posture [m]
  double mass_fixed = 0.0;             ///< base and hip links [kg]
  Eigen::Vector2d moment_fixed = Eigen::Vector2d::Zero();  ///< their first moment, base x-z
  double i_fixed = 0.0;  ///< pitch inertia of the base and hips about their CoM [kg m^2]
  Eigen::Vector2d c0 = Eigen::Vector2d::Zero();         ///< CoM in the base, initial posture
  Eigen::Vector2d c_land = Eigen::Vector2d::Zero();     ///< ... and at the landing posture
  Eigen::Vector2d box_half = Eigen::Vector2d::Zero();   ///< half box size x, z
  Eigen::Vector2d q_landing = Eigen::Vector2d::Zero();  ///< (HFE, KFE) landing posture
  /// The surface the jump lands on (a touchdown target's height less z_land: the ground, or a
  /// platform's top; the ground for an apex target) [m], and the farthest any wheel's lowest
  /// point can reach below the CoM in the landing posture, at any pitch (|axle - c_land| + r)
  /// [m]: the touchdown (first wheel contact) comes when the CoM is below surface + that.
  double landing_surface = 0.0, touchdown_reach = 0.0;
  /// Fraction of the flight at which the legs start extending to the landing posture:
  /// settings.wall_extend_start_fraction over a wall, extend_start_fraction otherwise.
  double extend_start = 0.0;
  /// The legs' and wheels' momentum at t = 0 beyond the rigid body's (E(0), docs/planner.md,
  /// "Stance momentum") [kg m^2/s].
  double e0 = 0.0;
  model::ActuatorEnvelope env_haa, env_hfe, env_kfe, env_wheel;
  /// The loaded tyre's additions to a wheel's joint rate (settings.tyre_*): 1 / ratio - 1 per
  /// unit of rolling rate v_axle / r, and r^2 k, the wheel torque per rad/s of slip [Nm s/rad].
  double tyre_rolling_excess = 0.0, tyre_slip_torque = 0.0;
  /// The tyre's sink (settings.tyre_contact_modulus_pa): F = tyre_hertz x^(3/2) per wheel,
  /// tyre_hertz = 4/3 E* sqrt(r) [N/m^1.5]; 0 for the rigid wheel.
  double tyre_hertz = 0.0;
  std::array<double, 2> lim_hfe{}, lim_kfe{};
  /// Each pair's leg as a fixed-base two-link arm, for its joint-space inertia M(q_KFE)
  /// (docs/planner.md, "Flight: the legs brake"): M11 = i_hip + 2 m_l1_c cos q2, M12 = i_knee
  /// + m_l1_c cos q2, M22 = i_knee [kg m^2].
  struct LegInertia {
    double i_hip = 0.0;   ///< thigh about the HFE, lower leg about the knee, + m_lower l1^2
    double i_knee = 0.0;  ///< shank and wheel (point mass) about the knee
    double m_l1_c = 0.0;  ///< m_lower l1 |c_lower|
  };
  std::array<LegInertia, 2> leg_inertia{};
  Eigen::VectorXd lower, upper;  ///< search box of u
  int num_constraint_samples = 0;
  int per_contact_sample = 0, per_flight_sample = 0, num_contact_samples = 0;
};

}  // namespace detail

/// Immutable jump model for one (robot, settings, task, initial state).
class JumpModel {
 public:
  /// Validates the task, the initial state and the correction (std::invalid_argument naming
  /// the field). `correction`: what the flight adds to the take-off model's lift-off state.
  JumpModel(const model::RobotModel& robot, const PlannerSettings& settings, const JumpTask& task,
            const InitialState& initial, const LiftOffCorrection& correction = {});

  int dimension() const { return kNumDecision; }
  /// Search box of u; fixed entries (lower == upper) for a simultaneous take-off.
  const Eigen::VectorXd& lowerBounds() const { return k_.lower; }
  const Eigen::VectorXd& upperBounds() const { return k_.upper; }

  /// Evaluates candidate u into `ev`. Allocation-free; safe to call concurrently. With a
  /// finite `cutoff` it stops once the cost is known to exceed it (the target's position first,
  /// then the take-off samples, checked after each, the whole target error and the flight
  /// samples): ev.cut_off is then set and ev.cost is a lower bound > cutoff. The DE passes a
  /// trial's parent cost.
  void evaluate(const Eigen::Ref<const Eigen::VectorXd>& u, Evaluation& ev,
                double cutoff = std::numeric_limits<double>::infinity()) const;

  /// The target terms of the cost from the target residuals e (dx, height, pitch, landing
  /// pitch: evaluateConstraints' order): sum of (error / tolerance)^2 over dx, height and pitch.
  /// evaluate() adds the landing pitch's excess over its tolerance; the polish's closest
  /// approach minimises this.
  double targetErrorCost(const Eigen::Ref<const Eigen::Vector4d>& e) const;

  /// Number of individual constraint samples (fixed for this model), for the polish.
  int numConstraintSamples() const { return k_.num_constraint_samples; }
  /// Where constraint sample i of evaluateConstraints() comes from: the same margin (a joint's
  /// torque, a wheel's normal force, ...) sampled over time forms one channel.
  struct SampleOrigin {
    int channel = 0;  ///< which margin
    int step = 0;     ///< index along time within the channel
  };
  SampleOrigin constraintSampleOrigin(int i) const;
  /// Every sampled margin divided by its class scale (>= 0 when satisfied), and the target
  /// residuals (dx, height, pitch errors, landing pitch), and the take-off energy with |P|
  /// smoothed as sqrt(P^2 + 1 W^2) for gradient-based use. Returns false if u is invalid.
  bool evaluateConstraints(const Eigen::Ref<const Eigen::VectorXd>& u,
                           Eigen::Ref<Eigen::VectorXd> g,
                           Eigen::Ref<Eigen::Vector4d> target_residual, double* energy_j) const;

  /// The paper's decision vector D = [s(t1/2), s(t2), s(t3), t1, t2, t3] for candidate u.
  Eigen::VectorXd decisionVector(const Eigen::Ref<const Eigen::VectorXd>& u) const;
  /// The dense plan for candidate u (throws std::runtime_error if u is invalid). `evaluation`,
  /// if given, must be this model's evaluate(u) without a cut-off: its predicted outcome is
  /// used instead of evaluating u again (a cache hit has just evaluated it).
  JumpPlan buildPlan(const Eigen::Ref<const Eigen::VectorXd>& u,
                     const Evaluation* evaluation = nullptr) const;
  /// The same plan with its trajectory as knots (JumpPlan::knots, `sampling.knot_dt_s` apart
  /// at most, on every phase boundary and flight-posture corner) instead of dense samples:
  /// what the contract's TRAJECTORY_FORMAT_KNOTS sends. densify() turns it into a dense plan.
  JumpPlan buildKnots(const Eigen::Ref<const Eigen::VectorXd>& u,
                      const Evaluation* evaluation = nullptr) const;

  /// CoM state at t = 0 (x = 0).
  const PlanarState& initialState() const { return k_.initial; }
  /// CoM height at touchdown in the landing posture [m].
  double landingHeight() const { return k_.z_land; }
  double mass() const { return k_.mass; }
  double pitchInertia() const { return k_.inertia; }
  const JumpTask& task() const { return k_.task; }
  const PlannerSettings& settings() const { return k_.settings; }
  /// Everything the model derived in its constructor (for the model's own source files).
  const detail::JumpModelConstants& constants() const { return k_; }
  /// Normalisation scale of a class's margins in the penalty (sigma_n = violation / scale).
  static double classScale(ConstraintClass c);
  /// Priority n of a class in the penalty W_n (10^(n+3) + 10^n sigma_n); 10 is the highest.
  static int classPriority(ConstraintClass c);

  /// Whole-robot CoM in the base frame (x-z) with both hind legs at `q_hind` and both front
  /// legs at `q_front` (HFE, KFE), HAA at 0: the planar counterpart of
  /// RobotModel::calcCompositeInertia. The CoM moves in the base as the heavy wheels move.
  Eigen::Vector2d comInBase(const Eigen::Vector2d& q_hind, const Eigen::Vector2d& q_front) const;

  /// CoM height of the posture `q` standing on flat ground at pitch 0 [m].
  static double standingComHeight(const model::RobotModel& robot, const Eigen::VectorXd& q);

 private:
  // `evaluation`'s predicted outcome if it is this model's full evaluation of u, else u's.
  JumpOutcome predictedOutcome(const Eigen::Ref<const Eigen::VectorXd>& u,
                               const Evaluation* evaluation) const;
  detail::JumpModelConstants k_;
};

}  // namespace wj::planner
