#pragma once
/// @file Execution of a JumpPlan at the control rate: the joint commands of take-off, flight
/// and landing, as the robot client will send them to the drives.

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "planner/jump_plan.h"
#include "robot_model/momentum.h"
#include "robot_model/robot_interface.h"
#include "robot_model/robot_model.h"
#include "sim/statics.h"

namespace wj::sim {

/// Phase of a jump being executed.
enum class JumpPhase : std::uint8_t {
  Takeoff,  ///< t < t2: track the plan's joint references and feedforward torques
  Flight,   ///< t >= t2 until touchdown: legs follow the plan's flight references to q_landing
  Landing,  ///< after touchdown: impedance posture, wheels braking
};

/// "takeoff", "flight", "landing".
std::string_view toString(JumpPhase phase);

/// Gains and timing of the executor. Leg gains apply to HAA, HFE and KFE; wheels always run
/// with kp = 0 (speed control, paper Sec. II-D).
struct ExecutorSettings {
  double takeoff_kp = 150.0;  ///< leg stiffness tracking plan.q in take-off [Nm/rad]
  double takeoff_kd = 3.0;    ///< leg damping tracking plan.qd in take-off [Nm s/rad]
  /// Wheel speed gain in the landing, and in a two-step plan's take-off on the whole error to
  /// the plan's rate (the robot client also holds its wheels with it before its NMPC's first
  /// policy) [Nm s/rad].
  double wheel_kd = 1.0;
  /// The take-off's wheel law (issue 22, docs/planner.md "The wheels' traction in the push"):
  /// each wheel on the ground gets the plan's torque, and its speed reference is the plan's
  /// rolling rate corrected by the tyre (the rolling radius and the slip its planned traction
  /// needs, below). A speed error within takeoff_wheel_slip_band_m_s of that reference gets no
  /// feedback (the tyre's own scatter of slip, the legs' tracking errors); beyond it this gain
  /// acts on the excess, which bounds a wheel that loses traction and spins up (or locks) to
  /// the band plus |torque| / gain. A gain on the whole error (session 16: 1 Nm s/rad against
  /// the plan's no-slip rate) took 0.2-2 Nm off the planned torques [Nm s/rad]. A two-step
  /// plan (the backflip) keeps that loop with wheel_kd: on its hind wheels alone the wheel
  /// torques close the body's pitch (hind_pitch_kp), and with this law Simbody's flips
  /// rotated 0.1-0.2 rad less by their touchdown.
  double takeoff_wheel_kd = 1.0;
  /// Centroidal momentum feedback in a four-wheel take-off (issue 22; docs/planner.md, "The
  /// take-off's momentum feedback"). The whole robot's nose-up angular momentum about its CoM,
  /// H (from the IMU's attitude and rate and the joints' positions and rates, through
  /// model::CentralMomentum), is driven to the plan's by a moment
  /// M = kp e + kd e', e = H_plan - H (e' from one period to the next), clamped to
  /// +-takeoff_momentum_max_nm. The legs put M on the ground as normal force moved from the
  /// hind pair to the front one (each leg's HAA, HFE and KFE torques change by -J^T of its
  /// wheel's share; the total force is unchanged). Without it Simbody's compliant contact and
  /// the joints' PD leave the body 0.03-0.09 kg m^2/s more nose-down than the plan by t2.
  /// Both gains 0: off [1/s].
  double takeoff_momentum_kp = 150.0;
  double takeoff_momentum_kd = 0.5;       ///< see takeoff_momentum_kp [-]
  double takeoff_momentum_max_nm = 40.0;  ///< see takeoff_momentum_kp [Nm]
  /// Ground-speed error (wheel rate x radius) left to the plan's torque in the take-off [m/s].
  double takeoff_wheel_slip_band_m_s = 0.03;
  /// The tyre's longitudinal slip stiffness per wheel: it carries a traction F while its
  /// contact slips at F / stiffness [N s/m]. The take-off's reference adds the slip of the
  /// plan's wheel torque. 370 is what Simbody's wheels show in the push (docs/planner.md).
  double tyre_slip_stiffness_n_s_m = 370.0;
  /// The loaded tyre's rolling radius over the wheel radius: a wheel on the ground turns
  /// 1 / ratio times faster than a rigid one of the nominal radius (the contact's
  /// deflection). The take-off's reference scales the plan's rolling rate by it.
  double tyre_rolling_radius_ratio = 0.99;
  /// Wheel speed gain in flight [Nm s/rad]. 0 lets the wheels spin freely: they keep the
  /// spin they rolled with at take-off (ground speed / r, which flight conserves) and trade no
  /// angular momentum with the body; a gain towards a joint speed would tilt the body.
  double flight_wheel_kd = 0.0;
  /// Leg stiffness towards the plan's flight references [Nm/rad]. The tuck and the landing
  /// extension have no feed-forward (the plan's flight torques are the lift-off braking's), so
  /// this gain sets how far the legs lag them: at 80 / 2 the lag turned the body 0.015-0.044
  /// rad nose-up of the plan by touchdown, at 300 / 6 0.005-0.016 (docs/planner.md, "The
  /// take-off's momentum feedback").
  double flight_kp = 300.0;
  double flight_kd = 6.0;  ///< leg damping in flight [Nm s/rad]
  /// Plans without flight samples: quintic blend from the take-off state to q_landing [s].
  double flight_blend_s = 0.12;
  double joint_limit_margin_rad = 0.05;  ///< flight references stay this far inside the range
  /// The lifted front pair's HFE and KFE references stay this far inside their range while the
  /// robot stands on its hind wheels [rad]. The plan brings them to rest 0.03 rad from a stop
  /// (a flip's front knees at their extended end), and the body's pitch acceleration and rate
  /// load them there: tracking with the take-off gains lagged by up to 0.09 rad, 0.02-0.04 rad
  /// past the knee's range (docs/backflip.md, "Session 12").
  double lifted_pair_margin_rad = 0.12;
  /// A two-step plan's (the backflip's) leg gains in take-off and in flight [Nm/rad, Nm s/rad],
  /// in place of takeoff_kp/kd and flight_kp/kd. With those, Simbody's hind legs ran 0.05-0.1
  /// rad ahead of the push, which took 12-16 Nm off the hips' and knees' planned torques in its
  /// last 50 ms (lift-off 0.4 m/s slow upward, the flight 75 ms short), and in flight the hips
  /// lagged the brake and tuck by up to 0.7 rad (docs/backflip.md, "Session 13").
  double two_step_takeoff_kp = 600.0;
  double two_step_takeoff_kd = 8.0;   ///< see two_step_takeoff_kp
  double two_step_flight_kp = 400.0;  ///< see two_step_takeoff_kp
  double two_step_flight_kd = 8.0;    ///< see two_step_takeoff_kp
  /// ... and its landing's wheel deceleration [m/s^2]: a flip lands rolling backward at 0.8-1.5
  /// m/s, and braking that at 2 m/s^2 raised it onto its hind wheels (0.46 rad nose-up).
  double two_step_landing_wheel_decel_m_s2 = 1.0;
  /// Leg stiffness of the landing posture [Nm/rad]: the robot client's (config/
  /// robot_client.yaml); 60 let the robot tip onto its front wheels while braking from 3 m/s.
  double landing_kp = 120.0;
  double landing_kd = 2.5;                  ///< leg damping of the landing posture [Nm s/rad]
  bool landing_gravity_feedforward = true;  ///< add the standing statics torques of q_landing
  double landing_wheel_decel_m_s2 = 2.0;    ///< wheel speed reference ramps to 0 at this rate
  double landing_duration_s = 1.0;          ///< length of the landing phase [s]
  double airborne_debounce_s = 0.01;        ///< no wheel contact this long counts as airborne [s]
  double max_flight_overrun_s = 0.3;  ///< land anyway this long after t3 without touchdown [s]
  /// Body pitch feedback while the robot stands on its hind wheels alone (t1 <= t < t2 of a
  /// two-step take-off whose front legs carry no planned torque then): each hind wheel adds
  /// hind_pitch_kp (pitch_plan - pitch) + hind_pitch_kd (pitch_rate_plan - pitch_rate),
  /// clamped to +-hind_pitch_max_nm, to its planned torque. A forward wheel torque pitches the
  /// body nose-up (its reaction on the leg and the traction below the CoM), so this closes the
  /// balance on the hind wheels, which the joint references alone leave open loop in attitude
  /// (docs/backflip.md: it recovers the pitch rate the front legs take at t1). The clamp keeps
  /// the wheels inside their envelope and friction (larger ones spin the unloaded wheels).
  double hind_pitch_kp = 100.0;     ///< [Nm/rad]
  double hind_pitch_kd = 10.0;      ///< [Nm s/rad]
  double hind_pitch_max_nm = 10.0;  ///< [Nm] per wheel
  /// Leg placement for the measured pitch: in the descent every leg's HFE reference is offset
  /// by this fraction of the body pitch error (measured minus planned, nose-up positive), so
  /// the legs meet the ground at the plan's angle in the world whatever the body's pitch. It
  /// ramps in from the plan's apex to touchdown_placement_lead_s before touchdown, or to the
  /// touchdown when the apex is later than that (before the apex the legs pass the obstacle
  /// as planned); the offset at touchdown is held through the landing and fades with the
  /// hand-over blend. A
  /// robot that touches down 0.2 rad more nose-up than planned (a payload forward) otherwise
  /// lands its hind knees on the ground (docs/robust.md). 0: off (the plan's posture).
  double touchdown_pitch_placement = 0.0;
  double touchdown_placement_max_rad = 0.4;  ///< bound of that HFE offset [rad]
  double touchdown_placement_lead_s = 0.05;  ///< the offset is whole this long before t3 [s]
  /// Pitch errors inside [-band_down, band_up] are left to the plan [rad]. Nose-up is what
  /// puts the hind knees on the ground; the nominal robot touches down 0.065 rad less nose-up
  /// than its plan (the planner's take-off model, issue 22), which the nose-down band keeps
  /// from moving its legs (docs/robust.md).
  double touchdown_placement_band_up_rad = 0.0;
  double touchdown_placement_band_down_rad = 0.1;  ///< see touchdown_placement_band_up_rad
  /// Wheel braking against a wheelie in the landing: while the body is nose-up beyond
  /// landing_pitch_limit_rad every wheel adds -(kp (pitch - limit) + kd pitch_rate), clamped
  /// to [-landing_pitch_max_nm, 0], to its torque. A braking wheel pitches the body nose-down
  /// (its reaction, and the ground's braking force below the CoM); a rear-heavy robot (a
  /// payload behind) otherwise rose on its hind wheels to 0.69 rad after the landing and
  /// tipped over (docs/robust.md). Mirrored below landing_nose_down_limit_rad of nose-down
  /// pitch: every wheel adds kp (-pitch - limit) - kd pitch_rate, clamped to
  /// [0, landing_pitch_max_nm], a forward torque that pitches the body nose-up. A braking
  /// landing otherwise tipped a front-heavy robot (a payload ahead) onto its front wheels and
  /// over them (platform campaign, docs/robust.md, "The landing's stoppie"). Beyond either
  /// limit the speed reference of the pair the body tips over (the front pair in a stoppie,
  /// the hind pair in a wheelie) is held on the torque's side of the wheel's rate, so that its
  /// speed law adds to the torque and never undoes it. kp = kd = 0: off.
  double landing_pitch_limit_rad = 0.4;
  double landing_nose_down_limit_rad = 0.15;  ///< see landing_pitch_limit_rad [rad]
  double landing_pitch_kp = 0.0;              ///< [Nm/rad]
  double landing_pitch_kd = 0.0;              ///< [Nm s/rad]
  double landing_pitch_max_nm = 8.0;          ///< [Nm] per wheel

