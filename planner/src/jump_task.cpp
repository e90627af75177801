#include "planner/jump_task.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string_view>

namespace wj::planner {

namespace {

bool inRange(double value, double lo, double hi) {
  return std::isfinite(value) && value >= lo && value <= hi;
}

// `why`, if given, says where the range comes from.
[[noreturn]] void outOfRange(std::string_view field, double value, double lo, double hi,
                             std::string_view why = {}) {
  std::ostringstream ss;
  ss << field << " must be finite and in [" << lo << ", " << hi << "]";
  if (!why.empty()) ss << " (" << why << ")";
  ss << ", got " << value;
  throw std::invalid_argument(ss.str());
}

// A string_view, so that a valid value builds no string (validated on every request, hits
// included).
void requireRange(std::string_view field, double value, double lo, double hi) {
  if (!inRange(value, lo, hi)) outOfRange(field, value, lo, hi);
}

}  // namespace

void JumpTask::validate() const {
  requireRange("task.target.dx", target.dx, -3.0, 5.0);
  requireRange("task.target.height", target.height, 0.1, 1.5);
  requireRange("task.target.pitch_change", target.pitch_change, -7.0, 7.0);
  if (obstacle) {
    requireRange("task.obstacle.x_min", obstacle->x_min, -5.0, 5.0);
    requireRange("task.obstacle.x_max", obstacle->x_max, obstacle->x_min + 1e-3, 6.0);
    requireRange("task.obstacle.height", obstacle->height, 1e-3, 1.0);
    if (landsOnObstacle())
      requireRange("task.target.height (landing on the obstacle: CoM above its top)", target.height,
                   obstacle->height + 0.05, 1.5);
  }
}

bool JumpTask::landsOnObstacle() const {
  return obstacle && target.event == TargetEvent::Touchdown && target.dx > obstacle->x_min &&
         target.dx < obstacle->x_max;
}

bool JumpTask::isBackflip() const {
  return mode == TakeoffMode::TwoStep && target.pitch_change > M_PI;
}

double maxRunUpSpeed(const model::RobotModel& robot) {
  double reach = 4.0;
  for (const model::Leg leg : model::kLegs)
    reach =
        std::min(reach, robot.wheelRadius() *
                            robot.joint(leg, model::JointKind::Wheel).actuator.no_load_speed_rad_s);
  return reach;
}

void InitialState::validate(const model::RobotModel& robot) const {
  if (const double hi = maxRunUpSpeed(robot); !inRange(v0, kMinRunUpSpeed, hi))
    outOfRange("initial.v0", v0, kMinRunUpSpeed, hi,
               "up to the wheels' reach: radius x no-load speed");
  requireRange("initial.pitch", pitch, -0.5, 0.5);
  requireRange("initial.pitch_rate", pitch_rate, -3.0, 3.0);
  for (int i = 0; i < model::kNumJoints; ++i) {
    const auto& j = robot.joints()[i];
    if (j.continuous) {
      if (!std::isfinite(q[i]))
        throw std::invalid_argument("initial.q[" + j.name + "] must be finite");
      continue;
    }
    if (!inRange(q[i], j.lower_rad, j.upper_rad))
      outOfRange("initial.q[" + j.name + "]", q[i], j.lower_rad, j.upper_rad);
  }
}

}  // namespace wj::planner
