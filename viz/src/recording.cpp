#include "viz/recording.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wj::viz {

namespace {

bool finite(const Eigen::Vector3d& v) {
  return v.allFinite();
}

}  // namespace

void Recording::validate() const {
  if (frames.empty()) throw std::invalid_argument("recording '" + title + "': no frames");
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const Frame& f = frames[i];
    const std::string where = "recording '" + title + "': frames[" + std::to_string(i) + "]";
    if (!std::isfinite(f.t)) throw std::invalid_argument(where + ".t is not finite");
    if (i > 0 && !(f.t > frames[i - 1].t))
      throw std::invalid_argument(where + ".t must be greater than the previous frame's");
    if (!finite(f.p_WB) || !f.q_WB.coeffs().allFinite() || std::abs(f.q_WB.norm() - 1.0) > 1e-6)
      throw std::invalid_argument(where + ": base pose not finite or quaternion not unit");
    if (!finite(f.p_WC)) throw std::invalid_argument(where + ".p_WC is not finite");
    for (int j = 0; j < model::kNumJoints; ++j)
      if (!std::isfinite(f.q[j]) || !std::isfinite(f.qd[j]) || !std::isfinite(f.tau[j]))
        throw std::invalid_argument(where + ": joint " + std::to_string(j) + " not finite");
  }
  for (const SceneBox& b : boxes)
    if (!finite(b.min) || !finite(b.max) || !(b.min.array() < b.max.array()).all())
      throw std::invalid_argument("recording '" + title + "': a box needs min < max");
}

int Recording::frameAt(double t) const {
  const auto it = std::upper_bound(frames.begin(), frames.end(), t,
                                   [](double v, const Frame& f) { return v < f.t; });
  if (it == frames.begin()) return 0;
  return static_cast<int>(std::distance(frames.begin(), it)) - 1;
}

int Recording::apexFrame() const {
  return apexFrame(jump_start_t, touchdown_t);
}

int Recording::apexFrame(double from_t, double to_t) const {
  const int first = std::isfinite(from_t) ? frameAt(from_t) : 0;
  const int last = std::isfinite(to_t) ? frameAt(to_t) : static_cast<int>(frames.size()) - 1;
  int best = first;
  for (int i = first; i <= last; ++i)
    if (frames[i].p_WC.z() > frames[best].p_WC.z()) best = i;
  return best;
}

Frame makePlanarFrame(const model::RobotModel& robot, double t, double com_x, double com_z,
                      double pitch, const Eigen::Ref<const Eigen::VectorXd>& q) {
  if (q.size() != model::kNumJoints)
    throw std::invalid_argument("makePlanarFrame: q must have 16 entries");
  Frame f;
  f.t = t;
  // Nose-up pitch is a rotation about -y (as the planner and the simulation place the robot).
  f.q_WB = Eigen::Quaterniond(Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()));
  for (int j = 0; j < model::kNumJoints; ++j) f.q[j] = q[j];
  const Eigen::Vector3d p_BC = robot.calcCompositeInertia(q).com;
  f.p_WC = Eigen::Vector3d(com_x, 0.0, com_z);
  f.p_WB = f.p_WC - f.q_WB.toRotationMatrix() * p_BC;
  return f;
}

}  // namespace wj::viz