  /// Throws std::invalid_argument naming the field when a value is out of range.
  void validate() const;
};

/// Where the landing phase leaves the robot for the controller that takes over after it (the
/// locomotion NMPC): its legs blended from q_landing to `q` (the posture that controller's
/// model assumes: a centroidal model frozen at one posture is unstable in roll when handed a
/// robot standing 6 cm taller, docs/robot-client.md), its wheels at `speed_m_s`.
struct LandingHandover {
  JointVector q = JointVector::Zero();  ///< leg joints at the end of the landing (wheels unused)
  /// Standing statics torques of `q` (calcStandingStatics(...).tau), the gravity feedforward
  /// at the end of the blend; computed by the caller outside the real-time loop.
  JointVector tau_gravity = JointVector::Zero();
  double speed_m_s = 0.0;       ///< ground speed the wheels ramp to (0: brake to a stop) [m/s]
  double blend_start_s = 0.25;  ///< the blend starts this long after touchdown (impact over) [s]
};

/// What is wrong with a plan's shape (sizes, times, sample period), or "" when it can be run.
std::string checkPlan(const planner::JumpPlan& plan);

/// Turns a JumpPlan into joint commands, one control period at a time. Phase changes: at
/// t2 (plan time) to Flight; at the first wheel contact after having been airborne (or
/// max_flight_overrun_s after t3) to Landing. No allocation in update().
class PlanExecutor {
 public:
  /// Keeps references to `model` and `plan` (they must outlive the executor). Throws
  /// std::invalid_argument when checkPlan() reports a problem or the settings are invalid.
  PlanExecutor(const model::RobotModel& model, const planner::JumpPlan& plan,
               const ExecutorSettings& settings, double gravity_m_s2);

