#include "server/request_validation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string_view>
#include <utility>

namespace wj::server {

namespace {

[[noreturn]] void invalid(const std::string& message) {
  throw ServiceError(ErrorCode::InvalidArgument, message);
}

std::string fmt(double v) {
  std::ostringstream ss;
  ss << v;
  return ss.str();
}

// The checks below take the field's name in parts and join them only for the error message:
// a valid request (every hit) builds no string (docs/service.md, "Hits at the floor").
std::string fieldName(std::string_view field, std::string_view member = {}, int index = -1) {
  std::string name(field);
  name += member;
  if (index >= 0) name += "[" + std::to_string(index) + "]";
  return name;
}

void requireFinite(double v, std::string_view field, std::string_view member = {}, int index = -1) {
  if (!std::isfinite(v))
    invalid(fieldName(field, member, index) + " must be finite, got " + fmt(v));
}

void requireBound(double v, double bound, std::string_view field, std::string_view member = {},
                  int index = -1) {
  if (!std::isfinite(v) || std::abs(v) > bound)
    invalid(fieldName(field, member, index) + " must be finite and in [" + fmt(-bound) + ", " +
            fmt(bound) + "], got " + fmt(v));
}

void requireVector(std::string_view field, const v1::Vector3& v, double bound) {
  requireBound(v.x(), bound, field, ".x");
  requireBound(v.y(), bound, field, ".y");
  requireBound(v.z(), bound, field, ".z");
}

// Runs a planner check and renames its fields (e.g. "task.target.dx") to the proto's.
template <typename Check>
void withProtoNames(Check&& check,
                    std::initializer_list<std::pair<std::string_view, std::string_view>> names) {
  try {
    check();
  } catch (const std::invalid_argument& e) {
    std::string message = e.what();
    for (const auto& [from, to] : names) {
      if (message.rfind(from, 0) == 0) {
        message = std::string(to) + message.substr(from.size());
        break;
      }
    }
    invalid(message);
  }
}

// Front-most point of the front wheels along x of J, relative to the CoM at t = 0 [m].
double frontWheelReach(const model::RobotModel& robot, const planner::InitialState& initial) {
  const Eigen::VectorXd q = initial.q;
  const auto poses = robot.calcLinkPoses(q);
  const Eigen::Vector3d com = robot.calcCompositeInertia(q).com;
  const double c = std::cos(initial.pitch), s = std::sin(initial.pitch);
  double reach = -1e9;
  for (const model::Leg leg : {model::Leg::LF, model::Leg::RF}) {
    const auto& wheel = robot.joint(leg, model::JointKind::Wheel);
    const Eigen::Vector3d p = poses[static_cast<std::size_t>(wheel.child_link)].translation() - com;
    // Nose-up pitch is a rotation about -y: x_J = x_B cos(pitch) - z_B sin(pitch).
    reach = std::max(reach, p.x() * c - p.z() * s + robot.wheelRadius());
  }
  return reach;
}

}  // namespace

planner::InitialState toInitialState(const v1::RobotState& state, const model::RobotModel& robot) {
  requireVector("state.base_position_w_m", state.base_position_w_m(), RequestBounds::kMaxPositionM);
  const auto& qm = state.base_orientation_w();
  for (const auto& [name, v] :
       {std::pair{".w", qm.w()}, {".x", qm.x()}, {".y", qm.y()}, {".z", qm.z()}})
    requireFinite(v, "state.base_orientation_w", name);
  Eigen::Quaterniond q_WB(qm.w(), qm.x(), qm.y(), qm.z());
  const double norm = q_WB.norm();
  if (std::abs(norm - 1.0) > RequestBounds::kQuaternionNormTolerance)
    invalid("state.base_orientation_w must be a unit quaternion (norm within " +
            fmt(RequestBounds::kQuaternionNormTolerance) + " of 1), got norm " + fmt(norm));
  q_WB.normalize();
  const Eigen::Matrix3d R_WB = q_WB.toRotationMatrix();
  const double roll = std::atan2(R_WB(2, 1), R_WB(2, 2));
  if (std::abs(roll) > RequestBounds::kMaxRollRad)
    invalid("state.base_orientation_w: roll must be in [" + fmt(-RequestBounds::kMaxRollRad) +
            ", " + fmt(RequestBounds::kMaxRollRad) + "] rad (the jump is planar), got " +
            fmt(roll));
  requireVector("state.base_linear_velocity_w_m_s", state.base_linear_velocity_w_m_s(),
                RequestBounds::kMaxLinearSpeedMS);
  requireVector("state.base_angular_velocity_b_rad_s", state.base_angular_velocity_b_rad_s(),
                RequestBounds::kMaxAngularSpeedRadS);
  if (state.joint_positions_rad_size() != model::kNumJoints)
    invalid("state.joint_positions_rad must have " + std::to_string(model::kNumJoints) +
            " entries (LF, RF, LH, RH x HAA, HFE, KFE, WHEEL), got " +
            std::to_string(state.joint_positions_rad_size()));
  if (state.joint_velocities_rad_s_size() != model::kNumJoints)
    invalid("state.joint_velocities_rad_s must have " + std::to_string(model::kNumJoints) +
            " entries, got " + std::to_string(state.joint_velocities_rad_s_size()));
  for (int i = 0; i < model::kNumJoints; ++i)
    requireBound(state.joint_velocities_rad_s(i), RequestBounds::kMaxJointSpeedRadS,
                 "state.joint_velocities_rad_s", {}, i);
  if (const double stamp = state.stamp_s();
      !std::isfinite(stamp) || stamp < 0.0 || stamp > RequestBounds::kMaxStampS)
    invalid(
        "state.stamp_s (the robot's clock, informative; 0 = not given) must be finite and in "
        "[0, " +
        fmt(RequestBounds::kMaxStampS) + "] s, got " + fmt(stamp));

  // The jump frame's x is the base heading projected on the ground.
  const Eigen::Vector3d x_B = R_WB.col(0);
  planner::InitialState s;
  s.pitch = std::atan2(x_B.z(), x_B.head<2>().norm());
  // Checked before the heading is used: a steep pitch leaves no horizontal heading.
  if (std::abs(s.pitch) > 0.5)
    invalid("state.base_orientation_w (pitch, nose-up) must be finite and in [-0.5, 0.5], got " +
            fmt(s.pitch));
  const Eigen::Vector2d heading = x_B.head<2>().normalized();
  const auto& v = state.base_linear_velocity_w_m_s();
  s.v0 = heading.x() * v.x() + heading.y() * v.y();
  s.pitch_rate = -state.base_angular_velocity_b_rad_s().y();
  for (int i = 0; i < model::kNumJoints; ++i) {
    requireFinite(state.joint_positions_rad(i), "state.joint_positions_rad", {}, i);
    s.q[i] = state.joint_positions_rad(i);
  }
  withProtoNames([&] { s.validate(robot); },
                 {{"initial.v0",
                   "state.base_linear_velocity_w_m_s (forward speed v0 along the "
                   "heading)"},
                  {"initial.pitch_rate", "state.base_angular_velocity_b_rad_s (pitch rate -y)"},
                  {"initial.pitch", "state.base_orientation_w (pitch, nose-up)"},
                  {"initial.q", "state.joint_positions_rad"}});
  return s;
}

planner::JumpTask toJumpTask(const v1::JumpTask& task, const model::RobotModel& robot,
                             const planner::InitialState& initial) {
  planner::JumpTask t;
  switch (task.event()) {
    case v1::TARGET_EVENT_APEX:
      t.target.event = planner::TargetEvent::Apex;
      break;
    case v1::TARGET_EVENT_TOUCHDOWN:
      t.target.event = planner::TargetEvent::Touchdown;
      break;
    default:
      invalid("task.event must be TARGET_EVENT_APEX (1) or TARGET_EVENT_TOUCHDOWN (2), got " +
              std::to_string(static_cast<int>(task.event())));
  }
  switch (task.takeoff_mode()) {
    case v1::TAKEOFF_MODE_SIMULTANEOUS:
      t.mode = planner::TakeoffMode::Simultaneous;
      break;
    case v1::TAKEOFF_MODE_TWO_STEP:
      t.mode = planner::TakeoffMode::TwoStep;
      break;
    default:
      invalid(
          "task.takeoff_mode must be TAKEOFF_MODE_SIMULTANEOUS (1) or TAKEOFF_MODE_TWO_STEP (2), "
          "got " +
          std::to_string(static_cast<int>(task.takeoff_mode())));
  }
  t.target.dx = task.target_dx_m();
  t.target.height = task.target_height_m();
  t.target.pitch_change = task.target_pitch_change_rad();
  if (task.has_obstacle()) {
    t.obstacle = planner::BoxObstacle{task.obstacle().x_min_m(), task.obstacle().x_max_m(),
                                      task.obstacle().height_m()};
  }
  withProtoNames([&] { t.validate(); },
                 {{"task.target.dx", "task.target_dx_m"},
                  {"task.target.height", "task.target_height_m"},
                  {"task.target.pitch_change", "task.target_pitch_change_rad"},
                  {"task.obstacle.x_min", "task.obstacle.x_min_m"},
                  {"task.obstacle.x_max", "task.obstacle.x_max_m"},
                  {"task.obstacle.height", "task.obstacle.height_m"}});
  if (t.obstacle) {
    const double reach = frontWheelReach(robot, initial);
    if (t.obstacle->x_min <= reach)
      invalid("task.obstacle.x_min_m must be ahead of the front wheels (> " + fmt(reach) +
              " m in J at this posture), got " + fmt(t.obstacle->x_min));
  }
  return t;
}

PlanRequest toPlanRequest(const v1::PlanJumpRequest& request, const model::RobotModel& robot) {
  if (request.request_id().size() > RequestBounds::kMaxRequestIdBytes)
    invalid("request_id must be at most " + std::to_string(RequestBounds::kMaxRequestIdBytes) +
            " bytes, got " + std::to_string(request.request_id().size()));
  for (std::size_t i = 0; i < request.request_id().size(); ++i) {
    const auto c = static_cast<unsigned char>(request.request_id()[i]);
    if (c < 0x20 || c == 0x7f)
      invalid(
          "request_id must hold no control characters (bytes 0x00 to 0x1f and 0x7f), got "
          "byte " +
          std::to_string(c) + " at index " + std::to_string(i));
  }
  if (!request.has_state()) invalid("state is required");
  if (!request.has_task()) invalid("task is required");
  PlanRequest r;
  r.request_id = request.request_id();
  r.initial = toInitialState(request.state(), robot);
  r.task = toJumpTask(request.task(), robot, r.initial);
  const auto& b = request.budget();
  if (b.max_evaluations() > RequestBounds::kMaxEvaluations)
    invalid("budget.max_evaluations must be in [0, " +
            std::to_string(RequestBounds::kMaxEvaluations) + "] (0 = server default), got " +
            std::to_string(b.max_evaluations()));
  if (b.max_verified_candidates() > RequestBounds::kMaxVerifiedCandidates)
    invalid("budget.max_verified_candidates must be in [0, " +
            std::to_string(RequestBounds::kMaxVerifiedCandidates) + "] (0 = server default), got " +
            std::to_string(b.max_verified_candidates()));
  if (b.max_evaluations() > 0) r.max_evaluations = b.max_evaluations();
  r.max_verified_candidates = static_cast<int>(b.max_verified_candidates());
  r.skip_verification = b.skip_verification();
  r.seed = b.seed();
  switch (request.trajectory_format()) {
    case v1::TRAJECTORY_FORMAT_UNSPECIFIED:
    case v1::TRAJECTORY_FORMAT_DENSE:
      r.trajectory = TrajectoryFormat::Dense;
      break;
    case v1::TRAJECTORY_FORMAT_KNOTS:
      r.trajectory = TrajectoryFormat::Knots;
      break;
    case v1::TRAJECTORY_FORMAT_COMPACT_KNOTS:
      r.trajectory = TrajectoryFormat::CompactKnots;
      break;
    default:
      invalid(
          "trajectory_format must be TRAJECTORY_FORMAT_UNSPECIFIED (0), TRAJECTORY_FORMAT_DENSE "
          "(1), TRAJECTORY_FORMAT_KNOTS (2) or TRAJECTORY_FORMAT_COMPACT_KNOTS (3), got " +
          std::to_string(static_cast<int>(request.trajectory_format())));
  }
  return r;
}

WarmRequest toWarmRequest(const v1::WarmCacheRequest& request, const model::RobotModel& robot,
                          const planner::InitialState& nominal) {
  if (!request.has_task()) invalid("task is required");
  WarmRequest w;
  w.task = toJumpTask(request.task(), robot, nominal);
  const double lo = request.v0_min_m_s(), hi = request.v0_max_m_s(), step = request.v0_step_m_s();
  // The planner's run-up range (InitialState::validate): up to the wheels' reach.
  const double v_lo = planner::kMinRunUpSpeed, v_hi = planner::maxRunUpSpeed(robot);
  for (const auto& [name, v] : {std::pair{"v0_min_m_s", lo}, {"v0_max_m_s", hi}}) {
    if (!std::isfinite(v) || v < v_lo || v > v_hi)
      invalid(std::string(name) + " must be finite and in [" + fmt(v_lo) + ", " + fmt(v_hi) +
              "] (up to the wheels' reach: radius x no-load speed), got " + fmt(v));
  }
  if (hi < lo) invalid("v0_max_m_s must be >= v0_min_m_s (" + fmt(lo) + "), got " + fmt(hi));
  // A step wider than any run-up range (at most [-1, 4]) names no second point: absurd.
  if (!std::isfinite(step) || step <= 0.0 || step > 5.0)
    invalid("v0_step_m_s must be finite and in (0, 5] (the width of the run-up range), got " +
            fmt(step));
  const double points = std::floor((hi - lo) / step + 1e-9) + 1.0;
  if (points > RequestBounds::kMaxWarmGridPoints)
    invalid("the grid v0_min_m_s..v0_max_m_s in steps of v0_step_m_s must have at most " +
            std::to_string(RequestBounds::kMaxWarmGridPoints) + " points, got " + fmt(points));
  const int n = static_cast<int>(points);
  for (int i = 0; i < n; ++i) w.v0_grid.push_back(std::min(lo + i * step, hi));
  return w;
}

}  // namespace wj::server
