#include "robot_client/control_loop.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "sim/statics.h"

namespace wj::robot_client {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// A range reading implying a base x this far from the estimate belongs to another object [m].
constexpr double kRangeGate_m = 1.0;
// First seed of the retries when the connection leaves the seed to the service (seed 0).
constexpr std::uint64_t kRetrySeedBase = 1000;

}  // namespace

ControlLoop::ControlLoop(const model::RobotModel& robot, const ClientSettings& settings,
                         const ScenarioSettings& scenario, model::RobotInterface& backend,
                         nmpc::LocomotionController& controller, MpcWorker& mpc,
                         PlanRequester* requester, const FaultSource* faults, RangeSensor* range)
    : robot_(robot),
      settings_(settings),
      scenario_(scenario),
      backend_(backend),
      controller_(controller),
      mpc_(mpc),
      requester_(requester),
      faults_(faults),
      range_(range),
      estimator_(robot, settings.estimator),
      fsm_(scenario, settings.safety, settings.planner.retries),
      leg_{robot.legGeometry(model::Leg::LF).thigh_length,
           robot.legGeometry(model::Leg::LF).shank_length},
      takeoff_speed_(kNaN),
      takeoff_t_(kNaN) {
  settle_periods_ =
      static_cast<int>(std::lround(settings.contact.settle_s / backend.controlPeriod()));
  mpc_every_ = std::max(
      1, static_cast<int>(std::lround(settings.loop.mpc_period_s / backend.controlPeriod())));
  // The landing ends where the NMPC takes over: in the posture its centroidal model is frozen
  // at (docs/robot-client.md, "After the landing"), at the speed it is to go on with.
  const nmpc::CentroidalModel& model = controller.model();
  for (int leg = 0; leg < model::kNumLegs; ++leg)
    for (int j = 0; j < nmpc::kLegDofs; ++j)
      handover_.q[nmpc::robotJointIndex(leg, j)] = model.nominalJoints()[nmpc::kLegDofs * leg + j];
  handover_.tau_gravity =
      sim::calcStandingStatics(robot, handover_.q, model.settings().gravity_m_s2).tau;
  handover_.speed_m_s =
      scenario.after_landing == AfterLanding::RollOn ? scenario.roll_on_speed_m_s : 0.0;
}

void ControlLoop::initialise(const Eigen::Vector3d& p_WB) {
  backend_.read(sensors_);
  Eigen::Matrix<double, model::kNumJoints, 1> q;
  for (int j = 0; j < model::kNumJoints; ++j) q[j] = sensors_.joints[j].q;
  com_offset_B_ = robot_.calcCompositeInertia(q).com;
  for (int j = 0; j < model::kNumJoints; ++j) q_start_[j] = q[j];
  estimator_.reset(p_WB, Eigen::Vector3d::Zero());
  t_ = sensors_.t;
  k_ = 0;
  route_yaw_set_ = false;
  mpc_input_ = MpcInput{};
  mpc_input_.active = false;  // the first NMPC period starts it (cold, a few extra iterations)
  mpc_input_.command.t_start_s = t_;
  ++mpc_input_.command_version;
}

void ControlLoop::setSpeedCommand(double v_target, double accel) {
  nmpc::SpeedCommand& c = mpc_input_.command;
  c.t_start_s = t_;
  c.v_start_m_s = speed_;
  c.v_target_m_s = v_target;
  c.acceleration_m_s2 = accel;
  c.yaw_rad = routeHeading();
  ++mpc_input_.command_version;
}

double ControlLoop::routeHeading() const {
  const RouteSettings& r = settings_.route;
  const double v = mpc_input_.command.v_target_m_s;
  if (r.lateral_gain_rad_per_m == 0.0 || std::abs(v) < r.min_speed_m_s) return route_yaw_;
  // The estimated position's offset to the left of the run's line, and the heading offset
  // that steers back onto it (towards the right for an offset to the left, driving forward).
  const Eigen::Vector2d d = estimator_.state().p_WB.head<2>() - route_origin_;
  const double left = -std::sin(route_yaw_) * d.x() + std::cos(route_yaw_) * d.y();
  const double offset = std::clamp(-r.lateral_gain_rad_per_m * left, -r.max_heading_offset_rad,
                                   r.max_heading_offset_rad);
  return route_yaw_ + (v > 0.0 ? offset : -offset);
}