  /// Commands for time `t` [s since the start of take-off], given the latest sensors and
  /// whether any wheel touches the ground.
  void update(double t, const model::SensorData& sensors, bool any_wheel_contact,
              model::JointCommands& out);

  /// Current phase.
  JumpPhase phase() const { return phase_; }
  /// True once all wheels have been off the ground for airborne_debounce_s, unless a wheel
  /// touched it again within the take-off phase: a hop in the push (a robot placed a few mm
  /// off the ground by a measured start state, which falls or bounces at first) is not the
  /// flight.
  bool wasAirborne() const { return airborne_; }
  /// Sets where the landing phase ends (see LandingHandover); without it the legs hold
  /// q_landing and the wheels brake to a stop. Real-time safe (a copy); call before the
  /// landing phase starts.
  void setHandover(const LandingHandover& handover) { handover_ = handover; }
  /// Start of the landing phase [s] (infinity before).
  double landingStart() const { return landing_start_; }
  /// True when the landing phase has lasted landing_duration_s.
  bool finished(double t) const;

 private:
  // Where time t falls between the plan's rows: row k0 and the weight a of row k0 + 1.
  struct SamplePoint {
    int k0 = 0;
    double a = 0.0;
  };
  SamplePoint samplePoint(double t) const;
  // Plan references interpolated linearly at time t (take-off gains).
  void sample(double t, model::JointCommands& out) const;
  // Keeps the lifted front pair's HFE and KFE references lifted_pair_margin_rad inside their
  // range while the robot stands on its hind wheels.
  void keepLiftedPairInRange(model::JointCommands& out) const;
  // The take-off's wheel law on the sampled references (ExecutorSettings::takeoff_wheel_kd):
  // the speed reference corrected by the tyre, a band around it without feedback.
  void applyTakeoffWheelLaw(double t, const model::SensorData& sensors,
                            model::JointCommands& out) const;
  // Adds the body pitch feedback of the hind-only push to the hind wheels' torques.
  void addHindPitchFeedback(double t, const Eigen::Vector3d& omega_W,
                            model::JointCommands& out) const;
  // The HFE offset of the leg placement for the measured pitch (touchdown_pitch_placement).
  double calcPlacementOffset(double t) const;
  // Adds the landing's wheel torque against a wheelie (braking) or a stoppie (driving) to
  // every wheel's torque, and keeps the wheels' speed law from working against it.
  void addLandingPitchBrake(const Eigen::Vector3d& omega_W, const model::SensorData& sensors,
                            model::JointCommands& out) const;
  // Adds `offset` to every leg's HFE reference, inside the joint range.
  void addHfeOffset(double offset, model::JointCommands& out) const;
  // Adds the take-off's momentum feedback (takeoff_momentum_kp) to the legs' torques.
  void addMomentumFeedback(double t, const model::SensorData& sensors, const Eigen::Matrix3d& R_WB,
                           model::JointCommands& out);
  // Flight references of a plan without flight samples (positions and speeds only).
  void blendToLanding(double t, model::JointCommands& out) const;

