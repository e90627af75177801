#include "robot_client/plan_requester.h"

#include <google/protobuf/util/json_util.h>

#include <cmath>
#include <fstream>
#include <future>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "planner/plan_knots.h"
#include "planner_client/compact_knots.h"
#include "planner_client/planner_client.h"
#include "wheeljump/planner/v1/jump_planner.pb.h"

namespace wj::robot_client {

namespace v1 = wheeljump::planner::v1;

namespace {

constexpr int kIdle = 0, kWriting = 3, kPosted = 1, kStop = 4;

void setVector(v1::Vector3* out, const Eigen::Vector3d& v) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

v1::PlanJumpRequest makeRequest(const PlanRequestSnapshot& s, const PlannerConnection& c) {
  v1::PlanJumpRequest r;
  v1::RobotState* st = r.mutable_state();
  setVector(st->mutable_base_position_w_m(), s.p_WB);
  v1::Quaternion* q = st->mutable_base_orientation_w();
  const Eigen::Quaterniond qn = s.q_WB.normalized();
  q->set_w(qn.w());
  q->set_x(qn.x());
  q->set_y(qn.y());
  q->set_z(qn.z());
  setVector(st->mutable_base_linear_velocity_w_m_s(), s.v_WB);
  setVector(st->mutable_base_angular_velocity_b_rad_s(), s.omega_B);
  for (int j = 0; j < model::kNumJoints; ++j) {
    st->add_joint_positions_rad(s.q[j]);
    st->add_joint_velocities_rad_s(s.qd[j]);
  }
  st->set_stamp_s(s.t);
  v1::JumpTask* task = r.mutable_task();
  task->set_target_dx_m(s.target_dx_m);
  task->set_target_height_m(s.target_height_m);
  task->set_target_pitch_change_rad(s.target_pitch_change_rad);
  task->set_event(s.event == planner::TargetEvent::Apex ? v1::TARGET_EVENT_APEX
                                                        : v1::TARGET_EVENT_TOUCHDOWN);
  task->set_takeoff_mode(s.mode == planner::TakeoffMode::TwoStep ? v1::TAKEOFF_MODE_TWO_STEP
                                                                 : v1::TAKEOFF_MODE_SIMULTANEOUS);
  if (s.has_obstacle) {
    v1::BoxObstacle* o = task->mutable_obstacle();
    o->set_x_min_m(s.obstacle_x_min_m);
    o->set_x_max_m(s.obstacle_x_max_m);
    o->set_height_m(s.obstacle_height_m);
  }
  v1::ComputeBudget* b = r.mutable_budget();
  b->set_max_evaluations(c.max_evaluations);
  b->set_seed(s.seed != 0 ? s.seed : c.seed);
  b->set_skip_verification(c.skip_verification);
  using Format = PlannerConnection::Format;
  r.set_trajectory_format(c.format == Format::CompactKnots ? v1::TRAJECTORY_FORMAT_COMPACT_KNOTS
                          : c.format == Format::Knots      ? v1::TRAJECTORY_FORMAT_KNOTS
                                                           : v1::TRAJECTORY_FORMAT_DENSE);
  std::ostringstream id;
  id << "jump-" << std::lround(s.t * 1000.0);
  r.set_request_id(id.str());
  return r;
}

planner::JumpEvent fromProto(const v1::JumpEvent& e) {
  planner::JumpEvent out;
  out.t = e.t_s();
  out.state = {e.com_x_m(),    e.com_z_m(),    e.pitch_rad(),
               e.com_vx_m_s(), e.com_vz_m_s(), e.pitch_rate_rad_s()};
  out.base_z = e.base_z_m();
  return out;
}

planner::JumpOutcome fromProto(const v1::JumpOutcome& o) {
  planner::JumpOutcome out;
  out.takeoff = fromProto(o.takeoff());
  out.apex = fromProto(o.apex());
  out.touchdown = fromProto(o.touchdown());
  out.min_obstacle_clearance = o.min_obstacle_clearance_m();
  return out;
}

planner::Polynomial fromProto(const v1::Polynomial& p) {
  return planner::Polynomial{{p.coefficients().begin(), p.coefficients().end()}};
}

std::string sourceName(v1::PlanSource s) {
  switch (s) {
    case v1::PLAN_SOURCE_CACHE_HIT:
      return "cache_hit";
    case v1::PLAN_SOURCE_CACHE_MISS:
      return "cache_miss";
    case v1::PLAN_SOURCE_WARM_START:
      return "warm_start";
    case v1::PLAN_SOURCE_COALESCED:
      return "coalesced";
    default:
      return "unspecified";
  }
}

std::string verificationName(v1::VerificationStatus s) {
  switch (s) {
    case v1::VERIFICATION_STATUS_PASSED:
      return "passed";
    case v1::VERIFICATION_STATUS_FAILED:
      return "failed";
    case v1::VERIFICATION_STATUS_NOT_RUN:
      return "not_run";
    default:
      return "unspecified";
  }
}

}  // namespace

Eigen::Vector3d requestVelocity(const Eigen::Vector3d& v_WB, const Eigen::Quaterniond& q_WB) {
  const Eigen::Vector3d x_B = q_WB.normalized() * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d heading(x_B.x(), x_B.y(), 0.0);
  if (!(heading.squaredNorm() > 1e-12)) return v_WB;
  const Eigen::Vector3d h = heading.normalized();
  const double along = v_WB.dot(h);
  // Clamped a hair inside the planner's range: the service projects the sent velocity on the
  // heading it reads from the sent quaternion, and at exactly -1 m/s its last bit fell outside
  // (noise seed 3: "must be in [-1, 4], got -1").
  const double lowest = kPlannerLowestSpeedMS + kRequestSpeedMarginMS;
  return along < lowest ? Eigen::Vector3d(v_WB + (lowest - along) * h) : v_WB;
}

bool applyTakeoffPosture(const ScenarioSettings& scenario,
                         std::array<double, model::kNumJoints>& q) {
  if (!scenario.has_takeoff_posture) return false;
  const double tol = scenario.takeoff_posture_max_offset_rad;
  for (const model::Leg leg : model::kLegs) {
    const double hfe = q[model::jointIndex(leg, model::JointKind::HFE)];
    const double kfe = q[model::jointIndex(leg, model::JointKind::KFE)];
    if (!(std::abs(hfe - scenario.takeoff_hfe_rad) <= tol) ||
        !(std::abs(kfe - scenario.takeoff_kfe_rad) <= tol))
      return false;
  }
  for (const model::Leg leg : model::kLegs) {
    q[model::jointIndex(leg, model::JointKind::HFE)] = scenario.takeoff_hfe_rad;
    q[model::jointIndex(leg, model::JointKind::KFE)] = scenario.takeoff_kfe_rad;
  }
  return true;
}

namespace {

// The header of a plan: phase times and force polynomials.
void convertHeader(const v1::Plan& p, planner::JumpPlan& plan) {
  plan = planner::JumpPlan{};
  plan.t1 = p.phase_times().t1_s();
  plan.t2 = p.phase_times().t2_s();
  plan.t3 = p.phase_times().t3_s();
  plan.mode = p.force_phases_size() > 1 ? planner::TakeoffMode::TwoStep
                                        : planner::TakeoffMode::Simultaneous;
  for (const v1::ForcePhase& fp : p.force_phases()) {
    planner::ForcePhase f;
    f.t_start = fp.t_start_s();
    f.t_end = fp.t_end_s();
    f.hind = {fromProto(fp.hind().fx_n()), fromProto(fp.hind().fz_n())};
    f.front = {fromProto(fp.front().fx_n()), fromProto(fp.front().fz_n())};
    plan.force_phases.push_back(std::move(f));
  }
}

// A plan sent as knots (`k`: the plan's own, or its compact knots expanded), densified at the
// executor's 1 kHz.
std::string convertKnots(const v1::Plan& p, const v1::TrajectoryKnots& k, planner::JumpPlan& plan) {
  constexpr double kDenseDt = 0.001;
  const int n = k.t_s_size();
  const std::size_t values = static_cast<std::size_t>(n) * model::kNumJoints;
  if (static_cast<std::size_t>(k.positions_rad_size()) != values ||
      static_cast<std::size_t>(k.velocities_rad_s_size()) != values ||
      static_cast<std::size_t>(k.torques_nm_size()) != values)
    return "knot arrays do not match the knot count x 16";
  if (k.centroidal_size() != 6 * n) return "knot CoM states do not match the knot count x 6";
  convertHeader(p, plan);
  planner::PlanKnots& K = plan.knots;
  K.t.assign(k.t_s().begin(), k.t_s().end());
  using KnotMajor = Eigen::Matrix<float, Eigen::Dynamic, model::kNumJoints, Eigen::RowMajor>;
  K.q = Eigen::Map<const KnotMajor>(k.positions_rad().data(), n, model::kNumJoints).cast<double>();
  K.qd =
      Eigen::Map<const KnotMajor>(k.velocities_rad_s().data(), n, model::kNumJoints).cast<double>();
  K.tau = Eigen::Map<const KnotMajor>(k.torques_nm().data(), n, model::kNumJoints).cast<double>();
  K.centroidal.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const float* c = k.centroidal().data() + 6 * i;
    K.centroidal[static_cast<std::size_t>(i)] = {c[0], c[1], c[2], c[3], c[4], c[5]};
  }
  try {
    planner::densify(plan, kDenseDt);  // checks the knots first (planner::checkKnots)
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// A plan sent as dense samples.
std::string convertDense(const v1::Plan& p, planner::JumpPlan& plan) {
  const v1::JointTrajectory& jt = p.joints();
  const int n = static_cast<int>(jt.num_samples());
  const std::size_t values = static_cast<std::size_t>(n) * model::kNumJoints;
  if (n < 2) return "the plan has fewer than 2 joint samples";
  if (static_cast<std::size_t>(jt.positions_rad_size()) != values ||
      static_cast<std::size_t>(jt.velocities_rad_s_size()) != values ||
      static_cast<std::size_t>(jt.torques_nm_size()) != values)
    return "joint trajectory sizes do not match num_samples x 16";
  if (p.centroidal_trajectory_size() != n)
    return "centroidal trajectory has " + std::to_string(p.centroidal_trajectory_size()) +
           " samples, joints " + std::to_string(n);
  convertHeader(p, plan);
  plan.dt = jt.sample_period_s();
  plan.q.resize(n, model::kNumJoints);
  plan.qd.resize(n, model::kNumJoints);
  plan.tau.resize(n, model::kNumJoints);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < model::kNumJoints; ++j) {
      const int i = k * model::kNumJoints + j;
      plan.q(k, j) = jt.positions_rad(i);
      plan.qd(k, j) = jt.velocities_rad_s(i);
      plan.tau(k, j) = jt.torques_nm(i);
    }
  plan.centroidal.reserve(static_cast<std::size_t>(n));
  for (const v1::CentroidalSample& c : p.centroidal_trajectory())
    plan.centroidal.push_back({c.com_x_m(), c.com_z_m(), c.pitch_rad(), c.com_vx_m_s(),
                               c.com_vz_m_s(), c.pitch_rate_rad_s()});
  return "";
}

// One line of JSON per request, appended (the worker thread; never the loop).
void logRequest(const v1::PlanJumpRequest& request, const std::string& path) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  if (!google::protobuf::util::MessageToJsonString(request, &json, options).ok()) return;
  std::ofstream out(path, std::ios::app);
  out << json << "\n";
}

}  // namespace

