#pragma once
/// @file Settings of the jump planner. Every field has a default; a YAML file overrides them and
/// fails on an unknown key (no silent fallback on a misspelling).

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "planner/de/differential_evolution.h"

namespace wj::planner {

/// Kinodynamic constraint classes, in the order of the proto's ConstraintClass (1-based there).
enum class ConstraintClass : int {
  NormalForce = 0,        ///< f_z per wheel >= min_normal_force_n
  FrictionCone = 1,       ///< |f_x| <= mu f_z
  JointPosition = 2,      ///< URDF limits and leg reach
  JointSpeed = 3,         ///< |qd| <= no-load speed (HAA, HFE, KFE)
  JointTorque = 4,        ///< |tau| <= peak torque (HAA, HFE, KFE)
  ActuatorEnvelope = 5,   ///< |tau| <= torque-speed envelope at qd (HAA, HFE, KFE)
  BodyHeight = 6,         ///< lowest point of the body above min_body_clearance_m
  ObstacleClearance = 7,  ///< body and wheels clear of the obstacle
  WheelTraction = 8,      ///< |f_x| r / 2 within the wheel's envelope at its speed
  WheelSpeed = 9,         ///< wheel spin within the wheel's no-load speed
};
inline constexpr int kNumConstraintClasses = 10;
/// Snake-case name, e.g. "actuator_envelope".
const char* toString(ConstraintClass c);
/// Unit of the margins of a class, e.g. "Nm".
const char* unitOf(ConstraintClass c);

/// The polish's NLP solver (`polish.solver`).
enum class PolishSolver {
  Sqp,    ///< "sqp": the planner's dense SQP (dense_sqp.h)
  Ipopt,  ///< "ipopt": Ipopt 3.11 + MUMPS
};
/// "sqp" or "ipopt".
const char* toString(PolishSolver s);

/// What torque the planner's model lets each drive give (`physics.actuator_model`).
enum class ActuatorModel {
  /// "envelope": the torque-speed envelope of models/actuators.yaml (peak torque up to the
  /// corner speed, falling linearly to zero at the no-load speed). The default.
  Envelope,
  /// "constant_torque": the paper's model (Zeng et al., Sec. V-A: 42 Nm and 40 rad/s): the peak
  /// torque at any speed up to the no-load speed. The actuator_envelope and wheel_traction
  /// classes then check the constant peak, so the envelope never binds. For the paper-gap study
  /// (docs/paper-gap.md): a plan made this way promises more than the drives give.
  ConstantTorque,
};
/// "envelope" or "constant_torque".
const char* toString(ActuatorModel m);

/// How the take-off constraint samples chain their CoM-offset iteration (`sampling.contact_chain`;
/// docs/planner.md, "Simplifications"). Each sample takes one step of the fixed-point iteration
/// for c(q), warm-started from the sample next to it.
enum class ContactChain {
  /// "from_start": in time order from t = 0 (start: the standing posture's offset, exact there).
  /// The error builds up towards the take-off, where the legs extend fastest: there it
  /// underestimates the knee speed by 0.8-2 rad/s against the converged fixed point and Simbody.
  FromStart,
  /// "from_takeoff": t = 0 as above, then from the take-off t2 backwards, starting at the
  /// converged take-off posture: exact where the speeds and the envelope bind, and cheaper for
  /// the DE's cut-off (late violations are found first). Makes the forward preset infeasible.
  FromTakeoff,
};

struct PlannerSettings {
  // --- physics of the planar model
  double gravity = 9.81;               ///< [m/s^2]
  double friction_mu = 0.7;            ///< Coulomb friction coefficient wheel-ground
  double min_normal_force_n = 5.0;     ///< per wheel while in contact [N]
  double min_body_clearance_m = 0.04;  ///< lowest body point above the ground [m]
  /// Clearance kept from an obstacle the jump clears (a wall) [m]. The robot client's service
  /// plans with 0.05 (config/planner_settings.yaml; docs/robust.md, "Where the clearance comes
  /// from").
  double obstacle_margin_m = 0.02;
  /// The same for an obstacle the jump lands on (a platform): its near edge and faces [m].
  double platform_margin_m = 0.02;
  /// Scales every actuator's peak torque in the planner's model (what-if studies of stronger
  /// motors; 1 = the URDF's figures).
  double actuator_torque_scale = 1.0;
  /// The drives' torque limit in the model (see ActuatorModel); the simulation always uses the
  /// envelope.
  ActuatorModel actuator_model = ActuatorModel::Envelope;
  /// Take-off pitch on the whole robot's angular momentum, the legs' and wheels' included
  /// (docs/planner.md, "Stance momentum"); off: a rigid body. Off by default: with it, plans
  /// are consistent but not closer to Simbody on the forward and vertical presets. Settings
  /// file: physics.stance_momentum (in the service's settings hash, server/src/cache_key.cpp).
  bool stance_momentum = false;
  /// The lift-off's unloading tail [s]: a simultaneous take-off's ground force at t2 is not
  /// zero (~150 N per wheel on vertical), and the wheels keep pushing after t2: the executor
  /// holds the push's references until its first control instant after t2 (both executors run
  /// at 1 kHz, kExecutorControlPeriod in jump_model.h), and from there
  /// the contact unloads while the legs brake. The model takes the force as holding until that
  /// instant and then falling linearly to zero over this time, and adds the impulse to the
  /// flight's CoM velocity and angular momentum (unloadingTailWeight; docs/planner.md, "The
  /// lift-off's unloading tail"). Simbody's fall, the hold taken out: 2.4-3.4 ms, median 3.0
  /// (session 16, 30 cases); 0: no tail at all, the flight starts from the push's state at t2
  /// (the model until session 13). A two-step take-off is not affected.
  double takeoff_unload_s = 0.003;
  /// The loaded tyre (docs/planner.md, "The loaded tyre"): the model's wheels roll without
  /// slip on their nominal radius r, but a loaded tyre rolls on this fraction of it, so its
  /// joint turns 1 / ratio times faster than the rigid wheel's, and it carries a traction F
  /// only while its contact slips at F / tyre_slip_stiffness_n_s_m, which the joint adds too.
  /// The wheels' speed and envelope margins are taken at that joint rate (Simbody's wheels
  /// turn 0.8-1.0 rad/s faster than the rigid rate in forward_hw's push). The same figures as
  /// the executor's (sim::ExecutorSettings, a test checks it); ratio 1 and a very large
  /// stiffness: the rigid wheel.
  double tyre_rolling_radius_ratio = 0.99;
  double tyre_slip_stiffness_n_s_m = 370.0;  ///< [N s/m] per wheel; see tyre_rolling_radius_ratio
  /// The tyre's sink (docs/planner.md, "The tyre's sink"): the effective Hertz modulus E* of
  /// a wheel against the ground [Pa]. Each wheel in the take-off sits x = (F / k)^(2/3) into
  /// the ground under its share F of its pair's normal force, k = 4/3 E* sqrt(r), so its axle
  /// is r - x high and rises as the push unloads it; the joints' paths, rates and torques
  /// follow. 0: the rigid wheel (the model until session 27). Simbody's wheels, sphere on
  /// half-space at sim::ContactSettings::stiffness_pa = 8 MPa per surface, have E* = 8e6 /
  /// 2^1.5 = 2.83e6; the robot's real tyres are not measured (docs/planner.md).
  double tyre_contact_modulus_pa = 0.0;
  /// The balanced stance (`physics.balanced_stance`; docs/planner.md, "The balanced stance"):
  /// a simultaneous take-off's export moves normal force between the pairs until they make
  /// the moment the plan's motion needs (the rigid-body pitch leaves out the legs' momentum:
  /// 30-36 Nm at t2), and the unloading tail takes that moment into the flight. false: the
  /// model's own split in the feed-forward and the tail (the model until session 17), which
  /// the robot client's service keeps (config/planner_settings.yaml: without the tail, the
  /// balanced plans turn 0.03-0.06 rad more nose-up in Simbody). A two-step take-off keeps
  /// the model's split either way.
  bool balanced_stance = true;
  /// The flight's feed-forward (`physics.flight_feedforward`; docs/planner.md, "The flight's
  /// feed-forward"): the plan's flight rows carry the leg joints' torques that move the legs
  /// along their references while the base flies as the plan's (a Newton-Euler balance of each
  /// leg). false: the braking's torque until the joints are at rest, zero after (the joint PD
  /// alone follows the tuck and the extension).
  bool flight_feedforward = false;