double ControlLoop::groundHeightAt(double x) const {
  if (!scenario_.landsOnWall()) return estimator_.groundHeight();
  const double near = wall_readings_ > 0 ? wall_x_est_ : scenario_.wallX(0);
  return x >= near && x <= near + scenario_.wall_thickness_m ? scenario_.wall_height_m : 0.0;
}

void ControlLoop::updateContacts() {
  bool over_platform = true;
  for (int leg = 0; leg < model::kNumLegs; ++leg) {
    const auto l = static_cast<model::Leg>(leg);
    const Eigen::Vector2d q(sensors_.joints[model::jointIndex(l, model::JointKind::HFE)].q,
                            sensors_.joints[model::jointIndex(l, model::JointKind::KFE)].q);
    const Eigen::Vector2d tau(sensors_.joints[model::jointIndex(l, model::JointKind::HFE)].tau,
                              sensors_.joints[model::jointIndex(l, model::JointKind::KFE)].tau);
    // Static balance of the leg: tau + J^T f = 0 for the force f of the ground on the wheel
    // (base x-z plane); its component along the base's up axis, rotated by the pitch, is the
    // normal force. A near-singular (straight) leg reports no force.
    const Eigen::Matrix2d J = leg_.jacobian(q);
    const double det = J.determinant();
    double fz = 0.0;
    if (std::abs(det) > 1e-4) {
      const Eigen::Vector2d f = -J.transpose().inverse() * tau;
      fz = f.y() * std::cos(pitch_) - f.x() * std::sin(pitch_);
    }
    contact_force_[leg] = fz;
    // The torque-based force also reads the legs' own inertia (a swing in flight looks like a
    // load), so a wheel counts as touching only if it is also near the ground and not rising
    // away from it by the estimator's state (its flight prediction is exact to millimetres,
    // docs/estimator.md): a tuck swings the wheels up at metres per second.
    Eigen::Vector3d p_BW, v_rel, axis, w_rel;
    estimator_.calcWheelKinematics(l, sensors_.joints, p_BW, v_rel, axis, w_rel);
    const estimation::EstimatedState& s = estimator_.state();
    const Eigen::Vector3d r_W = s.q_WB * p_BW;
    const Eigen::Vector3d p_WW = s.p_WB + r_W;  // the wheel's centre
    const double rise = (s.v_WB + s.omega_W.cross(r_W) + s.q_WB * v_rel).z();
    const double ground = groundHeightAt(p_WW.x());
    over_platform = over_platform && ground > 0.0;
    const double clearance = p_WW.z() - robot_.wheelRadius() - ground;
    contact_[leg] = fz > settings_.contact.force_threshold_n &&
                    clearance < settings_.contact.max_wheel_clearance_m &&
                    rise < settings_.contact.max_rise_speed_m_s;
    // A wheel driven past its traction slips (docs/estimator.md, "Slipping wheels"): its
    // rolling constraint would pull the estimate along with the slip.
    const double wheel_tau = sensors_.joints[model::jointIndex(l, model::JointKind::Wheel)].tau;
    const bool rolling = contact_[leg] && std::abs(wheel_tau) <= settings_.contact.traction_mu *
                                                                     fz * robot_.wheelRadius();
    rolling_periods_[leg] = rolling ? rolling_periods_[leg] + 1 : 0;
  }
  wheels_over_platform_ = scenario_.landsOnWall() && over_platform;
}