std::string PlanRequester::convert(const v1::PlanJumpResponse& response, planner::JumpPlan& plan) {
  const v1::Plan& p = response.plan();
  std::string problem;
  if (p.compact_knots().t_s_size() > 0) {
    v1::TrajectoryKnots knots;
    problem = client::expandKnots(p.compact_knots(), &knots);
    if (problem.empty()) problem = convertKnots(p, knots, plan);
  } else {
    problem = p.knots().t_s_size() > 0 ? convertKnots(p, p.knots(), plan) : convertDense(p, plan);
  }
  if (!problem.empty()) return problem;
  const int n = plan.numSamples();
  plan.initial = plan.centroidal.front();
  plan.q_initial = plan.q.row(0).transpose();
  plan.q_landing = plan.q.row(n - 1).transpose();
  plan.decision =
      Eigen::Map<const Eigen::VectorXd>(p.decision_vector().data(), p.decision_vector_size());
  plan.predicted = fromProto(response.predicted());
  return sim::checkPlan(plan);
}

PlanRequester::PlanRequester(const std::string& target, const PlannerConnection& connection,
                             const model::RobotModel& robot, const sim::ExecutorSettings& executor,
                             double gravity_m_s2)
    : connection_(connection), robot_(robot), executor_settings_(executor), gravity_(gravity_m_s2) {
  client::ClientOptions options;
  options.target = target;
  options.load_balancing =
      connection.round_robin ? client::LoadBalancing::RoundRobin : client::LoadBalancing::PickFirst;
  options.use_tls = connection.tls;
  options.tls.root_ca_file = connection.tls_root_ca_file;
  options.tls.cert_chain_file = connection.tls_cert_file;
  options.tls.private_key_file = connection.tls_key_file;
  options.tls.target_name_override = connection.tls_server_name;
  options.default_deadline =
      std::chrono::milliseconds(static_cast<long>(connection.deadline_s * 1000.0));
  client_ = std::make_unique<client::PlannerClient>(options);
  worker_ = std::thread([this] { run(); });
}

