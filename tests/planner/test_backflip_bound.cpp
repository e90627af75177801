// The backflip bound's pieces (planner/tools/backflip_bound.h) against closed forms and the
// robot model computed another way.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "backflip_bound.h"
#include "robot_model/momentum.h"

namespace {

using wj::model::JointKind;
using wj::model::RobotModel;

const RobotModel& robot() {
  static const RobotModel model = RobotModel::loadDefault();
  return model;
}

/// One geometry search for every test (the coarse grid keeps the suite short).
const wj::bound::Geometry& geometry() {
  static const wj::bound::Geometry g = [] {
    wj::bound::BoundSettings s;
    s.grid_step_rad = 0.2;
    return wj::bound::calcGeometry(robot(), s);
  }();
  return g;
}

/// Seeded joint positions inside every range (wheels at 0).
Eigen::VectorXd randomPosture(std::mt19937& rng) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(wj::model::kNumJoints);
  for (int j = 0; j < wj::model::kNumJoints; ++j) {
    const auto& spec = robot().joints()[j];
    if (spec.continuous) continue;
    q[j] = std::uniform_real_distribution<double>(spec.lower_rad, spec.upper_rad)(rng);
  }
  return q;
}

/// Pitch inertia as the momentum of the robot turning at 1 rad/s with its joints locked.
double inertiaByMomentum(const Eigen::VectorXd& q) {
  const Eigen::VectorXd qd = Eigen::VectorXd::Zero(wj::model::kNumJoints);
  return wj::model::calcCentralAngularMomentum(robot(), Eigen::Matrix3d::Identity(),
                                               Eigen::Vector3d::UnitY(), q, qd)
      .y();
}

TEST(BackflipBound, PitchInertiaIsTheLockedRobotsMomentumPerRate) {
  std::mt19937 rng(7);
  for (int i = 0; i < 20; ++i) {
    const Eigen::VectorXd q = randomPosture(rng);
    EXPECT_NEAR(wj::bound::calcPitchInertia(robot(), q), inertiaByMomentum(q), 1e-6);
  }
}

TEST(BackflipBound, InertiaRangeBracketsEveryPosture) {
  const auto& in = geometry().inertia;
  // The smallest found is a real posture's inertia, the lower bound lies below it, the
  // upper bound above the largest found.
  EXPECT_NEAR(in.i_min, inertiaByMomentum(in.q_min), 1e-6);
  EXPECT_NEAR(in.i_max_found, inertiaByMomentum(in.q_max), 1e-6);
  EXPECT_LE(in.i_min_lower, in.i_min + 1e-12);
  EXPECT_GE(in.i_max_upper, in.i_max_found - 1e-12);
  // Grid error: a 0.2 rad grid stays within 5 % of what its lower bound promises.
  EXPECT_LT(in.i_min - in.i_min_lower, 0.05 * in.i_min);
  std::mt19937 rng(11);
  for (int i = 0; i < 300; ++i) {
    const Eigen::VectorXd q = randomPosture(rng);
    const double inertia = wj::bound::calcPitchInertia(robot(), q);
    EXPECT_GE(inertia, in.i_min_lower - 0.01 * in.i_min) << "sample " << i;
    EXPECT_LE(inertia, in.i_max_upper) << "sample " << i;
  }
}

TEST(BackflipBound, MaxPowerOfTheEnvelope) {
  const auto& envelope = robot().joint(wj::model::Leg::LH, JointKind::KFE).actuator;
  double sampled = 0.0;
  for (int i = 0; i <= 40000; ++i) {
    const double w = envelope.no_load_speed_rad_s * i / 40000.0;
    sampled = std::max(sampled, envelope.torqueLimit(w) * w);
  }
  // Peak torque up to 20 rad/s, falling to 0 at 40 rad/s: the best is at 20 rad/s, 20 x peak.
  EXPECT_NEAR(wj::bound::calcMaxPower(envelope), sampled, 1e-9);
  EXPECT_NEAR(wj::bound::calcMaxPower(envelope), 20.0 * envelope.peak_torque_nm, 1e-9);
  // A corner below half the no-load speed moves the best speed to w0 / 2.
  auto slow = envelope;
  slow.corner_speed_rad_s = 10.0;
  EXPECT_NEAR(wj::bound::calcMaxPower(slow), slow.peak_torque_nm * (40.0 - 20.0) / 30.0 * 20.0,
              1e-9);
}