void ControlLoop::senseRange() {
  // A course: the readings belong to the wall being approached only.
  if (fsm_.wallIndex() != wall_index_) {
    wall_index_ = fsm_.wallIndex();
    wall_readings_ = 0;
  }
  double range_m = 0.0;
  if (range_ == nullptr || !scenario_.has_wall || wall_index_ >= scenario_.jumps() ||
      !range_->read(range_m))
    return;
  // The configured wall minus the range is a fix of the base's x: odometry drifts (about 1 %
  // of the distance, docs/robot-client.md, "Estimator over a long run"), the range does not.
  // A reading more than a metre off is not this wall's.
  const double x_fix = scenario_.wallX(wall_index_) - range_m;
  if (std::abs(x_fix - estimator_.state().p_WB.x()) < kRangeGate_m)
    estimator_.correctPositionX(x_fix, range_->noiseStd());
  // The wall as the range sensor sees it, averaged in the estimator's frame: the take-off
  // point follows the wall, whatever is left of the odometry's drift.
  const double wall = estimator_.state().p_WB.x() + range_m;
  ++wall_readings_;
  wall_x_est_ += (wall - wall_x_est_) / std::min(wall_readings_, 200);
  fsm_.setWallX(wall_x_est_);
}

void ControlLoop::estimate() {
  // Planned contacts while the NMPC drives (all four wheels roll); detected ones in a jump.
  const Mode m = fsm_.mode();
  const bool jumping = m == Mode::Takeoff || m == Mode::Flight || m == Mode::Landing;
  // A wheel that has just touched down slips until its spin matches the ground (impact, a
  // spin kept from take-off), and one driven past its traction slips (a flip's hind wheels
  // after the front pair lifts): its rolling constraint joins the filter only once it has
  // rolled within its traction for settle_s; until then the IMU carries the estimate.
  std::array<bool, model::kNumLegs> contact{};
  for (int leg = 0; leg < model::kNumLegs; ++leg)
    contact[leg] = !jumping || rolling_periods_[leg] >= settle_periods_;
  estimator_.update(sensors_, contact, backend_.controlPeriod());
  // In a jump, a wheel whose rolling measurement the estimator's gate refused slips beyond what
  // its torque shows (a floor with less friction than traction_mu): it settles again before it
  // rejoins, so that a slip does not read as the filter's divergence (every wheel refused for
  // max_consecutive_rejections updates; docs/estimator.md, "Slipping wheels").
  const estimation::EstimatedState& s = estimator_.state();
  if (jumping) {
    for (int leg = 0; leg < model::kNumLegs; ++leg)
      if (contact[leg] && !s.velocity_used[leg]) rolling_periods_[leg] = 0;
  } else {
    senseRange();
  }
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  X_WB.linear() = s.q_WB.toRotationMatrix();
  X_WB.translation() = s.p_WB;
  Eigen::Matrix<double, model::kNumJoints, 1> q;
  for (int j = 0; j < model::kNumJoints; ++j) q[j] = sensors_.joints[j].q;
  x_ = controller_.model().calcStateFromBase(X_WB, s.v_WB, s.omega_W, q, yaw_);
  yaw_ = x_[nmpc::state_index::kTheta + 2];
  if (!route_yaw_set_) {  // the run's heading and line: the robot's pose at the start
    route_yaw_ = yaw_;
    route_origin_ = s.p_WB.head<2>();
    route_yaw_set_ = true;
  }
  roll_ = x_[nmpc::state_index::kTheta];
  pitch_ = x_[nmpc::state_index::kTheta + 1];
  const Eigen::Vector3d heading(std::cos(yaw_), std::sin(yaw_), 0.0);
  speed_ = s.v_WB.dot(heading);
  com_x_ = (s.p_WB + X_WB.linear() * com_offset_B_).x();
}