PlanRequester::~PlanRequester() {
  stop_.store(true);
  slot_state_.store(kStop);
  slot_state_.notify_all();
  client_->cancelAll();
  worker_.join();
}

bool PlanRequester::post(const PlanRequestSnapshot& snapshot) {
  int expected = kIdle;
  if (!slot_state_.compare_exchange_strong(expected, kWriting, std::memory_order_acquire))
    return false;
  slot_ = snapshot;
  status_.store(PlanStatus::Pending, std::memory_order_release);
  slot_state_.store(kPosted, std::memory_order_release);
  slot_state_.notify_one();
  return true;
}

void PlanRequester::run() {
  for (;;) {
    const int s = slot_state_.load(std::memory_order_acquire);
    if (s == kStop || stop_.load()) return;
    if (s != kPosted) {
      slot_state_.wait(s, std::memory_order_acquire);
      continue;
    }
    const PlanRequestSnapshot snapshot = slot_;
    handle(snapshot);
    int posted = kPosted;
    slot_state_.compare_exchange_strong(posted, kIdle, std::memory_order_release);
  }
}

void PlanRequester::handle(const PlanRequestSnapshot& snapshot) {
  const auto start = std::chrono::steady_clock::now();
  const auto deadline =
      std::chrono::milliseconds(static_cast<long>(connection_.deadline_s * 1000.0));
  const v1::PlanJumpRequest request = makeRequest(snapshot, connection_);
  if (!connection_.request_log_file.empty()) logRequest(request, connection_.request_log_file);
  client::PlanResult result = client_->planJump(request, deadline).get();
  PlanRequestInfo info;
  info.latency_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  info.attempts = result.attempts;
  info.target_height_m = snapshot.target_height_m;
  PlanStatus status = PlanStatus::Failed;
  if (!result.ok()) {
    info.summary = "status " + std::to_string(static_cast<int>(result.status.error_code())) + ": " +
                   result.status.error_message();
  } else {
    const v1::PlanJumpResponse& r = result.response;
    info.source = sourceName(r.source());
    // The service's hot tier answered with the plan of an earlier request of the same cache
    // bin (planned_for, within half a bin of this state); the executor tracks it from the
    // robot's own state all the same (docs/service.md, "Hot tier").
    if (r.ready_response()) info.source += "_ready";
    info.verification = verificationName(r.verification().status());
    info.summary = r.feasibility().summary();
    if (r.ready_response()) {
      const Eigen::Vector3d x_B = snapshot.q_WB.normalized() * Eigen::Vector3d::UnitX();
      const Eigen::Vector2d h = Eigen::Vector2d(x_B.x(), x_B.y()).normalized();
      std::ostringstream from;
      from << std::fixed << std::setprecision(3) << " (planned for v0 " << r.planned_for().v0_m_s()
           << " m/s, pitch " << r.planned_for().pitch_rad() << " rad; this state v0 "
           << snapshot.v_WB.head<2>().dot(h) << " m/s)";
      info.summary += from.str();
    }
    info.feasible = r.feasibility().feasible();
    info.predicted = fromProto(r.predicted());
    info.simulated = fromProto(r.verification().simulated());
    const bool verified_ok = r.verification().status() != v1::VERIFICATION_STATUS_FAILED;
    // A target out of reach: the closest approach is flown if it meets every constraint and
    // the service's simulation of it passed (not merely skipped).
    bool constraints_hold = r.feasibility().margins_size() > 0;
    for (const v1::ConstraintMargin& m : r.feasibility().margins())
      constraints_hold = constraints_hold && m.worst_margin() >= 0.0;
    info.closest_approach = !info.feasible && snapshot.accept_closest_approach &&
                            constraints_hold && r.has_plan() &&
                            r.verification().status() == v1::VERIFICATION_STATUS_PASSED;
    if ((!info.feasible && !info.closest_approach) || !verified_ok) {
      status = PlanStatus::Infeasible;
      if (!verified_ok) {
        info.summary += "; verification failed";
        for (const std::string& why : r.verification().failure_reasons())
          info.summary += ": " + why;
      }
    } else {
      executor_.reset();
      const std::string problem = convert(r, plan_);
      if (problem.empty()) {
        executor_.emplace(robot_, plan_, executor_settings_, gravity_);
        status = PlanStatus::Feasible;
      } else {
        info.summary = "unusable plan: " + problem;
        status = PlanStatus::Failed;
      }
    }
  }
  info_ = std::move(info);
  status_.store(status, std::memory_order_release);
}

}  // namespace wj::robot_client
