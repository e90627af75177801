#include "sim/statics.h"

#include <cmath>
#include <stdexcept>
#include <vector>

namespace wj::sim {

namespace {

// Base-frame CoM of every link at posture q.
std::vector<Eigen::Vector3d> linkComs(const model::RobotModel& model, const Eigen::VectorXd& q) {
  const auto X = model.calcLinkPoses(q);
  std::vector<Eigen::Vector3d> out(X.size());
  for (std::size_t i = 0; i < X.size(); ++i) out[i] = X[i] * model.links()[i].inertia.com;
  return out;
}

}  // namespace

std::array<Eigen::Vector3d, model::kNumLegs> calcWheelCenters(const model::RobotModel& model,
                                                              const JointVector& q) {
  const auto X = model.calcLinkPoses(q);
  std::array<Eigen::Vector3d, model::kNumLegs> out;
  for (const model::Leg leg : model::kLegs)
    out[static_cast<int>(leg)] =
        X[model.joint(leg, model::JointKind::Wheel).child_link].translation();
  return out;
}

StandingStatics calcStandingStatics(const model::RobotModel& model, const JointVector& q,
                                    double gravity_m_s2, double vertical_accel_m_s2) {
  StandingStatics out;
  const double g_eff = gravity_m_s2 + vertical_accel_m_s2;
  const auto wheels = calcWheelCenters(model, q);
  const model::Inertia total = model.calcCompositeInertia(q);

  // Pair loads from the moment balance about y through the CoM.
  double x_front = 0.0, x_hind = 0.0, z_lowest = 0.0;
  for (const model::Leg leg : model::kLegs) {
    const Eigen::Vector3d& w = wheels[static_cast<int>(leg)];
    (model::isFront(leg) ? x_front : x_hind) += 0.5 * w.x();
    z_lowest = std::min(z_lowest, w.z());
  }
  if (!(x_front > x_hind)) throw std::invalid_argument("calcStandingStatics: wheels not apart");
  const double weight = total.mass * g_eff;
  const double front = weight * (total.com.x() - x_hind) / (x_front - x_hind);
  for (const model::Leg leg : model::kLegs)
    out.wheel_load_n[static_cast<int>(leg)] = 0.5 * (model::isFront(leg) ? front : weight - front);
  out.base_height_m = model.wheelRadius() - z_lowest;

  // Generalized forces by virtual work, Jacobians by central differences.
  const Eigen::VectorXd q0 = q;
  const double h = 1e-6;
  for (int j = 0; j < model::kNumJoints; ++j) {
    if (model.joints()[j].kind == model::JointKind::Wheel) continue;
    Eigen::VectorXd qp = q0, qm = q0;
    qp[j] += h;
    qm[j] -= h;
    const auto cp = linkComs(model, qp), cm = linkComs(model, qm);
    double tau = 0.0;
    for (std::size_t l = 0; l < cp.size(); ++l) {
      const double dz = (cp[l].z() - cm[l].z()) / (2.0 * h);
      tau += model.links()[l].inertia.mass * g_eff * dz;  // -J^T m g with g = (0, 0, -g_eff)
    }
    const auto wp = calcWheelCenters(model, qp), wm = calcWheelCenters(model, qm);
    for (int i = 0; i < model::kNumLegs; ++i)
      tau -= out.wheel_load_n[i] * (wp[i].z() - wm[i].z()) / (2.0 * h);  // -J^T f, f = (0,0,F)
    out.tau[j] = tau;
  }
  return out;
}

double calcHertzPenetration(const ContactSettings& contact, double radius, double load_n) {
  const double modulus = contact.stiffness_pa / std::pow(2.0, 1.5);
  return std::pow(3.0 * load_n / (4.0 * modulus * std::sqrt(radius)), 2.0 / 3.0);
}

}  // namespace wj::sim