TEST(BackflipBound, FlightRotationClosedFormWithoutWheels) {
  // max over H of H / I_min * 2 vz / g with 1/2 m vz^2 + H^2 / (2 I_max) = E is at
  // H^2 = I_max E: 2 E / (g I_min) sqrt(I_max / m).
  const double e = 150.0, m = 22.5, i_min = 0.7, i_max = 1.0;
  double h = 0.0, vz = 0.0;
  const double turn = wj::bound::maxFlightRotation(e, m, i_min, i_max, 0.0, &h, &vz);
  EXPECT_NEAR(turn, 2.0 * e / (9.81 * i_min) * std::sqrt(i_max / m), 1e-6);
  EXPECT_NEAR(h, std::sqrt(i_max * e), 1e-4);
  EXPECT_NEAR(0.5 * m * vz * vz + h * h / (2.0 * i_max), e, 1e-6);
  // The wheels' momentum only adds.
  EXPECT_GT(wj::bound::maxFlightRotation(e, m, i_min, i_max, 1.0, nullptr, nullptr), turn);
}

TEST(BackflipBound, BoundGrowsWithKneeTorqueAndRunUp) {
  const wj::bound::BoundSettings s;
  double last = 0.0;
  for (const double knee : {42.0, 47.0, 52.0, 57.0}) {
    const auto variant = robot().withPeakTorque(JointKind::KFE, knee);
    const auto standing = wj::bound::calcBound(variant, geometry(), s, 0.0);
    const auto rolling = wj::bound::calcBound(variant, geometry(), s, -1.0);
    EXPECT_GT(standing.bound_rad, last);
    EXPECT_GT(rolling.bound_rad, standing.bound_rad);
    EXPECT_NEAR(standing.work_by_kind_j[2], 4.0 * knee * 2.2, 1e-9);  // one stroke of 2.2 rad
    EXPECT_NEAR(rolling.run_up_energy_j - standing.run_up_energy_j, 0.5 * 22.5, 1e-9);
    EXPECT_NEAR(
        standing.bound_rad,
        standing.theta_liftoff_max_rad + standing.flight_rotation_rad + standing.shape_rotation_rad,
        1e-12);
    last = standing.bound_rad;
  }
}

TEST(BackflipBound, HeightsAndReach) {
  const auto& g = geometry();
  EXPECT_GT(g.z_min_m, 0.0);
  EXPECT_LT(g.z_min_m, g.z_start_m);
  EXPECT_NEAR(g.z_start_m, 0.2274, 1e-3);  // the planner's standing posture (HFE 1, KFE -2)
  EXPECT_GT(g.theta_liftoff_max_rad, 0.5 * M_PI);
  EXPECT_LE(g.theta_liftoff_max_rad, 2.0 * M_PI + 0.01);
  // Four wheels of 0.00542 kg m^2 about their axle at 50 rad/s.
  EXPECT_NEAR(wj::bound::calcWheelMomentumMax(robot(), 50.0), 4.0 * 0.00542 * 50.0, 1e-9);
}

TEST(BackflipBound, FromLiftoffAddsTheFlightsTurn) {
  const wj::bound::BoundSettings s;
  const wj::bound::LiftoffState lo{2.66, 9.45, 1.43, 0.22};
  std::array<double, 3> terms{};
  const double bound = wj::bound::calcBoundFromLiftoff(robot(), geometry(), s, lo, &terms);
  const double t = (1.43 + std::sqrt(1.43 * 1.43 + 2.0 * 9.81 * 0.22)) / 9.81;
  const double i_min = std::min(geometry().inertia.i_min_lower, geometry().inertia.i_min);
  EXPECT_NEAR(terms[1], (9.45 + geometry().wheel_momentum_max) / i_min * t, 1e-9);
  EXPECT_NEAR(bound, terms[0] + terms[1] + terms[2], 1e-12);
  EXPECT_THROW(wj::bound::calcBoundFromLiftoff(robot(), geometry(), s, {0, 0, 0, -1.0}, nullptr),
               std::invalid_argument);
}

}  // namespace
