#pragma once
/// @file The jump model's internals, shared by its source files (planner/src/jump_model_*.cpp):
/// the solved take-off of one candidate (Solved), one take-off sample's kinematics and statics
/// (Sample), and the free functions that compute them from the model's constants. Everything
/// here is per evaluation: the model (JumpModelConstants) is read, never written.
///
///   jump_model_takeoff.cpp      forces, CoM and pitch of the take-off (the linear solves)
///   jump_model_stance.cpp       contact posture, joint rates and statics of a take-off sample
///   jump_model_flight.cpp       centroidal momentum, flight attitude and leg motion
///   jump_model_constraints.cpp  the constraint sweep, target errors and the cost (evaluate)
///   jump_model_plan.cpp         the plan's rows, knots and header
///   jump_model.cpp              the constructor: the constants from robot, settings and task

#include <Eigen/Core>
#include <array>

#include "jump_model_math.h"
#include "planner/jump_model.h"

namespace wj::planner::detail {

/// Share of a drive's torque envelope the legs brake with after their lift-off (the rest is
/// for the joint controllers' tracking and the inertia the fixed-base figure leaves out).
inline constexpr double kBrakeTorqueShare = 0.8;
/// Share of a joint's no-load speed the hind pair's tuck after the braking may reach at its
/// peak: Simbody's hind knee passed its no-load speed when the platform's short flight asked
/// its tuck for 40 rad/s. (The front pair tucks by tuck_end regardless: its wheels are the
/// first to pass an obstacle; slowed the same way they hit the platform's face.)
inline constexpr double kTuckSpeedShare = 0.8;
/// Share of a drive's peak torque a drive-limited tuck (postures.drive_limited_tuck)
/// accelerates and decelerates its joint with, over the fixed-base leg's inertia about it (the
/// rest is for the coupling to the other joint and the body, which that figure leaves out).
inline constexpr double kTuckTorqueShare = 0.8;
/// How far from its limit a braking joint must come to rest [rad].
inline constexpr double kBrakeLimitClearance = 0.03;
/// ... a backflip's hind hip (HFE) at the lift-off [rad]: the hind knees brake from 30-36 rad/s
/// there, and their braking torque's reaction on the thighs swung Simbody's hips 0.14-0.18 rad
/// past the stop the fixed-base brake model (startBrake) gives them, onto the HFE's range
/// (docs/backflip.md, "Session 13").
inline constexpr double kFlipHindHipClearance = 0.2;
/// Constraint rows of the legs' braking after the lift-off, from the converged take-off state
/// (sweepFlight): HFE and KFE of each pair.
inline constexpr int kFlightBrakeRows = 4;

/// One joint braking from its speed at a lift-off to rest (docs/planner.md, "Flight: the legs
/// brake"): at `decel` up to the drive's corner speed and above it at the same share of the
/// envelope's torque, which falls linearly to zero at the no-load speed, so the speed there
/// falls exponentially; below it the torque falls along a cubic to zero at rest, with no kink
/// at the corner speed nor at rest (a C1 feed-forward). The driving envelope's, whatever the
/// drive's braking limit: the planner's conservative assumption (docs/planner.md).
struct JointBrake {
  double q0 = 0.0, sign = 0.0;
  double w0 = 0.0, w_nl = 0.0, lambda = 0.0;  // start speed (abs.), no-load speed, 1/s
  double t_a = 0.0, q_a = 0.0, w_a = 0.0;     // end of the envelope-limited part
  double decel = 0.0;                         // [rad/s^2]
  double t_b = 0.0, kappa = 0.0;              // below w_c: duration [s], shape (lambda t_b)
  double torque = 0.0;                        // the drive's torque it assumes below w_c [Nm]
  double t_stop = 0.0, q_stop = 0.0;          // at rest: when (after the start) and where