  const model::RobotModel& model_;
  const planner::JumpPlan& plan_;
  ExecutorSettings settings_;
  JointVector landing_feedforward_ = JointVector::Zero();
  // The momentum feedback: the plan's nose-up H at each row (empty when off), the
  // calculator and its inputs (sized once), and the last error and its time.
  std::vector<double> h_plan_;
  model::CentralMomentum momentum_;
  Eigen::VectorXd q_meas_, qd_meas_;
  double h_error_ = 0.0;
  double h_error_t_ = -1.0;   // < 0: no error yet
  double wheel_speed_ = 0.0;  // wheel joint speed reference after take-off [rad/s]
  JointVector q_flight_start_ = JointVector::Zero();   // measured at t2
  JointVector qd_flight_start_ = JointVector::Zero();  // measured at t2
  bool hind_only_ = false;  // two-step plan: the front legs carry no torque in [t1, t2)
  // The leg gains and landing deceleration this plan runs with (a two-step plan's own).
  double takeoff_kp_ = 0.0, takeoff_kd_ = 0.0, flight_kp_ = 0.0, flight_kd_ = 0.0;
  double takeoff_wheel_kd_ = 0.0;
  double landing_decel_ = 0.0;
  bool have_pitch_ = false;  // pitch0_ and pitch_ measured
  double pitch0_ = 0.0;      // body pitch at t = 0 (the plan's pitch is relative to it)
  double pitch_ = 0.0;       // unwrapped body pitch [rad]
  JumpPhase phase_ = JumpPhase::Takeoff;
  bool airborne_ = false;
  double last_contact_t_ = 0.0;
  double flight_start_ = 0.0;
  /// When the plan's legs are at rest after their lift-off braking: no touchdown is taken
  /// before, since a torque-based contact reads the braking as a load while the wheels are
  /// still near the ground [s].
  double brake_end_t_ = 0.0;
  double landing_start_ = std::numeric_limits<double>::infinity();
  double placement_td_ = 0.0;  // HFE offset of the leg placement at touchdown [rad]
  double t_apex_ = 0.0;        // the plan's apex: the CoM's vertical speed turns down [s]
  std::optional<LandingHandover> handover_;
};

}  // namespace wj::sim
