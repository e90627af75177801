// Mirror symmetry about the sagittal plane (see sim/symmetry.h).
#include "sim/symmetry.h"

#include <cmath>

namespace wj::sim {

namespace {

// Relative tolerance of the comparisons: the URDF's figures are mirrored digit for digit, the
// planner's right-leg values are copies of the left-leg ones; anything beyond round-off is a
// real asymmetry.
constexpr double kTol = 1e-9;

bool near(double a, double b) {
  return a == b || std::abs(a - b) <= kTol * (1.0 + std::abs(a) + std::abs(b));
}

template <class A, class B>
bool near(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b) {
  for (Eigen::Index i = 0; i < a.rows(); ++i)
    for (Eigen::Index k = 0; k < a.cols(); ++k)
      if (!near(a(i, k), b(i, k))) return false;
  return true;
}

// The reflection y -> -y.
const Eigen::Matrix3d kS = Eigen::Vector3d(1.0, -1.0, 1.0).asDiagonal().toDenseMatrix();

std::string checkInertia(const model::Inertia& left, const model::Inertia& right,
                         const std::string& name) {
  if (!near(left.mass, right.mass) || !near(kS * left.com, right.com) ||
      !near(kS * left.inertia_com * kS, right.inertia_com))
    return "link " + name + " is not the mirror image of its left counterpart";
  return "";
}

}  // namespace

std::string findAsymmetry(const model::RobotModel& model) {
  const model::Inertia& base = model.links()[0].inertia;
  if (!near(base.com.y(), 0.0) || !near(base.inertia_com(0, 1), 0.0) ||
      !near(base.inertia_com(1, 2), 0.0))
    return "the base's centre of mass or inertia is not symmetric about y = 0";
  for (int j = 0; j < model::kNumJoints; ++j) {
    if (isLeftJoint(j)) continue;
    const model::JointSpec& r = model.joints()[j];
    const model::JointSpec& l = model.joints()[mirrorJoint(j)];
    const double s = mirrorSign(j);
    const bool limits_ok = s > 0.0
                               ? near(r.lower_rad, l.lower_rad) && near(r.upper_rad, l.upper_rad)
                               : near(r.lower_rad, -l.upper_rad) && near(r.upper_rad, -l.lower_rad);
    const model::ActuatorEnvelope& a = r.actuator;
    const model::ActuatorEnvelope& b = l.actuator;
    if (!near(kS * l.X_PJ.translation(), r.X_PJ.translation()) ||
        !near(kS * l.X_PJ.linear() * kS, r.X_PJ.linear()) || !near(-s * (kS * l.axis), r.axis) ||
        r.continuous != l.continuous || !limits_ok || !near(a.peak_torque_nm, b.peak_torque_nm) ||
        !near(a.corner_speed_rad_s, b.corner_speed_rad_s) ||
        !near(a.no_load_speed_rad_s, b.no_load_speed_rad_s) || a.braking != b.braking)
      return "joint " + r.name + " is not the mirror image of " + l.name;
    if (std::string why =
            checkInertia(model.links()[l.child_link].inertia, model.links()[r.child_link].inertia,
                         model.links()[r.child_link].name);
        !why.empty())
      return why;
  }
  return "";
}

std::string findAsymmetry(const SimSettings& settings) {
  if (settings.noise.enabled) return "sensor noise is on";
  if (!settings.plant.nominal()) return "the plant differs from the model";
  if (settings.contact.wheel_shape != WheelShape::Sphere) return "the wheels are ellipsoids";
  for (const Box& b : settings.terrain.boxes)
    if (!near(b.min.y(), -b.max.y())) return "a terrain box does not span y symmetrically";
  return "";
}

}  // namespace wj::sim