  /// Starts at position q and speed v, braking at `decel` with `torque` below the corner speed.
  void start(double q, double v, double decel, double torque, const model::ActuatorEnvelope& env);
  /// Position at time tau after the start, and its rate if `qd`.
  double at(double tau, double* qd) const;
  /// The braking torque at time tau after the start (0 once at rest) [Nm].
  double torqueAt(double tau) const;
};

/// A wheel's sink into the ground (docs/planner.md, "The tyre's sink") and its first two time
/// derivatives [m, m/s, m/s^2].
struct TyreSink {
  double x = 0.0, rate = 0.0, acc = 0.0;
};
/// The sink of a Hertz tyre, F = k x^(3/2), under the normal force f with time derivatives fd
/// and fdd (per wheel) [N, N/s, N/s^2]. Below kTyreSinkBlendN the law is the cubic in F that
/// meets Hertz's value, slope and curvature there and is zero at F = 0, so that the rates and
/// accelerations stay bounded and continuous where a pair unloads (Hertz's dx/dF is infinite
/// at F = 0). k = 0: no sink.
inline constexpr double kTyreSinkBlendN = 20.0;
TyreSink tyreSink(double k, double f, double fd = 0.0, double fdd = 0.0);

/// Kinematics and statics of one wheel pair at one instant (left leg; right is mirrored).
struct PairSample {
  bool contact = false;
  Eigen::Vector2d q = Eigen::Vector2d::Zero();    // HFE, KFE [rad]
  Eigen::Vector2d qd = Eigen::Vector2d::Zero();   // [rad/s]
  Eigen::Vector2d tau = Eigen::Vector2d::Zero();  // HFE, KFE [Nm]
  double haa_fz = 0.0;                            // body-z force per wheel, for the HAA torque [N]
  double wheel_rate = 0.0;                        // wheel joint speed [rad/s]
  // The loaded tyre's joint speed (PlannerSettings::tyre_rolling_radius_ratio): what the
  // wheel's speed and envelope margins take [rad/s].
  double wheel_rate_loaded = 0.0;
  double wheel_tau = 0.0;                          // [Nm]
  Eigen::Vector2d f = Eigen::Vector2d::Zero();     // ground force per wheel, J frame [N]
  Eigen::Vector2d axle = Eigen::Vector2d::Zero();  // axle position in J [m]
  TyreSink sink;                                   // the tyre's, in contact (0 lifted)
  double reach = 0.0;                              // reach margin [m]
  // Where (HFE, KFE) come to rest if the pair lifts off here and brakes (its lift-off
  // sample; otherwise q, and `brakes` false).
  Eigen::Vector2d q_stop = Eigen::Vector2d::Zero();
  bool brakes = false;
};

struct Sample {
  double t = 0.0;
  double t1 = 0.0;                              // end of the four-wheel phase
  Eigen::Vector2d c = Eigen::Vector2d::Zero();  // CoM in the base frame (x-z)
  PlanarState s;
  Rot2 R;  // of s.pitch
  PairSample hind, front;
  const PairSample& pair(int i) const { return i == 0 ? hind : front; }  ///< 0 hind, 1 front
  // What the posture half of a sample (contactPosture) leaves for its statics half: the phase,
  // the time in it, the poses without angles, the axles relative to the CoM (base frame) and
  // the hind axle's speed.
  bool phase2 = false;
  double local = 0.0;
  LegPose pose_h, pose_f;
  Eigen::Vector2d rel_h = Eigen::Vector2d::Zero(), rel_f = Eigen::Vector2d::Zero();
  double hind_axle_vx = 0.0;
};

/// The solved take-off: every polynomial of the trajectory.
struct Solved {
  bool two_step = false;
  // t2 + Tf is when the ballistic CoM comes down to the landing height (the legs' flight
  // schedule is in fractions of Tf); t3 the touchdown, the first wheel on the landing surface
  // (solveFlight; until then t2 + Tf), never before t3_min (docs/planner.md, "Touchdown").
  double t1 = 0, T2 = 0, t2 = 0, Tf = 0, t3 = 0, t3_min = 0;
  Poly X1, Z1, P1, VX1, VZ1, W1;  // phase 1, in t
  Poly fHx1, fHz1, fFx1, fFz1;    // pair forces, phase 1
  Poly X2, Z2, P2, VX2, VZ2, W2;  // phase 2, in tau = t - t1
  Poly fHx2, fHz2;                // hind forces, phase 2
  Poly dH2, ddH2;                 // hind axle offset from the CoM and its rate, phase 2
  Poly Fx1, Fz1, Fx2, Fz2;        // total ground force per phase (x and z axis solves)
  double pm = 0, pe = 0, we = 0;  // pitch targets: at t1/2, at t2, pitch rate at t2
  // The legs' and wheels' momentum in stance, E(t) - E(0): phase 1 in t, phase 2 in tau
  // (solveStanceMomentum; zero until it ran, which `stance_momentum` records).
  Poly D1, D2;
  bool stance_momentum = false;
  double e_t1 = 0.0;  // E at t1 from the first pass (two-step: the front's t1 sample)
  // A two-step's front pair, braking to rest once lifted, hands its momentum relative to the
  // body to the body at t1: E falls by this there (first pass; stance_momentum only).
  double handover_t1 = 0.0;
  Eigen::Vector2d c_front_t1 = Eigen::Vector2d::Zero();  // ... and its CoM offset
  bool takeoff_posture = false;                          // takeoff_sample is final
  // `takeoff` is the flight's start: the push's state at t2 plus the unloading tail's
  // velocity change (addUnloadingTail); tail_h is the tail's nose-up angular impulse about the
  // CoM [kg m^2/s], which the flight's momentum adds: tail_weight [s] times the moment the
  // motion at t2 needs (addUnloadingTailMoment, once the take-off posture is known). Both add
  // the lift-off correction. flight_h is the flight's nose-up momentum about the CoM.
  PlanarState mid, takeoff, touchdown;
  double tail_weight = 0.0, tail_h = 0.0, flight_h = 0.0;
  Eigen::Vector2d front_b_t1 = Eigen::Vector2d::Zero();  // front axle rel. HFE at t1 (body)
  double front_wheel_rate_t1 = 0.0;
  LegPose front_pose_t1;  // inversePose(front_b_t1), and its reach margin
  double front_reach_t1 = 0.0;
  // Two-step: the front pair's (HFE, KFE) braking from their speeds at t1 once lifted, and
  // the pose it comes to rest in.
  std::array<JointBrake, 2> front_brake{};
  LegPose front_pose_stop;
  // The legs' braking from their take-off speeds at t2 (per pair), before they tuck, and when
  // the last joint is at rest (after t2).
  std::array<std::array<JointBrake, 2>, 2> brake{};
  double brake_end = 0.0;
  // How long each pair's (HFE, KFE) then tuck (tuckDuration) [s].
  std::array<Eigen::Vector2d, 2> tuck_duration{};
  // The converged contact sample at t2 (the take-off posture, joint and wheel rates, CoM in
  // the base), and the flight attitude table: pitch and pitch rate at t2 + Tf k / n_flight from
  // the conservation of angular momentum with the legs moving (docs/planner.md, "Flight").
  Sample takeoff_sample;
  int n_flight = 0;
  std::array<double, 257> flight_pitch{}, flight_rate{};
  // The legs' (HFE, KFE) per pair and the CoM in the base at the same flight instants.
  std::array<std::array<Eigen::Vector2d, 257>, 2> flight_q{};
  std::array<Eigen::Vector2d, 257> flight_c{};
};

/// Whether the take-off's constraint samples chain their CoM-offset iteration from the
/// converged take-off posture backwards (PlannerSettings::contact_chain), which a backflip
/// always does: chained from the start, the flips' lift-off sample missed the converged
/// posture by 0.035 rad and 3 rad/s at the hind knee, and the plan's braking knee went past its
/// stop unseen (docs/backflip.md, "Session 13").
inline bool chainsFromTakeoff(const JumpModelConstants& M) {
  return M.settings.contact_chain == ContactChain::FromTakeoff || M.task.isBackflip();
}

// ---- take-off (jump_model_takeoff.cpp)

// Solves the take-off for candidate u and, with `complete`, the stance momentum, the converged
// posture at take-off and the flight attitude (otherwise solveStanceMomentum(),
// solveTakeoffPosture() and solveFlight() complete S later). Returns false if u has no valid
// trajectory.
bool solve(const JumpModelConstants& M, const Eigen::Ref<const Eigen::VectorXd>& u, Solved& S,
           bool complete = true);
// The legs' and wheels' share of the angular momentum in stance (docs/planner.md, "Stance
// momentum"): E = (whole robot's momentum about the CoM) - I theta' at nodes of the first
// pass's path, interpolated per phase, and the pitch solved again with it. Once per S; nothing
// unless settings.stance_momentum.
bool solveStanceMomentum(const JumpModelConstants& M, Solved& S);
// The unloading tail's angular impulse (S.tail_h) of a simultaneous take-off with its take-off
// posture: S.tail_weight times the rate of the whole robot's angular momentum at t2, the moment
// that the ground forces, balanced for the legs' motion, make there (docs/planner.md, "The
// balanced stance"); without settings.balanced_stance, the moment of the model's split. Zero
// for a two-step take-off or without the tail.
void addUnloadingTailMoment(const JumpModelConstants& M, Solved& S);
// The nose-up angular momentum about the CoM of a take-off sample (legs, wheels' spin and
// body) less the rigid body's I theta' [kg m^2/s].
double stanceMomentumExcess(const JumpModelConstants& M, const Sample& smp);
// ... of the pairs' (HFE, KFE) q and qd, wheel joint rates and body pitch rate w.
double stanceMomentumExcess(const JumpModelConstants& M, const std::array<Eigen::Vector2d, 2>& q,
                            const std::array<Eigen::Vector2d, 2>& qd,
                            const std::array<double, 2>& wheel_rate, double w);
// The CoM state at time t (take-off polynomials, flight table, or ballistic with gravity g).
PlanarState stateAt(const JumpModelConstants& M, const Solved& S, double t, double g);
// `s` moved ballistically by dt under gravity g, pitch rate held.
PlanarState ballisticG(const PlanarState& s, double dt, double g);

// ---- stance (jump_model_stance.cpp)

// The converged posture at take-off (S.takeoff_sample) of a solved take-off.
// (Once per S: it returns at once if solveStanceMomentum() has already set it.)
void solveTakeoffPosture(const JumpModelConstants& M, Solved& S);
// The same from a converged sample at t2 of the final path.
void setTakeoffPosture(const Sample& smp, Solved& S);
// The CoM in the base frame for the pairs' poses, and its Jacobians d c / d q_pair.
Eigen::Vector2d comOffset(const JumpModelConstants& M, const LegPose& hind, const LegPose& front);
std::array<Eigen::Matrix2d, 2> comJacobians(const JumpModelConstants& M, const LegPose& hind,
                                            const LegPose& front);
// The sines and cosines of posture q (no inverse kinematics).
LegPose poseOf(const Eigen::Vector2d& q);
// Kinematics and statics of both pairs at time t of the take-off (see the definition), in
// two halves: the posture, and the statics on it.
// `tolerance`: the converged iteration's last step [m] (1e-8 m at the hip is ~5e-8 rad at the
// joints).
inline constexpr double kCoMTolerance = 1e-7;
void contactSample(const JumpModelConstants& M, const Solved& S, double t, Sample& out, bool phase2,
                   const Eigen::Vector2d& c_guess, bool converge = false,
                   double tolerance = kCoMTolerance);
void contactPosture(const JumpModelConstants& M, const Solved& S, double t, Sample& out,
                    bool phase2, const Eigen::Vector2d& c_guess, bool converge,
                    double tolerance = kCoMTolerance);
void contactStatics(const JumpModelConstants& M, const Solved& S, Sample& out);

// ---- flight (jump_model_flight.cpp)

// Whole-robot pitch inertia about the CoM and the legs' angular momentum relative to the base.
void flightMomentum(const JumpModelConstants& M, const std::array<Eigen::Vector2d, 2>& q,
                    const std::array<Eigen::Vector2d, 2>& qd, double& i_total, double& h,
                    Eigen::Vector2d* com_in_base = nullptr);
// The flight attitude and the touchdown state of a solved take-off.
void solveFlight(const JumpModelConstants& M, Solved& S);
// The state in flight: ballistic CoM, attitude from the table.
PlanarState flightState(const JumpModelConstants& M, const Solved& S, double t);
// (HFE, KFE) of a pair (0 hind, 1 front) in flight at time t, and its rate if `qd`.
Eigen::Vector2d flightPosture(const JumpModelConstants& M, const Solved& S, int pair, double t,
                              Eigen::Vector2d* qd);
// How long joint j (0 HFE, 1 KFE) of a pair tucks after its braking ends [s].
double tuckDuration(const JumpModelConstants& M, const Solved& S, int pair, int j);
// The pair's braking from (q, qd) at its lift-off (the leg's inertia, the drives' envelopes).
std::array<JointBrake, 2> startBrake(const JumpModelConstants& M, int pair,
                                     const Eigen::Vector2d& q, const Eigen::Vector2d& qd,
                                     double torque_share = kBrakeTorqueShare);
// The torque share a two-step take-off's front pair brakes with at its lift-off (t1): a
// backflip's settings.flip_front_brake_share, otherwise kBrakeTorqueShare.
double frontLiftBrakeShare(const JumpModelConstants& M);
// (HFE, KFE) of a braking pair at time tau after the start, and its rate if `qd`.
Eigen::Vector2d brakePosture(const std::array<JointBrake, 2>& b, double tau, Eigen::Vector2d* qd);
// The braking torques of a pair at time tau after the start (the joint controllers' feed-forward).
Eigen::Vector2d brakeTorque(const std::array<JointBrake, 2>& b, double tau);
// Wheel joint rate of a pair in flight.
double flightWheelRate(const JumpModelConstants& M, const Solved& S, int pair, double t);

}  // namespace wj::planner::detail
