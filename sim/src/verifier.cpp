#include "sim/verifier.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <stdexcept>
#include <utility>

#include "contact_law.h"
#include "robot_model/momentum.h"
#include "sim/statics.h"
#include "sim/symmetry.h"

namespace wj::sim {

Scenario scenarioForTask(const planner::JumpTask& task) {
  Scenario scenario;
  if (!task.obstacle) return scenario;
  const planner::BoxObstacle& box = *task.obstacle;
  if (task.landsOnObstacle()) {
    scenario.name = "platform";
    scenario.terrain = Terrain::platform(box.x_min, box.x_max, box.height);
  } else {
    scenario.name = "wall";
    scenario.terrain = Terrain::wall(box.x_min, box.x_max, box.height);
  }
  return scenario;
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = 3.14159265358979323846;

double rollOf(const Eigen::Matrix3d& R_WB) {
  return std::atan2(R_WB(2, 1), R_WB(2, 2));
}

// printf-style formatting into a std::string (GCC 12 has no std::format).
[[gnu::format(printf, 1, 2)]] std::string strf(const char* format, ...) {
  char buffer[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buffer, sizeof buffer, format, args);
  va_end(args);
  return buffer;
}

planner::JumpEvent makeEvent(const GroundTruth& gt, double pitch) {
  planner::JumpEvent e;
  e.t = gt.t;
  e.state.x = gt.p_WC.x();
  e.state.z = gt.p_WC.z();
  e.state.pitch = pitch;
  e.state.vx = gt.v_WC.x();
  e.state.vz = gt.v_WC.z();
  e.state.pitch_rate = -gt.w_WB.y();
  e.base_z = gt.X_WB.translation().z();
  return e;
}

// The whole robot's angular momentum about its CoM, nose-up (about -y), the wheels as point
// masses (planner::JumpEvent::momentum) [kg m^2/s].
double noseUpMomentum(const model::RobotModel& robot, const Eigen::Matrix3d& R_WB,
                      const Eigen::Vector3d& w_WB, const JointVector& q, const JointVector& qd) {
  return -model::calcCentralAngularMomentum(robot, R_WB, w_WB, q, qd, model::WheelSpin::Excluded)
              .y();
}

TelemetrySample makeSample(const GroundTruth& gt, JumpPhase phase) {
  TelemetrySample s;
  s.t = gt.t;
  s.phase = phase;
  s.p_WB = gt.X_WB.translation();
  s.q_WB = Eigen::Quaterniond(gt.X_WB.linear());
  s.v_WB = gt.v_WB;
  s.w_WB = gt.w_WB;
  s.p_WC = gt.p_WC;
  s.v_WC = gt.v_WC;
  for (int j = 0; j < model::kNumJoints; ++j) {
    s.q[j] = gt.q[j];
    s.qd[j] = gt.qd[j];
    s.tau[j] = gt.tau[j];
  }
  for (int l = 0; l < model::kNumLegs; ++l) s.wheel_force_W[l] = gt.wheels[l].force_W;
  s.obstacle_clearance_m = gt.obstacle_clearance_m;
  return s;
}

// Accumulates the verdict: a reason is recorded once, with the first sentence given for it.
class Verdict {
 public:
  explicit Verdict(VerificationReport& r) : r_(r) {}
  void fail(FailureReason why, std::string sentence) {
    if (r_.failures.contains(why)) return;
    r_.failures.insert(why);
    r_.reasons.push_back(std::move(sentence));
  }

 private:
  VerificationReport& r_;
};

// The lowest wheel's signed distance to the terrain.
double wheelGap(const model::RobotModel& model, const RobotPlacement& p, const Terrain& terrain) {
  const auto centers = calcWheelCenters(model, p.q);
  double gap = kInf;
  for (const auto& c : centers)
    gap = std::min(gap, calcTerrainDistance(terrain, p.X_WB * c) - model.wheelRadius());
  return gap;
}

// True when every right-leg column of `m` (N x 16, or empty) is mirrorSign() times its left
// mirror joint's, to round-off.
bool mirroredColumns(const Eigen::MatrixXd& m) {
  if (m.size() == 0) return true;
  if (m.cols() != model::kNumJoints) return false;
  for (int j = 0; j < model::kNumJoints; ++j) {
    if (isLeftJoint(j)) continue;
    const auto r = m.col(j);
    const auto l = m.col(mirrorJoint(j));
    for (Eigen::Index k = 0; k < m.rows(); ++k)
      if (std::abs(r[k] - mirrorSign(j) * l[k]) > 1e-9 * (1.0 + std::abs(r[k]) + std::abs(l[k])))
        return false;
  }
  return true;
}

// The plan commands the right legs as the mirror image of the left ones.
bool isSymmetric(const planner::JumpPlan& plan) {
  return mirroredColumns(plan.q_initial.transpose()) &&
         mirroredColumns(plan.q_landing.transpose()) && mirroredColumns(plan.q) &&
         mirroredColumns(plan.qd) && mirroredColumns(plan.tau) && mirroredColumns(plan.knots.q) &&
         mirroredColumns(plan.knots.qd) && mirroredColumns(plan.knots.tau);
}

}  // namespace

//==============================================================================================
std::string_view toString(FailureReason reason) {
  switch (reason) {
    case FailureReason::InvalidPlan:
      return "invalid_plan";
    case FailureReason::InvalidInitialState:
      return "invalid_initial_state";
    case FailureReason::SimulationError:
      return "simulation_error";
    case FailureReason::NoTakeoff:
      return "no_takeoff";
    case FailureReason::NoTouchdown:
      return "no_touchdown";
    case FailureReason::TorqueLimit:
      return "torque_limit";
    case FailureReason::SpeedLimit:
      return "speed_limit";
    case FailureReason::JointLimit:
      return "joint_limit";
    case FailureReason::ObstacleCollision:
      return "obstacle_collision";
    case FailureReason::BaseContact:
      return "base_contact";
    case FailureReason::LegContact:
      return "leg_contact";
    case FailureReason::NotUpright:
      return "not_upright";
    case FailureReason::BaseHeight:
      return "base_height";
    case FailureReason::NotSettled:
      return "not_settled";
    case FailureReason::TargetMissed:
      return "target_missed";
  }
  return "?";
}

int FailureSet::size() const {
  return std::popcount(bits_);
}

std::vector<FailureReason> FailureSet::toVector() const {
  std::vector<FailureReason> out;
  for (int i = 0; i < kNumFailureReasons; ++i)
    if (contains(static_cast<FailureReason>(i))) out.push_back(static_cast<FailureReason>(i));
  return out;
}

double calcTerrainDistance(const Terrain& terrain, const Eigen::Vector3d& p_W) {
  double d = kInf;
  if (terrain.has_ground) {
    const Eigen::Vector3d n(-std::sin(terrain.slope_rad), 0.0, std::cos(terrain.slope_rad));
    d = n.dot(p_W);
  }
  for (const Box& b : terrain.boxes) d = std::min(d, detail::signedDistance(b, p_W).distance);
  return d;
}

InitialState initialStateFromPlan(const model::RobotModel& model, const planner::JumpPlan& plan) {
  InitialState s;
  s.com = plan.initial;
  s.q = plan.q_initial;
  if (plan.qd.rows() > 0 && plan.qd.cols() == model::kNumJoints) s.qd = plan.qd.row(0).transpose();
  for (const model::Leg leg : model::kLegs)
    s.qd[model::jointIndex(leg, model::JointKind::Wheel)] = plan.initial.vx / model.wheelRadius();
  return s;
}

RobotPlacement calcPlacement(const model::RobotModel& model, const InitialState& initial,
                             const Terrain& terrain) {
  const double slope = terrain.has_ground ? terrain.slope_rad : 0.0;
  const Eigen::Vector3d along(std::cos(slope), 0.0, std::sin(slope));
  const Eigen::Vector3d normal(-std::sin(slope), 0.0, std::cos(slope));
  RobotPlacement p;
  p.q = initial.q;
  p.qd = initial.qd;
  // Nose-up pitch is a rotation about -y.
  const Eigen::Matrix3d R_WB =
      Eigen::AngleAxisd(-(initial.com.pitch + slope), Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d p_BC = model.calcCompositeInertia(initial.q).com;
  const Eigen::Vector3d p_WC = initial.com.x * along + initial.com.z * normal;
  p.X_WB.linear() = R_WB;
  p.X_WB.translation() = p_WC - R_WB * p_BC;
  p.w_WB = Eigen::Vector3d(0.0, -initial.com.pitch_rate, 0.0);
  const Eigen::Vector3d v_WC = initial.com.vx * along + initial.com.vz * normal;
  p.v_WB = v_WC - p.w_WB.cross(R_WB * p_BC);
  return p;
}

//==============================================================================================
VerifierSettings VerifierSettings::reference() {
  // The reference integrator of docs/sim.md, "Integrator": Runge-Kutta-Merson at 1e-5.
  VerifierSettings s;
  s.sim.integrator.kind = IntegratorKind::RungeKuttaMerson;
  s.sim.integrator.accuracy = 1e-5;
  return s;
}

Verifier::Verifier(model::RobotModel model, VerifierSettings settings)
    : model_(std::move(model)), settings_(std::move(settings)) {
  settings_.sim.validate();
  settings_.executor.validate();
  symmetric_robot_ = findAsymmetry(model_).empty();
}

VerificationReport Verifier::verify(const planner::JumpPlan& plan, const Scenario& scenario,
                                    const TelemetryCallback& telemetry) const {
  return verify(plan, initialStateFromPlan(model_, plan), scenario, telemetry);
}

namespace {

// One verification after the plan is checked: the robot placed, the plan run to its end with
// every quantity the criteria need recorded per control step, then the verdict. The steps fill
// the report.
class VerificationRun {
 public:
  VerificationRun(const model::RobotModel& model, const VerifierSettings& settings,
                  const planner::JumpPlan& plan, const Scenario& scenario, double gravity,
                  VerificationReport& r)
      : model_(model),
        settings_(settings),
        acc_(settings.acceptance),
        plan_(plan),
        scenario_(scenario),
        slope_(scenario.terrain.has_ground ? scenario.terrain.slope_rad : 0.0),
        r_(r),
        verdict_(r),
        gravity_(gravity) {}

  // Places the robot; then corrects the base velocity so that the CoM moves as requested even
  // when the legs move (a common base velocity offset shifts the CoM velocity by the same).
  // False (and the verdict) when the initial state does not put the wheels on the terrain.
  bool place(SimRobot& robot, const InitialState& initial);
  // Runs the plan until the executor is done, the stop time, the robot at rest or a
  // simulation error; false when `stop` (may be null) was set first.
  bool simulate(SimRobot& robot, PlanExecutor& executor, const TelemetryCallback& telemetry,
                const std::atomic<bool>* stop);
  // The verdict, most fundamental first.
  void judge();

 private:
  // Events: take-off = last contact before the airborne interval, touchdown = first
  // contact after it, apex = highest CoM in between.
  void recordFlight(const GroundTruth& gt, bool contact, const PlanExecutor& executor);
  // Drives and joints: torque envelope, speeds, position limits.
  void recordDrives(const GroundTruth& gt, JumpPhase phase);
  void recordContacts(const GroundTruth& gt);
  // The landing state in the report's end-of-run fields: at the end of the run, and at every
  // landing step to find the robot at rest.
  void recordFinalState(const GroundTruth& g, double pitch_now);
  // Every end-of-run bound on the landing holds at this step.
  bool atRest(const GroundTruth& g, double pitch_now);
  void judgeDrives();
  void judgeContacts();
  void judgeLanding();
  void judgeTargets();

  const model::RobotModel& model_;
  const VerifierSettings& settings_;
  const AcceptanceCriteria& acc_;
  const planner::JumpPlan& plan_;
  const Scenario& scenario_;
  const double slope_;
  VerificationReport& r_;
  Verdict verdict_;
  const double gravity_;

  GroundTruth gt_;
  double pitch_ = 0.0;
  planner::JumpEvent last_contact_;
  // The motion at last_contact_, whose angular momentum is computed once it is the take-off.
  struct Motion {
    Eigen::Matrix3d R_WB = Eigen::Matrix3d::Identity();
    Eigen::Vector3d w_WB = Eigen::Vector3d::Zero();
    JointVector q = JointVector::Zero(), qd = JointVector::Zero();
  } last_contact_motion_;
  int limit_joint_ = -1;
  double limit_time_ = 0.0;
  int speed_joint_ = -1;
  double speed_time_ = 0.0;
  double envelope_time_ = 0.0;
  double first_obstacle_contact_ = kInf;
  double first_base_contact_ = kInf, first_leg_contact_ = kInf;
};

bool VerificationRun::place(SimRobot& robot, const InitialState& initial) {
  RobotPlacement placement = calcPlacement(model_, initial, scenario_.terrain);
  r_.initial_ground_gap_m = wheelGap(model_, placement, scenario_.terrain);
  if (!(std::abs(r_.initial_ground_gap_m) <= acc_.initial_gap_tolerance_m)) {
    verdict_.fail(FailureReason::InvalidInitialState,
                  strf("the initial CoM height puts the lowest wheel %.4f m from the "
                       "terrain (tolerance %.4f m)",
                       r_.initial_ground_gap_m, acc_.initial_gap_tolerance_m));
    return false;
  }
  robot.reset(placement);
  robot.calcGroundTruth(gt_, false);
  {
    const double slope = scenario_.terrain.has_ground ? scenario_.terrain.slope_rad : 0.0;
    const Eigen::Vector3d along(std::cos(slope), 0.0, std::sin(slope));
    const Eigen::Vector3d normal(-std::sin(slope), 0.0, std::cos(slope));
    const Eigen::Vector3d v_WC = initial.com.vx * along + initial.com.vz * normal;
    placement.v_WB += v_WC - gt_.v_WC;
  }
  robot.reset(placement);
  return true;
}

void VerificationRun::recordFinalState(const GroundTruth& g, double pitch_now) {
  r_.final_time_s = g.t;
  r_.final_base_height_m = calcTerrainDistance(scenario_.terrain, g.X_WB.translation());
  r_.final_rotation_rad = pitch_now - slope_;
  r_.final_pitch_rad = foldAngle(pitch_now - slope_);
  r_.final_roll_rad = rollOf(g.X_WB.linear());
  r_.final_angular_speed_rad_s = g.w_WB.norm();
}

bool VerificationRun::atRest(const GroundTruth& g, double pitch_now) {
  recordFinalState(g, pitch_now);
  return std::abs(r_.final_pitch_rad) <= acc_.max_final_pitch_rad &&
         std::abs(r_.final_roll_rad) <= acc_.max_final_roll_rad &&
         std::abs(r_.final_base_height_m - r_.nominal_base_height_m) <=
             acc_.base_height_tolerance_m &&
         r_.final_angular_speed_rad_s <= acc_.max_final_angular_speed_rad_s && !g.base_in_contact;
}

void VerificationRun::recordFlight(const GroundTruth& gt, bool contact,
                                   const PlanExecutor& executor) {
  if (executor.wasAirborne() && !r_.took_off) {
    r_.took_off = true;
    const Motion& m = last_contact_motion_;
    last_contact_.momentum = noseUpMomentum(model_, m.R_WB, m.w_WB, m.q, m.qd);
    r_.measured.takeoff = last_contact_;
    r_.measured.apex = last_contact_;
  }
  if (r_.took_off && !r_.touched_down && contact && !executor.wasAirborne()) {
    // Back on the ground within the take-off phase (the executor cleared its flag): that was
    // a hop in the push, not the flight; the take-off is the last contact before the next.
    r_.took_off = false;
    r_.max_base_z_m = -kInf;
    return;
  }
  if (r_.took_off && !r_.touched_down) {
    if (contact) {
      r_.touched_down = true;
      r_.measured.touchdown = makeEvent(gt, pitch_);
      r_.measured.touchdown.momentum =
          noseUpMomentum(model_, gt.X_WB.linear(), gt.w_WB, gt.q, gt.qd);
    } else {
      if (gt.p_WC.z() > r_.measured.apex.state.z) r_.measured.apex = makeEvent(gt, pitch_);
      r_.max_base_z_m = std::max(r_.max_base_z_m, gt.X_WB.translation().z());
    }
  }
}

void VerificationRun::recordDrives(const GroundTruth& gt, JumpPhase phase) {
  const double t = gt.t;
  const bool checked_phase = phase == JumpPhase::Takeoff;  // take-off: the envelope ratio counts
  // Speeds count until touchdown: what the plan commands. The landing impact back-drives the
  // wheels of a robot rolling at 3 m/s (35 rad/s of 40) past their no-load speed whatever the
  // plan; those peaks stay in the per-joint metrics.
  // In flight the wheels spin freely (no drive), so only the leg joints count then.
  const bool speed_checked = phase != JumpPhase::Landing;
  const bool wheels_driven = phase == JumpPhase::Takeoff;
  for (int j = 0; j < model::kNumJoints; ++j) {
    const model::JointSpec& spec = model_.joints()[j];
    JointMetrics& m = r_.joints[j];
    const double limit = spec.actuator.torqueLimit(gt.tau_demand[j], gt.qd[j]);
    const double demand = std::abs(gt.tau_demand[j]);
    const double ratio = limit > 0.0 ? demand / limit : (demand > 0.0 ? kInf : 0.0);
    const double speed_ratio = std::abs(gt.qd[j]) / spec.actuator.no_load_speed_rad_s;
    m.max_abs_torque_nm = std::max(m.max_abs_torque_nm, std::abs(gt.tau[j]));
    m.max_abs_demand_nm = std::max(m.max_abs_demand_nm, demand);
    m.max_abs_speed_rad_s = std::max(m.max_abs_speed_rad_s, std::abs(gt.qd[j]));
    m.max_envelope_ratio = std::max(m.max_envelope_ratio, ratio);
    m.max_speed_ratio = std::max(m.max_speed_ratio, speed_ratio);
    m.min_q_rad = std::min(m.min_q_rad, gt.q[j]);
    m.max_q_rad = std::max(m.max_q_rad, gt.q[j]);
    if (checked_phase && ratio > r_.max_envelope_ratio) {
      r_.max_envelope_ratio = ratio;
      r_.worst_envelope_joint = j;
      envelope_time_ = t;
    }
    const bool drive_speed_counts =
        speed_checked && (wheels_driven || spec.kind != model::JointKind::Wheel);
    if (drive_speed_counts && speed_ratio > r_.max_speed_ratio) {
      r_.max_speed_ratio = speed_ratio;
      speed_joint_ = j;
      speed_time_ = t;
    }
    if (limit_joint_ < 0 && !spec.continuous &&
        (gt.q[j] < spec.lower_rad - acc_.joint_limit_tolerance_rad ||
         gt.q[j] > spec.upper_rad + acc_.joint_limit_tolerance_rad)) {
      limit_joint_ = j;
      limit_time_ = t;
    }
  }
}

void VerificationRun::recordContacts(const GroundTruth& gt) {
  const double t = gt.t;
  r_.measured.min_obstacle_clearance =
      std::min(r_.measured.min_obstacle_clearance, gt.obstacle_clearance_m);
  if (gt.obstacle_clearance_m < 0.0) first_obstacle_contact_ = std::min(first_obstacle_contact_, t);
  if (gt.base_in_contact) first_base_contact_ = std::min(first_base_contact_, t);
  if (gt.legs_in_contact) first_leg_contact_ = std::min(first_leg_contact_, t);
}

bool VerificationRun::simulate(SimRobot& robot, PlanExecutor& executor,
                               const TelemetryCallback& telemetry, const std::atomic<bool>* stop) {
  const double stop_time = plan_.t3 + settings_.executor.max_flight_overrun_s +
                           settings_.executor.landing_duration_s + 1.0;
  model::SensorData sensors;
  model::JointCommands commands{};
  double at_rest_since = kInf;
  GroundTruth& gt = gt_;
  r_.measured.min_obstacle_clearance = kInf;
  r_.nominal_base_height_m = calcStandingStatics(model_, plan_.q_landing, gravity_).base_height_m;
  for (;;) {
    robot.read(sensors);
    robot.calcGroundTruth(gt, static_cast<bool>(telemetry));
    const double t = gt.t;
    pitch_ = calcUnwrappedPitch(gt.X_WB.linear(), pitch_);
    bool contact = false;
    for (const auto& w : gt.wheels) contact = contact || w.in_contact;

    if (!executor.wasAirborne() && contact) {
      last_contact_ = makeEvent(gt, pitch_);
      last_contact_motion_ = {gt.X_WB.linear(), gt.w_WB, gt.q, gt.qd};
    }
    executor.update(t, sensors, contact, commands);
    recordFlight(gt, contact, executor);
    recordDrives(gt, executor.phase());
    recordContacts(gt);
    if (telemetry) telemetry(makeSample(gt, executor.phase()));

    if (executor.finished(t) || t >= stop_time) break;
    if (acc_.settle_window_s > 0.0 && executor.phase() == JumpPhase::Landing && r_.touched_down) {
      if (!atRest(gt, pitch_)) {
        at_rest_since = kInf;
      } else if (at_rest_since == kInf) {
        at_rest_since = t;
      } else if (t - at_rest_since >= acc_.settle_window_s) {
        r_.settled_early = true;
        break;
      }
    }
    if (stop && stop->load(std::memory_order_relaxed)) return false;
    robot.write(commands);
    try {
      robot.advance();
    } catch (const std::exception& e) {
      verdict_.fail(FailureReason::SimulationError, e.what());
      break;
    }
  }
  r_.integrator_steps = robot.integratorStats().steps_taken;
  r_.integrator_realizations = robot.integratorStats().realizations;

  // Landing state at the end of the run.
  recordFinalState(gt, pitch_);
  r_.base_contact = first_base_contact_ < kInf;
  r_.leg_contact = first_leg_contact_ < kInf;
  return true;
}

void VerificationRun::judgeDrives() {
  if (r_.max_envelope_ratio > acc_.max_envelope_ratio) {
    const model::JointSpec& j = model_.joints()[r_.worst_envelope_joint];
    verdict_.fail(
        FailureReason::TorqueLimit,
        strf("%s demands %.2f x its torque limit at t = %.3f s (allowed "
             "%.2f)",
             j.name.c_str(), r_.max_envelope_ratio, envelope_time_, acc_.max_envelope_ratio));
  }
  if (r_.max_speed_ratio > acc_.max_speed_ratio)
    verdict_.fail(
        FailureReason::SpeedLimit,
        strf("%s turns at %.2f x its no-load speed at t = %.3f s",
             model_.joints()[speed_joint_].name.c_str(), r_.max_speed_ratio, speed_time_));
  if (limit_joint_ >= 0)
    verdict_.fail(FailureReason::JointLimit,
                  strf("%s leaves its position range at t = %.3f s",
                       model_.joints()[limit_joint_].name.c_str(), limit_time_));
}

void VerificationRun::judgeContacts() {
  if (first_obstacle_contact_ < kInf)
    verdict_.fail(FailureReason::ObstacleCollision,
                  strf("the robot hits the obstacle at t = %.3f s (min clearance "
                       "%.4f m)",
                       first_obstacle_contact_, r_.measured.min_obstacle_clearance));
  if (r_.base_contact)
    verdict_.fail(FailureReason::BaseContact,
                  strf("the base touches the terrain at t = %.3f s", first_base_contact_));
  if (r_.leg_contact)
    verdict_.fail(FailureReason::LegContact,
                  strf("a leg touches the terrain at t = %.3f s", first_leg_contact_));
}

void VerificationRun::judgeLanding() {
  const bool pitch_ok = std::abs(r_.final_pitch_rad) <= acc_.max_final_pitch_rad;
  const bool roll_ok = std::abs(r_.final_roll_rad) <= acc_.max_final_roll_rad;
  const bool height_ok =
      std::abs(r_.final_base_height_m - r_.nominal_base_height_m) <= acc_.base_height_tolerance_m;
  r_.landed_upright = r_.touched_down && pitch_ok && roll_ok && height_ok && !r_.base_contact;
  if (!pitch_ok || !roll_ok)
    verdict_.fail(FailureReason::NotUpright,
                  strf("at the end pitch is %.3f rad and roll %.3f rad (allowed "
                       "%.3f, %.3f)",
                       r_.final_pitch_rad, r_.final_roll_rad, acc_.max_final_pitch_rad,
                       acc_.max_final_roll_rad));
  if (!height_ok)
    verdict_.fail(
        FailureReason::BaseHeight,
        strf("at the end the base is %.3f m above the terrain, standing "
             "height %.3f m +- %.3f m",
             r_.final_base_height_m, r_.nominal_base_height_m, acc_.base_height_tolerance_m));
  if (r_.final_angular_speed_rad_s > acc_.max_final_angular_speed_rad_s)
    verdict_.fail(FailureReason::NotSettled, strf("at the end the base still turns at %.3f rad/s",
                                                  r_.final_angular_speed_rad_s));
}

void VerificationRun::judgeTargets() {
  if (r_.took_off) {
    r_.apex_height_error_m = r_.measured.apex.state.z - plan_.predicted.apex.state.z;
    if (std::abs(r_.apex_height_error_m) > acc_.max_apex_height_error_m)
      verdict_.fail(FailureReason::TargetMissed,
                    strf("the apex is %+.3f m off the prediction", r_.apex_height_error_m));
  }
  if (r_.touched_down) {
    r_.touchdown_dx_error_m = r_.measured.touchdown.state.x - plan_.predicted.touchdown.state.x;
    r_.touchdown_pitch_error_rad =
        r_.measured.touchdown.state.pitch - plan_.predicted.touchdown.state.pitch;
    if (std::abs(r_.touchdown_dx_error_m) > acc_.max_touchdown_dx_error_m ||
        std::abs(r_.touchdown_pitch_error_rad) > acc_.max_touchdown_pitch_error_rad)
      verdict_.fail(FailureReason::TargetMissed,
                    strf("touchdown is %+.3f m and %+.3f rad off the prediction",
                         r_.touchdown_dx_error_m, r_.touchdown_pitch_error_rad));
  }
}

void VerificationRun::judge() {
  if (!r_.took_off)
    verdict_.fail(FailureReason::NoTakeoff, "the wheels never left the ground");
  else if (!r_.touched_down)
    verdict_.fail(FailureReason::NoTouchdown, strf("no touchdown within %.3f s after t3",
                                                   settings_.executor.max_flight_overrun_s));
  judgeDrives();
  judgeContacts();
  judgeLanding();
  judgeTargets();
  r_.passed = r_.failures.empty();
}

}  // namespace

VerificationReport Verifier::verify(const planner::JumpPlan& plan, const InitialState& initial,
                                    const Scenario& scenario,
                                    const TelemetryCallback& telemetry) const {
  return *verifyOn(plan, initial, scenario, telemetry, nullptr);
}

std::optional<VerificationReport> Verifier::verifyUnless(const planner::JumpPlan& plan,
                                                         const Scenario& scenario,
                                                         const std::atomic<bool>& stop) const {
  return verifyOn(plan, initialStateFromPlan(model_, plan), scenario, {}, &stop);
}

std::optional<VerificationReport> Verifier::verifyOn(const planner::JumpPlan& plan,
                                                     const InitialState& initial,
                                                     const Scenario& scenario,
                                                     const TelemetryCallback& telemetry,
                                                     const std::atomic<bool>* stop) const {
  if (const std::string problem = checkPlan(plan); !problem.empty()) {
    VerificationReport r;
    Verdict(r).fail(FailureReason::InvalidPlan, "invalid plan: " + problem);
    return r;
  }
  SimSettings sim_settings = settings_.sim;
  sim_settings.terrain = scenario.terrain;
  const bool sagittal = settings_.model == VerificationModel::SagittalWhenSymmetric &&
                        symmetric_robot_ && findAsymmetry(sim_settings).empty() &&
                        isSymmetric(plan);
  if (sagittal) {
    try {
      return run(plan, initial, scenario, telemetry, SimModel::Sagittal, stop);
    } catch (const AsymmetryError&) {
      // An asymmetric initial state (refused before the first step), or commands that break
      // the symmetry (a telemetry callback then sees the run restart at t = 0): the full model.
    }
  }
  return run(plan, initial, scenario, telemetry, SimModel::Full, stop);
}

std::optional<VerificationReport> Verifier::run(const planner::JumpPlan& plan,
                                                const InitialState& initial,
                                                const Scenario& scenario,
                                                const TelemetryCallback& telemetry, SimModel kind,
                                                const std::atomic<bool>* stop) const {
  VerificationReport r;
  r.model = kind;
  SimSettings sim_settings = settings_.sim;
  sim_settings.terrain = scenario.terrain;
  SimRobot robot(model_, sim_settings, kind);
  VerificationRun run(model_, settings_, plan, scenario, sim_settings.gravity_m_s2, r);
  if (!run.place(robot, initial)) return r;
  PlanExecutor executor(model_, plan, settings_.executor, sim_settings.gravity_m_s2);
  if (!run.simulate(robot, executor, telemetry, stop)) return std::nullopt;
  run.judge();
  return r;
}

VerificationReport verify(const model::RobotModel& model, const VerifierSettings& settings,
                          const planner::JumpPlan& plan, const InitialState& initial,
                          const Scenario& scenario) {
  return Verifier(model, settings).verify(plan, initial, scenario);
}

double calcUnwrappedPitch(const Eigen::Matrix3d& R_WB, double previous) {
  const double raw = std::atan2(R_WB(2, 0), R_WB(0, 0));
  return raw + 2.0 * kPi * std::round((previous - raw) / (2.0 * kPi));
}

double foldAngle(double angle_rad) {
  const double folded = angle_rad - 2.0 * kPi * std::round(angle_rad / (2.0 * kPi));
  return folded <= -kPi ? folded + 2.0 * kPi : folded;
}

}  // namespace wj::sim