  // --- postures (sagittal angles of every leg; HAA held at 0)
  double stand_hfe_rad = 1.0;  ///< take-off start posture used by the presets
  double stand_kfe_rad = -2.0;
  double landing_hfe_rad = 0.8;  ///< posture the legs take in flight and at landing
  double landing_kfe_rad = -1.6;
  /// Posture the legs tuck into in flight, to lift the wheels. The robot client's service tucks
  /// to HFE 1.0 by 0.15 of the flight (config/planner_settings.yaml): the front wheels pass a
  /// 0.25 m wall's near edge 18 % into the flight (docs/robust.md).
  double tuck_hfe_rad = 1.4;
  double tuck_kfe_rad = -2.5;
  double tuck_end_fraction = 0.25;  ///< fraction of the flight by which the legs are tucked
  /// The tuck's profile (docs/planner.md, "The drive-limited tuck"): false, a smoothstep done by
  /// tuck_end_fraction (the hind pair's slowed to a peak speed within 0.8 of the drives' no-load
  /// speed); true, each joint of both pairs at a constant acceleration within 0.8 of its drive's
  /// peak torque (over the fixed-base leg's inertia) and then a constant deceleration, its peak
  /// speed within 0.8 of the no-load speed, done by tuck_end_fraction if the drives allow it.
  bool drive_limited_tuck = false;
  double extend_start_fraction = 0.55;  ///< ... at which they start extending to landing
  double extend_end_fraction = 0.9;     ///< ... by which they are in the landing posture
  /// extend_start_fraction of a jump over a wall (an obstacle it clears, not one it lands on):
  /// the hind wheels pass the wall's far edge while the legs extend towards the ground. The
  /// robot client's service starts later (config/planner_settings.yaml; docs/robust.md, "The
  /// nominal touchdown pitch"); a platform's landing and the jumps without an obstacle keep
  /// extend_start_fraction.
  double wall_extend_start_fraction = 0.55;