void ControlLoop::postPlanRequest() {
  if (requester_ == nullptr) {
    pending_request_ = false;
    return;
  }
  const estimation::EstimatedState& s = estimator_.state();
  PlanRequestSnapshot r;
  r.t = t_;
  r.p_WB = s.p_WB;
  r.q_WB = s.q_WB;
  // The service refuses a speed faster backward than the planner's lowest: a run-up at -1 m/s
  // (the backflip's) is measured up to speed_tolerance_m_s past it, and the plan then starts
  // at most that much slower than the robot rolls.
  r.v_WB = requestVelocity(s.v_WB, s.q_WB);
  r.omega_B = s.q_WB.conjugate() * s.omega_W;
  for (int j = 0; j < model::kNumJoints; ++j) {
    r.q[j] = sensors_.joints[j].q;
    r.qd[j] = sensors_.joints[j].qd;
  }
  // The planner's model is sagittal (left and right legs alike, hip abduction at 0): the
  // request carries each front and hind pair's mean posture. Sent as measured, a robot that
  // stands asymmetric (a payload off the centre line loads one side) had the service's
  // verifier place the longer leg's wheel 1-2.6 cm into the ground and refuse the plan
  // (docs/robot-client.md, "Robustness").
  for (const auto& [left, right] :
       {std::pair{model::Leg::LF, model::Leg::RF}, std::pair{model::Leg::LH, model::Leg::RH}}) {
    for (const model::JointKind kind :
         {model::JointKind::HAA, model::JointKind::HFE, model::JointKind::KFE}) {
      const int l = model::jointIndex(left, kind), rr = model::jointIndex(right, kind);
      const bool haa = kind == model::JointKind::HAA;
      const double q = haa ? 0.0 : 0.5 * (r.q[l] + r.q[rr]);
      const double qd = haa ? 0.0 : 0.5 * (r.qd[l] + r.qd[rr]);
      r.q[l] = r.q[rr] = q;
      r.qd[l] = r.qd[rr] = qd;
    }
  }
  // The legs are planned from the take-off posture the executor imposes, if the scenario has
  // one and the measured crouch is near it (ScenarioSettings::has_takeoff_posture).
  (void)applyTakeoffPosture(scenario_, r.q);
  r.target_dx_m = scenario_.target_dx_m;
  r.target_height_m = scenario_.target_com_height_m;
  r.target_pitch_change_rad = scenario_.target_pitch_change_rad;
  r.event = scenario_.event;
  r.mode = scenario_.mode;
  r.accept_closest_approach = scenario_.accept_closest_approach;
  // A retry asks for another search: the next seed after the connection's.
  if (const int n = fsm_.planAttempt(); n > 0)
    r.seed = (settings_.planner.seed != 0 ? settings_.planner.seed : kRetrySeedBase) +
             static_cast<std::uint64_t>(n);
  r.has_obstacle = scenario_.has_wall;
  if (scenario_.has_wall) {
    // In J: the origin lies below the CoM at the start of take-off, the take-off point.
    r.obstacle_x_min_m = scenario_.takeoff_to_wall_m;
    r.obstacle_x_max_m = r.obstacle_x_min_m + scenario_.wall_thickness_m;
    r.obstacle_height_m = scenario_.wall_height_m;
  }
  if (requester_->post(r)) {
    pending_request_ = false;
  }
}

