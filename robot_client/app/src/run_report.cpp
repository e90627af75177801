#include "robot_client/run_report.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <sstream>

#include "nmpc/rotation.h"
#include "robot_client/backends.h"
#include "robot_client/plan_requester.h"
#include "sim/sim_robot.h"
#include "sim/verifier.h"
#include "viz/knee_figure.h"

namespace wj::robot_client {

namespace {

const std::array<std::string, model::kJointsPerLeg> kKindNames = {"HAA", "HFE", "KFE", "WHEEL"};

nlohmann::json num(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

std::string fmt(double v, int precision = 3) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(precision) << v;
  return s.str();
}

// v in scientific notation (residuals span many decades).
std::string fmtSci(double v) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::scientific << std::setprecision(1) << v;
  return s.str();
}

// A frame from the estimate (hardware: no ground truth). Yaw is not estimated: zero.
viz::Frame estimatedFrame(const model::RobotModel& robot, const TelemetrySample& s) {
  viz::Frame f;
  f.t = s.t;
  f.p_WB = Eigen::Vector3d(s.p_WB[0], s.p_WB[1], s.p_WB[2]);
  f.q_WB = Eigen::Quaterniond(Eigen::AngleAxisd(s.pitch, Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(s.roll, Eigen::Vector3d::UnitX()));
  f.q = s.q;
  f.qd = s.qd;
  f.tau = s.tau;
  Eigen::VectorXd q(model::kNumJoints);
  for (int j = 0; j < model::kNumJoints; ++j) q[j] = s.q[j];
  f.p_WC = f.p_WB + f.q_WB.toRotationMatrix() * robot.calcCompositeInertia(q).com;
  f.phase = std::string(toString(s.mode));
  return f;
}

}  // namespace

RunRecorder::RunRecorder(const model::RobotModel& robot, const ClientSettings& settings,
                         const ScenarioSettings& scenario, const std::string& csv_path)
    : robot_(robot), settings_(settings), scenario_(scenario), csv_path_(csv_path) {
  if (csv_path_.empty()) return;
  csv_.open(csv_path_);
  if (!csv_) throw std::runtime_error("cannot write telemetry file " + csv_path_);
  csv_ << "t,mode,est_x,est_y,est_z,est_vx,est_vy,est_vz,roll,pitch,est_com_x";
  for (const char* what : {"q", "qd", "tau"})
    for (int j = 0; j < model::kNumJoints; ++j)
      csv_ << "," << what << "_" << robot_.joints()[j].name;
  for (int leg = 0; leg < model::kNumLegs; ++leg)
    csv_ << ",fn_" << model::toString(static_cast<model::Leg>(leg));
  csv_ << ",compute_us,true_x,true_z,true_vx,true_pitch,true_com_x,true_com_z,true_clearance,"
          "true_body_contact\n";
}

void RunRecorder::drain(ControlLoop& loop) {
  Transition tr;
  while (loop.transitions().tryPop(tr)) {
    transitions_.push_back(tr);
    spdlog::info("t={:.3f} s {} -> {} ({}), CoM x {:.3f} m, speed {:.3f} m/s", tr.t,
                 toString(tr.from), toString(tr.to), toString(tr.reason), tr.com_x, tr.speed);
  }
  TelemetrySample s;
  while (loop.telemetry().tryPop(s)) {
    if (keep_frames_ && !truth_.available && (frames_.empty() || s.t > frames_.back().t)) {
      frames_.push_back(estimatedFrame(robot_, s));
      noteFrame(s.mode, s.t, frames_.back().p_WC.x());
    }
    if (!csv_.is_open()) continue;
    csv_ << s.t << "," << toString(s.mode);
    for (double v : s.p_WB) csv_ << "," << v;
    for (double v : s.v_WB) csv_ << "," << v;
    csv_ << "," << s.roll << "," << s.pitch << "," << s.com_x;
    for (const auto* a : {&s.q, &s.qd, &s.tau})
      for (double v : *a) csv_ << "," << v;
    for (double f : s.contact_force) csv_ << "," << f;
    csv_ << "," << s.compute_us;
    if (have_truth_row_ && std::abs(truth_row_[0] - s.t) < 1e-9)
      for (int i = 1; i < 9; ++i) csv_ << "," << truth_row_[i];
    else
      csv_ << ",,,,,,,,";
    csv_ << "\n";
  }
}

void RunRecorder::onTruth(const sim::GroundTruth& gt, const ControlLoop& loop) {
  truth_.available = true;
  const Mode m = loop.mode();
  const double t_read = loop.time();  // the sensor time of the period just run
  const Eigen::Vector3d p = gt.X_WB.translation();
  const Eigen::Matrix3d R = gt.X_WB.linear();
  const Eigen::Vector3d euler = nmpc::calcEulerAngles(R);  // roll, pitch, yaw (ZYX)
  const double roll = euler.x(), pitch = euler.y();
  have_truth_row_ = true;
  truth_row_ = {t_read, p.x(), p.z(), gt.v_WB.x(), pitch, gt.p_WC.x(), gt.p_WC.z(),
                std::isfinite(gt.obstacle_clearance_m) ? gt.obstacle_clearance_m : 99.0,
                // 1: the base touches the terrain, 2: a leg link does, 3: both
                (gt.base_in_contact ? 1.0 : 0.0) + (gt.legs_in_contact ? 2.0 : 0.0)};
  // Unwrapped from the first sample on; an upright robot starts within (-pi, pi].
  truth_pitch_ = sim::calcUnwrappedPitch(R, truth_pitch_);
  if (m == Mode::Takeoff && std::isnan(truth_.takeoff_speed)) {
    truth_.takeoff_speed = gt.v_WC.x();
    truth_.takeoff_com_x = gt.p_WC.x();
    takeoff_truth_pitch_ = truth_pitch_;
  }
  if (std::isfinite(takeoff_truth_pitch_))
    truth_.final_rotation = truth_pitch_ - takeoff_truth_pitch_;
  if (m == Mode::Flight && std::isnan(truth_.liftoff_vx)) {
    truth_.liftoff_vx = gt.v_WC.x();
    truth_.liftoff_vz = gt.v_WC.z();
    truth_.liftoff_pitch_rate = -gt.w_WB.y();
  }
  if (m == Mode::Takeoff || m == Mode::Flight) {
    truth_.apex_base_z = std::max(truth_.apex_base_z, p.z());
    truth_.apex_com_z = std::max(truth_.apex_com_z, gt.p_WC.z());
  }
  if (m == Mode::Landing && std::isnan(truth_.touchdown_dx)) {
    truth_.touchdown_dx = gt.p_WC.x() - truth_.takeoff_com_x;
    truth_.touchdown_rotation = truth_pitch_ - takeoff_truth_pitch_;
  }
  if (m == Mode::Roll && loop.stateMachine().rolledOn()) truth_.roll_on_speed = gt.v_WB.x();
  truth_.min_clearance = std::min(truth_.min_clearance, gt.obstacle_clearance_m);
  for (int j = 0; j < model::kNumJoints; ++j) {
    double& peak = truth_.max_applied_torque[static_cast<std::size_t>(j % model::kJointsPerLeg)];
    peak = std::max(peak, std::abs(gt.tau[j]));
  }
  if (m == Mode::Takeoff || m == Mode::Flight || m == Mode::Landing) {
    const auto jump = static_cast<std::size_t>(loop.stateMachine().landings());
    if (truth_.jump_clearance.size() <= jump)
      truth_.jump_clearance.resize(jump + 1, std::numeric_limits<double>::infinity());
    truth_.jump_clearance[jump] = std::min(truth_.jump_clearance[jump], gt.obstacle_clearance_m);
  }
  if (keep_frames_ && (frames_.empty() || t_read > frames_.back().t)) {
    viz::Frame f;
    f.t = t_read;
    f.p_WB = p;
    f.q_WB = Eigen::Quaterniond(R);
    for (int j = 0; j < model::kNumJoints; ++j) {
      f.q[j] = gt.q[j];
      f.qd[j] = gt.qd[j];
      f.tau[j] = gt.tau[j];
    }
    f.p_WC = gt.p_WC;
    f.phase = std::string(toString(m));
    frames_.push_back(std::move(f));
    noteFrame(m, t_read, gt.p_WC.x());
  }
  truth_.body_hit_ground = truth_.body_hit_ground || gt.base_in_contact || gt.legs_in_contact;
  truth_.final_x = p.x();
  truth_.final_pitch = pitch;
  truth_.final_roll = roll;
  truth_.final_y = p.y();
  truth_.final_heading = euler.z();
  if (!std::isnan(truth_.touchdown_dx))
    truth_.max_heading_after_landing =
        std::max(truth_.max_heading_after_landing, std::abs(euler.z()));
  truth_.final_speed = gt.v_WB.x();
  truth_.final_height = p.z();
  double front = -1e9;
  for (const model::Leg leg : {model::Leg::LF, model::Leg::RF})
    front = std::max(front, p.x() + R(0, 0) * robot_.legGeometry(leg).p_BH.x());
  truth_.final_front_wheel_x = front + robot_.wheelRadius();
  // Estimator error (position drifts by design in x and y; the height and velocity are
  // observable).
  const estimation::EstimatedState& e = loop.estimate();
  pos_err2_ += (e.p_WB - p).squaredNorm();
  truth_.est_pos_max = std::max(truth_.est_pos_max, (e.p_WB - p).norm());
  vel_err2_ += (e.v_WB - gt.v_WB).squaredNorm();
  ++err_n_;
}

RunSummary RunRecorder::summarise(const ControlLoop& loop, const PlanRequester* requester,
                                  const Backend& backend, const MpcCounters& mpc) {
  RunSummary s;
  s.scenario = scenario_.name;
  s.backend = backend.name();
  s.can_report = backend.canReport();
  const JumpStateMachine& fsm = loop.stateMachine();
  s.jumped = fsm.jumped();
  s.landings = fsm.landings();
  s.abort_reason =
      fsm.abortReason() == Reason::Start ? "" : std::string(toString(fsm.abortReason()));
  s.final_mode = std::string(toString(loop.mode()));
  s.takeoff_speed_est = loop.takeoffSpeed();
  s.transitions = transitions_;
  s.mpc = mpc;
  s.sim_time_s = loop.time();
  if (requester != nullptr && requester->status() != PlanStatus::None &&
      requester->status() != PlanStatus::Pending) {
    const PlanRequestInfo& info = requester->info();
    s.plan_latency_ms = info.latency_ms;
    s.plan_source = info.source;
    s.plan_verification = info.verification;
    s.plan_summary = info.summary;
    s.plan_target_height = info.target_height_m;
    if (info.feasible || !info.source.empty()) {
      s.planned_apex_base_z = info.predicted.apex.base_z;
      s.planned_apex_com_z = info.predicted.apex.state.z;
      s.planned_clearance = info.predicted.min_obstacle_clearance;
      s.planned_touchdown_dx = info.predicted.touchdown.state.x;
      s.service_verified = info.simulated;
      s.service_verified_available = info.verification == "passed" || info.verification == "failed";
      s.planned_liftoff_vx = info.predicted.takeoff.state.vx;
      s.planned_liftoff_vz = info.predicted.takeoff.state.vz;
      s.planned_liftoff_pitch_rate = info.predicted.takeoff.state.pitch_rate;
      s.planned_touchdown_rotation = info.predicted.touchdown.state.pitch;
    }
  }
  // The peak torques: applied by the simulated drives when the run has a ground truth (the
  // torque sensor adds noise: its reading may exceed the limit the drive saturates at), else
  // measured by the drives.
  s.max_torque_source = truth_.available ? "applied" : "measured";
  for (int j = 0; j < model::kNumJoints; ++j) {
    const int kind = j % model::kJointsPerLeg;
    const double peak = truth_.available ? truth_.max_applied_torque[static_cast<std::size_t>(kind)]
                                         : loop.maxAbsTorque()[j];
    s.max_torque[kind] = std::max(s.max_torque[kind], peak);
    s.torque_limit[kind] = robot_.joints()[j].actuator.peak_torque_nm;
  }
  s.actuators_file = scenario_.actuators_file;
  if (err_n_ > 0) {
    truth_.est_pos_rms = std::sqrt(pos_err2_ / static_cast<double>(err_n_));
    truth_.est_vel_rms = std::sqrt(vel_err2_ / static_cast<double>(err_n_));
  }
  s.truth = truth_;

  // Verdict.
  std::ostringstream v;
  if (loop.mode() == Mode::Damping) {
    // After a jump the state machine keeps no abort reason; the transition into damping has it.
    std::string why = s.abort_reason;
    for (const Transition& t : transitions_)
      if (t.to == Mode::Damping && why.empty()) why = std::string(toString(t.reason));
    v << "damping mode (" << why << ")";
  } else if (!s.jumped) {
    v << "no jump: " << (s.abort_reason.empty() ? "run ended" : s.abort_reason);
    if (truth_.available && scenario_.has_wall) {
      const bool before =
          truth_.final_front_wheel_x < scenario_.wallX(0) && truth_.min_clearance > 0.0;
      v << (before ? "; stopped before the wall" : "; DID NOT STOP before the wall");
    }
  } else {
    const bool upright = std::abs(truth_.final_pitch) < 0.3 && std::abs(truth_.final_roll) < 0.3;
    // A flip (more than half a turn asked for) must have turned it: upright after no turn or
    // after a turn too many is not the maneuver.
    const bool flip = std::abs(scenario_.target_pitch_change_rad) > M_PI;
    const bool turned =
        !flip || std::abs(truth_.final_rotation - scenario_.target_pitch_change_rad) < 1.0;
    const bool stopped = loop.mode() == Mode::Stand;
    // Onto a platform: the base ends over it, at least its height above the ground.
    const bool platform = scenario_.landsOnWall();
    const bool on_top = platform && truth_.final_x > scenario_.wallX(0) &&
                        truth_.final_x < scenario_.wallX(0) + scenario_.wall_thickness_m &&
                        truth_.final_height > scenario_.wall_height_m + 0.1;
    // Every wall jumped (a course: one after the other, without stopping between them).
    const int walls = scenario_.jumps();
    const bool all_jumped = fsm.landings() == walls;
    const double last_wall = scenario_.has_wall ? scenario_.wall_x_m.back() : 0.0;
    const bool cleared =
        !scenario_.has_wall ||
        (platform ? on_top
                  : all_jumped && truth_.min_clearance > 0.0 && truth_.final_x > last_wall);
    // Rolled on at the commanded speed after the landing (within 5 %), when asked to.
    const bool roll_on = scenario_.after_landing == AfterLanding::RollOn;
    const bool rolled_on =
        !roll_on ||
        (fsm.rolledOn() && std::abs(truth_.roll_on_speed - scenario_.roll_on_speed_m_s) <=
                               0.05 * scenario_.roll_on_speed_m_s + 0.02);
    if (!truth_.available) {
      s.success = stopped && (!roll_on || fsm.rolledOn());
      v << (stopped ? "jumped and stopped" : "jumped, not stopped");
    } else {
      s.success = upright && turned && stopped && cleared && rolled_on && !truth_.body_hit_ground;
      v << (platform    ? (cleared ? "landed on the platform" : "DID NOT LAND on the platform")
            : walls > 1 ? (cleared ? "cleared all " + std::to_string(walls) + " walls"
                                   : "DID NOT CLEAR all " + std::to_string(walls) + " walls (" +
                                         std::to_string(fsm.landings()) + " jumped)")
            : scenario_.has_wall ? (cleared ? "cleared the wall" : "DID NOT CLEAR the wall")
                                 : "jumped")
        << (flip ? (turned ? ", turned " : ", DID NOT TURN as asked: ") +
                       fmt(truth_.final_rotation, 2) + " rad"
                 : std::string())
        << (upright ? ", landed upright" : ", NOT upright")
        << (truth_.body_hit_ground ? ", body touched the ground" : "")
        << (roll_on ? (rolled_on ? ", rolled on" : ", DID NOT ROLL ON") : "")
        << (stopped ? ", stopped" : ", not stopped");
    }
  }
  s.verdict = v.str();
  return s;
}

nlohmann::json RunSummary::toJson() const {
  nlohmann::json j;
  j["scenario"] = scenario;
  j["backend"] = backend;
  j["success"] = success;
  j["verdict"] = verdict;
  j["jumped"] = jumped;
  j["landings"] = landings;
  j["abort_reason"] = abort_reason;
  j["final_mode"] = final_mode;
  j["takeoff_speed_estimated_m_s"] = num(takeoff_speed_est);
  j["plan"] = {{"latency_ms", num(plan_latency_ms)},
               {"source", plan_source},
               {"verification", plan_verification},
               {"summary", plan_summary},
               {"target_com_height_m", num(plan_target_height)},
               {"predicted_apex_base_z_m", num(planned_apex_base_z)},
               {"predicted_apex_com_z_m", num(planned_apex_com_z)},
               {"predicted_clearance_m", num(planned_clearance)},
               {"predicted_touchdown_dx_m", num(planned_touchdown_dx)},
               {"predicted_liftoff_vx_m_s", num(planned_liftoff_vx)},
               {"predicted_liftoff_vz_m_s", num(planned_liftoff_vz)},
               {"predicted_liftoff_pitch_rate_rad_s", num(planned_liftoff_pitch_rate)},
               {"predicted_touchdown_rotation_rad", num(planned_touchdown_rotation)}};
  j["actuators_file"] = actuators_file;
  if (truth.available)
    j["simulated"] = {{"takeoff_speed_m_s", num(truth.takeoff_speed)},
                      {"apex_base_z_m", num(truth.apex_base_z)},
                      {"apex_com_z_m", num(truth.apex_com_z)},
                      {"min_wall_clearance_m", num(truth.min_clearance)},
                      {"touchdown_dx_m", num(truth.touchdown_dx)},
                      {"liftoff_vx_m_s", num(truth.liftoff_vx)},
                      {"liftoff_vz_m_s", num(truth.liftoff_vz)},
                      {"liftoff_pitch_rate_rad_s", num(truth.liftoff_pitch_rate)},
                      {"touchdown_rotation_rad", num(truth.touchdown_rotation)},
                      {"final_rotation_rad", num(truth.final_rotation)},
                      {"body_touched_ground", truth.body_hit_ground},
                      {"roll_on_speed_m_s", num(truth.roll_on_speed)},
                      {"final_x_m", truth.final_x},
                      {"final_pitch_rad", truth.final_pitch},
                      {"final_roll_rad", truth.final_roll},
                      {"final_y_m", truth.final_y},
                      {"final_heading_rad", truth.final_heading},
                      {"max_heading_after_landing_rad", truth.max_heading_after_landing},
                      {"final_speed_m_s", truth.final_speed},
                      {"estimator_position_rms_m", truth.est_pos_rms},
                      {"estimator_position_max_m", truth.est_pos_max},
                      {"jump_wall_clearance_m", truth.jump_clearance},
                      {"estimator_velocity_rms_m_s", truth.est_vel_rms}};
  nlohmann::json torques = nlohmann::json::object();
  for (int k = 0; k < model::kJointsPerLeg; ++k)
    torques[kKindNames[k]] = {{"max_nm", max_torque[k]}, {"limit_nm", torque_limit[k]}};
  j["max_torque"] = torques;
  j["max_torque_source"] = max_torque_source;
  nlohmann::json trs = nlohmann::json::array();
  for (const Transition& t : transitions)
    trs.push_back({{"t", t.t},
                   {"from", toString(t.from)},
                   {"to", toString(t.to)},
                   {"reason", toString(t.reason)},
                   {"com_x", t.com_x},
                   {"speed", t.speed}});
  j["transitions"] = trs;
  j["mpc"] = {{"cycles", mpc.cycles},
              {"iterations_per_cycle", mpc.iterations_per_cycle},
              {"failed", mpc.failed},
              {"max_violation", mpc.max_violation},
              {"max_ms", mpc.max_ms}};
  j["sim_time_s"] = sim_time_s;
  j["wall_s"] = wall_s;
  if (!loop_stats.is_null()) j["loop"] = loop_stats;
  if (!can_report.empty()) j["can"] = can_report;
  return j;
}

void RunSummary::printTable(std::ostream& out) const {
  const auto row = [&](const std::string& what, const std::string& a, const std::string& b) {
    out << "  " << std::left << std::setw(30) << what << std::setw(18) << a << b << "\n";
  };
  out << "\n== robot_client: scenario " << scenario << " on " << backend << " ==\n";
  row("", "planned/estimated", "simulated");
  row("speed at take-off [m/s]", fmt(takeoff_speed_est), fmt(truth.takeoff_speed));
  row("apex, base height [m]", fmt(planned_apex_base_z), fmt(truth.apex_base_z));
  row("apex, CoM height [m]", fmt(planned_apex_com_z), fmt(truth.apex_com_z));
  if (scenario == "vertical") row("  (paper: 0.5 m on hardware,", "0.7 m target)", "");
  row("wall clearance [m]", fmt(planned_clearance),
      std::isfinite(truth.min_clearance) ? fmt(truth.min_clearance) : "-");
  row("lift-off CoM vx, vz [m/s]", fmt(planned_liftoff_vx) + ", " + fmt(planned_liftoff_vz),
      fmt(truth.liftoff_vx) + ", " + fmt(truth.liftoff_vz));
  row("lift-off pitch rate [rad/s]", fmt(planned_liftoff_pitch_rate),
      fmt(truth.liftoff_pitch_rate));
  row("touchdown dx, CoM [m]", fmt(planned_touchdown_dx), fmt(truth.touchdown_dx));
  row("rotation at touchdown [rad]", fmt(planned_touchdown_rotation),
      fmt(truth.touchdown_rotation));
  row("heading after landing [rad]", "0",
      "max " + fmt(truth.max_heading_after_landing) + ", end " + fmt(truth.final_heading));
  if (service_verified_available)
    out << "  service's verification (from the plan's ideal start): apex base "
        << fmt(service_verified.apex.base_z) << " m, clearance "
        << fmt(service_verified.min_obstacle_clearance) << " m, lift-off vx, vz, pitch rate "
        << fmt(service_verified.takeoff.state.vx) << ", " << fmt(service_verified.takeoff.state.vz)
        << ", " << fmt(service_verified.takeoff.state.pitch_rate) << ", touchdown dx "
        << fmt(service_verified.touchdown.state.x) << " m\n";
  row("plan latency [ms]", fmt(plan_latency_ms, 1),
      plan_source.empty() ? "-" : plan_source + ", verification " + plan_verification);
  if (!plan_summary.empty())
    out << "  plan (target CoM height " << fmt(plan_target_height) << " m): " << plan_summary
        << "\n";
  const int kfe = static_cast<int>(model::JointKind::KFE);
  out << "  robot " << actuators_file << ": knee peak torque " << fmt(max_torque[kfe], 1)
      << " of its " << fmt(torque_limit[kfe], 0) << " Nm limit (" << max_torque_source << ")\n";
  out << "  max |torque| per joint kind (limit):";
  for (int k = 0; k < model::kJointsPerLeg; ++k)
    out << "  " << kKindNames[k] << " " << fmt(max_torque[k], 1) << "/" << fmt(torque_limit[k], 0);
  out << " Nm\n";
  if (truth.available)
    out << "  estimator error vs truth (RMS): position " << fmt(truth.est_pos_rms)
        << " m, velocity " << fmt(truth.est_vel_rms) << " m/s\n";
  out << "  NMPC cycles " << mpc.cycles << " (" << mpc.iterations_per_cycle
      << " SQP iteration(s) each; " << mpc.failed << " failed; largest residual "
      << fmtSci(mpc.max_violation) << "), " << fmt(sim_time_s, 2) << " s robot time in "
      << fmt(wall_s, 1) << " s wall\n";
  if (!can_report.empty()) out << "  CAN: " << can_report << "\n";
  out << "  transitions:";
  for (const Transition& t : transitions) out << " " << toString(t.to) << "@" << fmt(t.t, 2);
  out << "\n  verdict: " << verdict << (success ? " -> SUCCESS" : " -> FAILED") << "\n";
}

void RunRecorder::noteFrame(Mode m, double t, double com_x) {
  if (m == Mode::Takeoff && last_frame_mode_ != Mode::Takeoff) jumps_.push_back({t, com_x, {}});
  last_frame_mode_ = m;
}

std::vector<viz::PathPoint> RunRecorder::plannedPath(const planner::JumpPlan& plan,
                                                     const JumpTrace& jump) const {
  // The plan is in its jump frame: x from the CoM at the start of take-off, z from the ground.
  std::vector<viz::PathPoint> path;
  path.reserve(static_cast<std::size_t>(plan.numSamples()));
  for (int k = 0; k < plan.numSamples(); ++k)
    path.push_back(
        {jump.takeoff_t + k * plan.dt,
         Eigen::Vector3d(jump.takeoff_com_x + plan.centroidal[k].x, 0.0, plan.centroidal[k].z)});
  return path;
}

void RunRecorder::notePlan(const PlanRequester* requester) {
  if (jumps_.empty() || !jumps_.back().planned_com.empty() || requester == nullptr ||
      requester->status() != PlanStatus::Feasible)
    return;
  jumps_.back().planned_com = plannedPath(requester->plan(), jumps_.back());
}

viz::Recording RunRecorder::recording(const ControlLoop& loop,
                                      const PlanRequester* requester) const {
  viz::Recording rec;
  rec.title = "robot_client " + scenario_.name;
  rec.source = truth_.available ? "simulated" : "estimated";
  rec.frames = frames_;
  if (scenario_.has_wall)
    for (const double x : scenario_.wall_x_m)
      rec.boxes.push_back(
          {Eigen::Vector3d(x, -1.0, 0.0),
           Eigen::Vector3d(x + scenario_.wall_thickness_m, 1.0, scenario_.wall_height_m)});
  const double takeoff = loop.takeoffTime();
  if (std::isfinite(takeoff)) {
    rec.jump_start_t = takeoff;
    for (const Transition& tr : transitions_)
      if (tr.to == Mode::Landing && tr.t >= takeoff) {
        rec.touchdown_t = tr.t;
        break;
      }
  }
  // The last jump's plan (the requester's), and every jump's own when there are several.
  if (!jumps_.empty()) {
    rec.planned_com = jumps_.back().planned_com;
    if (rec.planned_com.empty() && requester != nullptr &&
        requester->status() == PlanStatus::Feasible)
      rec.planned_com = plannedPath(requester->plan(), jumps_.back());
  }
  if (jumps_.size() > 1)
    for (const JumpTrace& j : jumps_) {
      viz::JumpSpan span;
      span.start_t = j.takeoff_t;
      for (const Transition& tr : transitions_)
        if (tr.to == Mode::Landing && tr.t >= j.takeoff_t) {
          span.touchdown_t = tr.t;
          break;
        }
      span.planned_com = &j == &jumps_.back() ? rec.planned_com : j.planned_com;
      rec.jumps.push_back(std::move(span));
    }
  if (requester != nullptr && requester->status() == PlanStatus::Feasible &&
      std::isfinite(takeoff)) {
    const planner::JumpPlan& plan = requester->plan();
    rec.liftoff_t = takeoff + plan.t2;
    if (plan.t2 - plan.t1 > plan.dt) rec.front_liftoff_t = takeoff + plan.t1;
    for (int k = 0; k < plan.numSamples(); ++k) {
      viz::PlannedJoints p;
      p.t = takeoff + k * plan.dt;
      for (int j = 0; j < model::kNumJoints; ++j) {
        p.qd[j] = plan.qd(k, j);
        p.tau[j] = plan.tau(k, j);
      }
      rec.planned_joints.push_back(p);
    }
  }
  return rec;
}

void RunRecorder::plotKnees(const std::string& png, const ControlLoop& loop,
                            const PlanRequester* requester) const {
  if (!std::isfinite(loop.takeoffTime()) || frames_.empty()) {
    spdlog::warn("no knee figure {}: the robot did not jump", png);
    return;
  }
  viz::writeKneeFigure(robot_, recording(loop, requester), png);
}

void RunRecorder::plot(const std::string& png, const ControlLoop& loop) const {
  if (csv_path_.empty()) {
    spdlog::warn("--plot needs --csv (the figure is drawn from the telemetry)");
    return;
  }
  const double takeoff = loop.takeoffTime();
  std::ostringstream gp;
  const auto& hfe = robot_.joint(model::Leg::LF, model::JointKind::HFE).actuator;
  // Columns: 1 t, 5 est_z, 6 est_vx, 12.. q (16), 28.. qd, 44.. tau, 60..63 fn, 64 compute,
  // 65 true_x, 66 true_z, 67 true_vx, 68 true_pitch, 69 true_com_x, 70 true_com_z.
  gp << "set terminal pngcairo size 1200,1100 font ',10'\n"
     << "set output '" << png << "'\nset datafile separator ','\nset key outside right\nset grid\n"
     << "set multiplot layout 3,1 title 'robot\\_client " << scenario_.name << "'\n";
  if (std::isfinite(takeoff))
    gp << "set arrow from " << takeoff << ", graph 0 to " << takeoff
       << ", graph 1 nohead dt 3 lc 'gray'\n";
  gp << "set ylabel 'speed [m/s]'\nplot '" << csv_path_
     << "' every ::1 using 1:6 w l t 'estimated vx', '' every ::1 using 1:67 w l t 'true vx'\n"
     << "set ylabel 'height [m]'\nplot '" << csv_path_
     << "' every ::1 using 1:5 w l t 'estimated base z', '' every ::1 using 1:66 w l t 'true base "
        "z', '' every ::1 using 1:70 w l t 'true CoM z'\n"
     << "set ylabel 'LF torque [Nm]'\nplot '" << csv_path_
     << "' every ::1 using 1:44 w l t 'HAA', '' every ::1 using 1:45 w l t 'HFE', '' every ::1 "
        "using 1:46 w l t 'KFE', '' every ::1 using 1:47 w l t 'WHEEL', "
     << hfe.peak_torque_nm << " dt 2 lc 'red' t 'peak', " << -hfe.peak_torque_nm
     << " dt 2 lc 'red' notitle\nunset multiplot\n";
  const std::string script = png + ".gp";
  {
    std::ofstream f(script);
    f << gp.str();
  }
  const std::string cmd = "gnuplot '" + script + "'";
  if (std::system(cmd.c_str()) != 0) spdlog::warn("gnuplot failed for {}", png);
}

}  // namespace wj::robot_client