  // --- discretisation
  int samples_phase1 = 24;     ///< constraint samples on [0, t1]
  int samples_phase2 = 16;     ///< constraint samples on [t1, t2]
  int samples_flight = 24;     ///< obstacle/body/attitude samples on [t2, t3], <= 256
  double output_dt_s = 0.001;  ///< sample period of the returned references (<= 0.002)
  double knot_dt_s = 0.02;     ///< largest knot spacing of a plan sent as knots [s]
  ContactChain contact_chain = ContactChain::FromStart;  ///< see ContactChain

  // --- search box of the decision variables (relative to the initial state where noted)
  std::array<double, 2> t1_s = {0.08, 0.6};            ///< four-wheel push duration
  std::array<double, 2> t2_minus_t1_s = {0.04, 0.35};  ///< hind-only push duration (two-step)
  std::array<double, 2> mid_dx_m = {-0.15, 0.15};      ///< x(t1/2) - v0 t1/2
  std::array<double, 2> mid_dz_m = {-0.12, 0.15};      ///< z(t1/2) - z0
  std::array<double, 2> mid_dpitch_rad = {-1.0, 1.0};
  std::array<double, 2> takeoff_dx_m = {-0.3, 0.4};  ///< x(t2) - v0 t2
  std::array<double, 2> takeoff_dz_m = {-0.1, 0.3};  ///< z(t2) - z0
  std::array<double, 2> takeoff_dpitch_rad = {-0.5, 0.5};
  std::array<double, 2> takeoff_dvx_m_s = {-2.5, 2.5};  ///< vx(t2) - v0
  std::array<double, 2> takeoff_vz_m_s = {0.5, 3.5};
  std::array<double, 2> takeoff_pitch_rate_rad_s = {-3.0, 3.0};
  /// Two-step take-offs (flips) get wider pitch bounds than the simultaneous ones.
  std::array<double, 2> two_step_takeoff_dpitch_rad = {-1.5, 2.5};
  std::array<double, 2> two_step_takeoff_pitch_rate_rad_s = {-6.0, 14.0};

  // --- backflips (JumpTask::isBackflip(); `flip:` in the YAML; docs/backflip.md). The flips
  // the model has at the paper's 57 Nm knee lift off pitched up 2.6-2.8 rad after a 0.45 s push
  // on the hind wheels alone, outside the two-step box above (t2 - t1 <= 0.35 s, pitch
  // <= 2.5 rad); below 2 rad at lift-off no flip lands (the body is still upside down when the
  // CoM comes down). These replace t1_s, t2_minus_t1_s, takeoff_vz_m_s and the two-step pitch
  // bounds for a backflip.
  std::array<double, 2> flip_t1_s = {0.08, 0.3};               ///< four-wheel push [s]
  std::array<double, 2> flip_t2_minus_t1_s = {0.3, 0.8};       ///< hind-only push [s]
  std::array<double, 2> flip_takeoff_dpitch_rad = {2.0, 3.2};  ///< pitch(t2) - pitch0
  std::array<double, 2> flip_takeoff_pitch_rate_rad_s = {8.0, 16.0};
  std::array<double, 2> flip_takeoff_vz_m_s = {1.5, 3.5};
  /// A backflip's shape as a search vector u (JumpModel's variable order, kNumDecision
  /// entries), entered into the DE's first population with the warm-start cloud when the
  /// request brings no warm start of its own; empty = none. The default is the flip Simbody
  /// verified (57 Nm, rolling back at 1 m/s, seed 2; docs/backflip.md, "Session 13"): 0.136 s
  /// on four wheels, 0.464 s on the hind wheels to 2.59 rad nose-up, lift-off at 12.5 rad/s,
  /// 1.58 m/s upward and 0.18 m/s faster forward than the start.
  std::vector<double> flip_initial_guess = {0.003, 0.018, 0.145,  0.400, 0.257, 2.589,
                                            0.178, 1.581, 12.531, 0.136, 0.464};
  /// How far short of its extension stop (-0.5 rad) a backflip's hind knee pushes while the
  /// hind wheels are on the ground [rad]. A 42 Nm flip whose hind knee straightened to 0.008
  /// rad from the stop chattered in Simbody (the knee at the stop, then +-42 Nm at ~100 Hz
  /// against the take-off gains) and turned 5.70 rad (docs/backflip.md, "A 42 Nm flip"); from
  /// perturbed starts the 42 Nm flip's pushes held the knee 0.107 rad from the stop, nearly
  /// straight, and chattered there too, so config/backflip-42nm.yaml keeps 0.25 ("From
  /// perturbed starts"). The default 0.1 keeps the 57 Nm flip of the default guess.
  double flip_hind_knee_clearance_rad = 0.1;
  /// The share of the drives' torque envelope a backflip's front pair brakes with once lifted
  /// at t1 (every other lift-off: 0.8, kBrakeTorqueShare). The 42 Nm flip's front knees extend
  /// at 26-28 rad/s into t1, 0.15 rad from their stop: braked at 0.8, Simbody's front knee
  /// demanded 1.00-1.13 x its envelope from perturbed starts; config/backflip-42nm.yaml brakes
  /// at 0.6 (docs/backflip.md, "From perturbed starts").
  double flip_front_brake_share = 0.8;