void ControlLoop::computeCommands(const FsmOutput& out) {
  const Mode m = out.mode;
  if (m == Mode::Damping) {
    for (int j = 0; j < model::kNumJoints; ++j)
      commands_[j] = {sensors_.joints[j].q, 0.0, 0.0, settings_.safety.damping_kd, 0.0};
    return;
  }
  if (m == Mode::Takeoff || m == Mode::Flight || m == Mode::Landing) {
    sim::PlanExecutor* ex = executor();
    // Until the plan's lift-off the wheels stand by the plan: the take-off's first tens of
    // milliseconds unload the legs (the base sinks into the push), the torque-based force of
    // every wheel can drop under the threshold for longer than the executor's airborne
    // debounce, and the executor then took the first contact after its flight switch for a
    // touchdown and extended the legs for the landing right after lift-off (course, second
    // wall: the front wheels hit its edge).
    bool any_contact = ex != nullptr && ex->phase() == sim::JumpPhase::Takeoff;
    for (bool c : contact_) any_contact = any_contact || c;
    if (ex != nullptr) {
      ex->update(t_ - takeoff_t_, sensors_, any_contact, commands_);
      if (settings_.jump_leg_support) addJumpLegSupport(*ex);
    }
    return;
  }
  // NMPC modes (also after a landing: the landing phase ended in the NMPC's own posture): the MPC
  // thread gets the state every MPC period; the loop evaluates the latest policy every period.
  const bool resuming = !mpc_input_.active;  // the first NMPC period: post at once
  mpc_input_.active = true;
  if (resuming || k_ - last_mpc_k_ >= static_cast<std::uint64_t>(mpc_every_)) {
    mpc_input_.t = t_;
    mpc_input_.x = x_;
    // The route's heading follows the robot's offset from the run's line.
    if (const double yaw = routeHeading(); yaw != mpc_input_.command.yaw_rad) {
      mpc_input_.command.yaw_rad = yaw;
      ++mpc_input_.command_version;
    }
    mpc_.post(mpc_input_);
    last_mpc_k_ = k_;
  }
  if (mpc_.counters().cycles == 0) {
    // Free-running NMPC that has not published a policy yet: hold the start posture.
    for (int j = 0; j < model::kNumJoints; ++j) {
      const bool wheel = model::isWheel(j);
      commands_[j] = {wheel ? sensors_.joints[j].q : q_start_[j], 0.0,
                      wheel ? 0.0 : settings_.executor.landing_kp,
                      wheel ? settings_.executor.wheel_kd : settings_.executor.landing_kd, 0.0};
    }
    return;
  }
  controller_.calcCommands(t_, x_, sensors_, commands_);
}

void ControlLoop::addJumpLegSupport(const sim::PlanExecutor& ex) {
  // What the legs' integral learnt while rolling (a payload's share of each leg, the drives'
  // shortfall) carried into the jump: in the push scaled by the plan's vertical load, (a_z + g)
  // / g from its CoM (a payload accelerates with the body), on the legs the plan keeps down
  // (a two-step take-off lifts the front pair at t1); in the landing as learnt, on the legs on
  // the ground. Not in flight.
  const double t = t_ - takeoff_t_;
  const double g = controller_.model().settings().gravity_m_s2;
  nmpc::ContactFlags legs{};
  double scale = 0.0;
  if (ex.phase() == sim::JumpPhase::Takeoff) {
    const planner::JumpPlan& plan = requester_->plan();
    const int k = std::clamp(static_cast<int>(t / plan.dt), 0, plan.numSamples() - 2);
    const double a_z = (plan.centroidal[k + 1].vz - plan.centroidal[k].vz) / plan.dt;
    scale = std::max(0.0, (a_z + g) / g);
    for (int leg = 0; leg < nmpc::kNumLegs; ++leg)
      legs[leg] = !model::isFront(static_cast<model::Leg>(leg)) || t < plan.t1;
  } else if (ex.phase() == sim::JumpPhase::Landing) {
    scale = 1.0;
    for (int leg = 0; leg < nmpc::kNumLegs; ++leg) legs[leg] = contact_[leg];
  }
  if (scale > 0.0) controller_.addLegSupport(x_, sensors_, legs, scale, commands_);
}

void ControlLoop::applySafety() {
  bool finite = true;
  for (int j = 0; j < model::kNumJoints; ++j) {
    model::JointCommand& c = commands_[j];
    finite = finite && std::isfinite(c.q_des) && std::isfinite(c.qd_des) && std::isfinite(c.kp) &&
             std::isfinite(c.kd) && std::isfinite(c.tau_ff);
    const model::JointSpec& spec = robot_.joints()[j];
    if (!model::isWheel(j)) c.q_des = std::clamp(c.q_des, spec.lower_rad, spec.upper_rad);
    const double peak = spec.actuator.peak_torque_nm;
    c.tau_ff = std::clamp(c.tau_ff, -peak, peak);
  }
  if (!finite)
    for (int j = 0; j < model::kNumJoints; ++j)
      commands_[j] = {sensors_.joints[j].q, 0.0, 0.0, settings_.safety.damping_kd, 0.0};
}