  // --- cost (paper Eq. 10): sum over violated classes W_n (10^(n+3) + 10^n sigma_n), plus the
  // target error and the energy.
  std::array<double, kNumConstraintClasses> class_weight = {1, 1, 1, 1, 1, 1, 1, 1, 1, 1};
  double energy_weight = 1e-3;  ///< per joule of |tau qd| over the take-off
  /// Target met when every error is within its tolerance (of the order of what the multibody
  /// simulation reproduces: docs/planner.md).
  double tolerance_dx_m = 0.05;
  double tolerance_height_m = 0.02;
  double tolerance_pitch_rad = 0.25;          ///< the verifier's "landed upright" bound
  double landing_pitch_tolerance_rad = 0.25;  ///< |pitch at touchdown| for apex targets

  // --- solver
  de::Settings de;  ///< Differential Evolution
  /// A warm start (from the cache) enters the first population with this many Gaussian
  /// perturbations of it, sigma warm_start_spread of each variable's range (0 = the points only).
  int warm_start_cloud = 12;
  double warm_start_spread = 0.02;
  int de_restarts = 3;  ///< fresh-population restarts after an infeasible stagnation
  /// After the de_restarts planned restarts, a best still violating a constraint gets further
  /// attempts while the evaluation budget left holds ten generations (each attempt at most
  /// max_evaluations / (de_restarts + 1)): the attempts stagnate well before their budget, and
  /// a plan that violates a constraint is no plan (docs/planner.md, "Restarts").
  bool de_restart_while_budget = true;
  bool polish = true;  ///< run the polish on the DE's best candidate
  /// The polish's NLP solver: the planner's dense SQP (the default: 3-6 times faster from the
  /// same DE point, bench_polish) or Ipopt 3.11 + MUMPS (docs/planner.md).
  PolishSolver polish_solver = PolishSolver::Sqp;
  int polish_max_iterations = 15;
  /// The same for a warm-started solve (it begins next to a polished neighbour), 0 = as cold.
  int polish_warm_max_iterations = 4;
  double polish_tolerance = 1e-6;
  /// When the polished best is still infeasible: polish the best of each other DE attempt
  /// (restart), lowest cost first, up to this many, and keep the first that is feasible.
  /// Near the feasibility boundary the attempts end in different basins, and the polish that
  /// fails from one often succeeds from another.
  int polish_retries = 3;
  /// Polish the best of an attempt that ends trapped (a constraint violated) before starting
  /// the next one, and stop if the polished plan is feasible.
  bool polish_between_attempts = true;
  /// Stop the polish once a point meeting every constraint is known and this many iterations in
  /// a row have not lowered its energy by 0.1 % (0 = run to Ipopt's own convergence or
  /// max_iterations).
  int polish_stall_iterations = 3;
  /// The polish keeps every sampled margin at least this far inside its bound, in units of the
  /// class scale (5 Nm, 50 N, 0.2 rad, 5 rad/s, 0.05 m): a plan polished onto its bounds is
  /// infeasible at the next velocity bin and after the smallest tracking error.
  double polish_backoff = 0.05;

  PlannerSettings();
  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
  /// Reads `path`, starting from the defaults. Throws std::runtime_error on an unknown key, a
  /// wrong type or an invalid value, naming the key.
  static PlannerSettings fromYaml(const std::filesystem::path& path);
  /// The same, from YAML text (for tests and the service's configuration).
  static PlannerSettings fromYamlString(const std::string& text);
};

}  // namespace wj::planner