void ControlLoop::step() {
  backend_.read(sensors_);
  t_ = sensors_.t;
  updateContacts();
  estimate();

  FsmInput in;
  in.t = t_;
  in.com_x = com_x_;
  in.speed = speed_;
  in.roll = roll_;
  in.pitch = pitch_;
  // A request not posted yet (the worker still finishing the last one) is pending: the last
  // answer's status is not this request's.
  if (requester_ != nullptr)
    in.plan = pending_request_ ? PlanStatus::Pending : requester_->status();
  else
    in.plan = fsm_.mode() == Mode::Plan ? PlanStatus::Failed : PlanStatus::None;
  const sim::PlanExecutor* ex = executor();
  const bool executing =
      fsm_.mode() == Mode::Takeoff || fsm_.mode() == Mode::Flight || fsm_.mode() == Mode::Landing;
  if (executing && ex != nullptr) {
    in.executor_in_flight = ex->phase() == sim::JumpPhase::Flight;
    in.executor_landing = ex->phase() == sim::JumpPhase::Landing;
    in.executor_finished = ex->finished(t_ - takeoff_t_);
  }
  in.estimator_diverged = estimator_.diverged();
  in.motor_fault = faults_ != nullptr && faults_->hasFault();
  in.watchdog_tripped = watchdog_.load(std::memory_order_acquire);
  const FsmOutput out = fsm_.step(in);

  if (out.start_roll) setSpeedCommand(scenario_.run_up_speed_m_s, scenario_.acceleration_m_s2);
  if (out.request_plan) pending_request_ = true;
  if (pending_request_) postPlanRequest();
  if (out.brake) setSpeedCommand(0.0, settings_.safety.brake_decel_m_s2);
  if (out.roll_on) setSpeedCommand(scenario_.roll_on_speed_m_s, scenario_.acceleration_m_s2);
  // A jump onto a platform: each wheel's contact test takes the ground under it
  // (groundHeightAt); once the robot is airborne and every wheel is over the platform, the
  // estimator's height correction takes the platform's top as its ground (the plan lands all
  // four there). The NMPC, when it drives again, finds the terrain height from the stance
  // wheels.
  if ((out.mode == Mode::Flight || out.mode == Mode::Landing) && wheels_over_platform_ &&
      estimator_.groundHeight() != scenario_.wall_height_m)
    estimator_.setGroundHeight(scenario_.wall_height_m);
  if (out.start_takeoff) {
    takeoff_t_ = t_;
    takeoff_speed_ = speed_;
    if (sim::PlanExecutor* jump = executor(); jump != nullptr) jump->setHandover(handover_);
    mpc_input_.active = false;
    mpc_.post(mpc_input_);  // pauses the NMPC for the jump
  }
  computeCommands(out);
  applySafety();
  backend_.write(commands_);
  backend_.advance();

  for (int j = 0; j < model::kNumJoints; ++j)
    max_abs_tau_[j] = std::max(max_abs_tau_[j], std::abs(sensors_.joints[j].tau));
  while (journal_seen_ < fsm_.journalCount()) transitions_.tryPush(fsm_.journal(journal_seen_++));
  if (k_ % static_cast<std::uint64_t>(settings_.loop.telemetry_decimation) == 0) {
    TelemetrySample s;
    s.t = t_;
    s.mode = out.mode;
    const estimation::EstimatedState& e = estimator_.state();
    for (int i = 0; i < 3; ++i) {
      s.p_WB[i] = e.p_WB[i];
      s.v_WB[i] = e.v_WB[i];
    }
    s.roll = roll_;
    s.pitch = pitch_;
    s.com_x = com_x_;
    for (int j = 0; j < model::kNumJoints; ++j) {
      s.q[j] = sensors_.joints[j].q;
      s.qd[j] = sensors_.joints[j].qd;
      s.tau[j] = sensors_.joints[j].tau;
    }
    s.contact_force = contact_force_;
    s.compute_us = last_compute_us_;
    telemetry_.tryPush(s);
  }
  ++k_;
}

}  // namespace wj::robot_client
