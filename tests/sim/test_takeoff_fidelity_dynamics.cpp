// The take-off's feed-forward torques against an independent inverse dynamics (issue 22,
// session 13): the planner adds the legs' own inertia and weight to the statics of the ground
// forces (docs/planner.md, "Stance torques"); the robot client's recursive Newton-Euler
// (nmpc::InverseDynamics, the 3D URDF tree) must give the same joint torques for the plan's
// motion and forces. The massless-leg statics of sessions 1-12 missed by up to 3-4 Nm at the
// knees, which is what this test would see if the dynamics were dropped. Since session 18 the
// forces are balanced: the pairs' normal forces split so that they make the moment the plan's
// motion needs (docs/planner.md, "The balanced stance"); without the split the knees' torques
// here differ by up to ~6 Nm at the push's end.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "nmpc/inverse_dynamics.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "robot_model/momentum.h"
#include "sim/verifier.h"

namespace wj::sim {
namespace {

using JointVec = Eigen::Matrix<double, model::kNumJoints, 1>;

/// Base frame origin in J at row k: the CoM minus the composite CoM's offset in the base.
Eigen::Vector3d baseOrigin(const model::RobotModel& robot, const planner::JumpPlan& plan, int k) {
  const planner::PlanarState& s = plan.centroidal[k];
  const JointVec q = plan.q.row(k).transpose();
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(-s.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return Eigen::Vector3d(s.x, 0.0, s.z) - R * robot.calcCompositeInertia(q).com;
}

/// The ground force phase holding t, or null.
const planner::ForcePhase* phaseAt(const planner::JumpPlan& plan, double t) {
  for (const planner::ForcePhase& ph : plan.force_phases)
    if (t > ph.t_start && t < ph.t_end) return &ph;
  return nullptr;
}

/// The phase holding the row at t and both its neighbours (the rows' central differences stay
/// inside one contact phase), or null.
const planner::ForcePhase* interiorPhaseAt(const planner::JumpPlan& plan, double t) {
  const planner::ForcePhase* ph = phaseAt(plan, t);
  const bool inside = ph && phaseAt(plan, t - plan.dt) == ph && phaseAt(plan, t + plan.dt) == ph;
  return inside ? ph : nullptr;
}

/// The base's motion at the plan's row k in its own frame (orientation R): the given nose-up
/// pitch rate and acceleration, and the origin's velocity and acceleration by central
/// differences of the rows.
nmpc::BaseMotion rowBaseMotion(const model::RobotModel& robot, const planner::JumpPlan& plan, int k,
                               const Eigen::Matrix3d& R, double pitch_rate, double pitch_dd) {
  const double dt = plan.dt;
  const Eigen::Vector3d pm = baseOrigin(robot, plan, k - 1), p0 = baseOrigin(robot, plan, k),
                        pp = baseOrigin(robot, plan, k + 1);
  nmpc::BaseMotion base;
  base.omega_B = Eigen::Vector3d(0.0, -pitch_rate, 0.0);
  base.omegadot_B = Eigen::Vector3d(0.0, -pitch_dd, 0.0);
  base.v_B = R.transpose() * (pp - pm) / (2 * dt);
  base.a_B = R.transpose() * (pp - 2 * p0 + pm) / (dt * dt);
  return base;
}

/// The inverse dynamics of the plan's row k (inside the contact phase ph, with its neighbours):
/// the joint torques and the base wrench that the plan's motion needs with its ground forces,
/// velocities and accelerations by central differences of the rows.
nmpc::InverseDynamicsResult rowInverseDynamics(const model::RobotModel& robot,
                                               const nmpc::InverseDynamics& id,
                                               const planner::JumpPlan& plan, int k,
                                               const planner::ForcePhase& ph) {
  const double dt = plan.dt;
  const double t = k * dt;
  const planner::PlanarState& s = plan.centroidal[k];
  const JointVec q = plan.q.row(k).transpose(), qd = plan.qd.row(k).transpose();
  const JointVec qdd = (plan.qd.row(k + 1) - plan.qd.row(k - 1)).transpose() / (2 * dt);
  const double pitch_dd =
      (plan.centroidal[k + 1].pitch_rate - plan.centroidal[k - 1].pitch_rate) / (2 * dt);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(-s.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const nmpc::BaseMotion base = rowBaseMotion(robot, plan, k, R, s.pitch_rate, pitch_dd);
  const auto X = robot.calcLinkPoses(q);
  std::array<nmpc::WheelForce, model::kNumLegs> wheels{};
  const double tau = t - ph.t_start;
  for (const model::Leg leg : model::kLegs) {
    const planner::PairForce& f = model::isFront(leg) ? ph.front : ph.hind;
    auto& w = wheels[static_cast<std::size_t>(leg)];
    // Half the pair's force per wheel, at the contact point below the axle.
    w.f_B = R.transpose() * Eigen::Vector3d(0.5 * f.fx(tau), 0.0, 0.5 * f.fz(tau));
    w.p_B = X[robot.joint(leg, model::JointKind::Wheel).child_link].translation() +
            R.transpose() * Eigen::Vector3d(0.0, 0.0, -robot.wheelRadius());
  }
  nmpc::InverseDynamicsResult out;
  const Eigen::Vector3d gravity_B =
      R.transpose() * Eigen::Vector3d(0.0, 0.0, -planner::PlannerSettings{}.gravity);
  id.calc(gravity_B, base, q, qd, qdd, wheels, out);
  return out;
}

/// The nose-up (about -y) moment about the CoM in the base's row of row k's inverse dynamics:
/// what the plan's motion needs beyond its ground forces. The base's force row is ~0 (the
/// plan's CoM obeys its forces), so it is the moment about the base origin less c x f.
double residualMoment(const model::RobotModel& robot, const planner::JumpPlan& plan, int k,
                      const nmpc::InverseDynamicsResult& out) {
  const Eigen::Vector3d c_B = robot.calcCompositeInertia(plan.q.row(k).transpose()).com;
  return -(out.base_torque_B - c_B.cross(out.base_force_B)).y();
}

/// The same with the pairs' normal forces balanced (docs/planner.md, "The balanced stance"):
/// the base's residual moment about the CoM of rowInverseDynamics (what the plan's motion needs
/// beyond its force phases) carried by the pairs' normal forces, front + M / (x_F - x_H) and
/// hind as much less (the total unchanged), the joints' torques changed by -J^T of that split
/// (the inverse dynamics at rest without gravity).
nmpc::InverseDynamicsResult balancedRowInverseDynamics(const model::RobotModel& robot,
                                                       const nmpc::InverseDynamics& id,
                                                       const planner::JumpPlan& plan, int k,
                                                       const planner::ForcePhase& ph) {
  nmpc::InverseDynamicsResult out = rowInverseDynamics(robot, id, plan, k, ph);
  const JointVec q = plan.q.row(k).transpose();
  const double residual = residualMoment(robot, plan, k, out);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(-plan.centroidal[k].pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const auto X = robot.calcLinkPoses(q);
  const int front = robot.joint(model::Leg::LF, model::JointKind::Wheel).child_link;
  const int hind = robot.joint(model::Leg::LH, model::JointKind::Wheel).child_link;
  const double split = residual / (R * (X[front].translation() - X[hind].translation())).x();
  std::array<nmpc::WheelForce, model::kNumLegs> wheels{};
  for (const model::Leg leg : model::kLegs) {
    auto& w = wheels[static_cast<std::size_t>(leg)];
    w.f_B = R.transpose() * Eigen::Vector3d(0.0, 0.0, model::isFront(leg) ? split / 2 : -split / 2);
    w.p_B = X[robot.joint(leg, model::JointKind::Wheel).child_link].translation() +
            R.transpose() * Eigen::Vector3d(0.0, 0.0, -robot.wheelRadius());
  }
  nmpc::InverseDynamicsResult extra;
  id.calc(Eigen::Vector3d::Zero(), nmpc::BaseMotion{}, q, JointVec::Zero(), JointVec::Zero(),
          wheels, extra);
  for (int j = 0; j < model::kNumJoints; ++j) out.tau[j] += extra.tau[j];
  return out;
}

/// The plan of a preset at a seed, with the given settings.
planner::JumpPlan presetPlan(const model::RobotModel& robot, const planner::PlannerSettings& s,
                             const char* task, std::uint64_t seed) {
  const planner::JumpPlanner planner(robot, s);
  const planner::Scenario sc = planner::makePreset(planner, task);
  planner::PlanOptions opts;
  opts.seed = seed;
  opts.threads = 2;
  return planner.plan(sc.task, sc.initial, opts).plan;
}

/// The plan of a preset at a seed.
planner::JumpPlan presetPlan(const model::RobotModel& robot, const char* task, bool stance_momentum,
                             std::uint64_t seed, bool balanced_stance = true) {
  planner::PlannerSettings settings;
  settings.stance_momentum = stance_momentum;
  settings.balanced_stance = balanced_stance;
  return presetPlan(robot, settings, task, seed);
}

TEST(TakeoffDynamics, StanceTorquesMatchTheInverseDynamics) {
  const auto robot = model::RobotModel::loadDefault();
  const nmpc::InverseDynamics id(robot);
  // With the balanced stance (the default), against the inverse dynamics with the base's
  // residual moment split between the pairs; without it (the robot client's service), against
  // the force phases' own split.
  for (const bool balanced : {true, false})
    for (const char* task : {"forward_hw", "forward", "vertical"}) {
      SCOPED_TRACE(std::string(task) + (balanced ? " balanced" : " the model's split"));
      const planner::JumpPlan plan = presetPlan(robot, task, false, 7, balanced);
      const double dt = plan.dt;
      double worst = 0.0, worst_other = 0.0;
      int rows = 0;
      for (int k = 2; k + 1 < plan.numSamples() && (k + 1) * dt < plan.t2; ++k) {
        const double t = k * dt;
        const planner::ForcePhase* ph = interiorPhaseAt(plan, t);
        if (!ph) continue;
        const nmpc::InverseDynamicsResult bal = balancedRowInverseDynamics(robot, id, plan, k, *ph);
        const nmpc::InverseDynamicsResult own = rowInverseDynamics(robot, id, plan, k, *ph);
        const nmpc::InverseDynamicsResult& out = balanced ? bal : own;
        const nmpc::InverseDynamicsResult& other = balanced ? own : bal;
        const double tau = t - ph->t_start;
        // Both pairs in the four-wheel phase; the hind pair alone after t1 (the lifted front
        // pair brakes with its own feed-forward).
        const bool front_down = std::abs(ph->front.fz(tau)) > 0.0;
        for (const model::Leg leg : model::kLegs) {
          if (model::isFront(leg) && !front_down) continue;
          for (const model::JointKind kind : {model::JointKind::HAA, model::JointKind::HFE,
                                              model::JointKind::KFE, model::JointKind::Wheel}) {
            const int j = model::jointIndex(leg, kind);
            worst = std::max(worst, std::abs(plan.tau(k, j) - out.tau[j]));
            worst_other = std::max(worst_other, std::abs(plan.tau(k, j) - other.tau[j]));
          }
        }
        ++rows;
      }
      std::cout << task << (balanced ? " (balanced)" : " (the model's split)") << ": " << rows
                << " rows, largest difference " << worst << " Nm (with the other split "
                << worst_other << ")\n";
      EXPECT_GT(rows, 100);
      // The difference steps of the two (1 ms in the planner, the plan's rows here) and the
      // planner's planar link inertia (pitch only) leave up to 0.05 Nm (seed 7).
      EXPECT_LT(worst, 0.1);
      EXPECT_GT(worst_other, 1.0);  // the split matters at the push's end
    }
}

// What the plan's pitch leaves out (issue 22, session 17; docs/planner.md, "Where Simbody's
// momentum at t2 goes"): the base's row of the same inverse dynamics is the moment that the
// plan's motion needs beyond its ground forces. Integrated over the push it is the plan's pitch
// model's imbalance (the rigid-body stance's: the legs' momentum, 0.6-1.5 kg m^2/s at seed 7;
// with stance_momentum its E(t) interpolation's, zero at t2 by construction); in the push's
// last 20 ms, where the legs' momentum changes fastest, both leave a nose-up lobe that the
// joints' PD cannot make the robot follow in that time (seed 7, printed).
TEST(TakeoffDynamics, PitchModelImbalanceFromTheInverseDynamics) {
  const auto robot = model::RobotModel::loadDefault();
  const nmpc::InverseDynamics id(robot);
  for (const bool stance_momentum : {false, true})
    for (const char* task : {"forward_hw", "forward", "vertical"}) {
      SCOPED_TRACE(std::string(task) + (stance_momentum ? " stance momentum" : ""));
      const planner::JumpPlan plan = presetPlan(robot, task, stance_momentum, 7);
      const double dt = plan.dt;
      double push = 0.0, last_20ms = 0.0, at_end = 0.0;
      for (int k = 2; k + 1 < plan.numSamples() && (k + 1) * dt < plan.t2; ++k) {
        const double t = k * dt;
        const planner::ForcePhase* ph = interiorPhaseAt(plan, t);
        if (!ph) continue;
        at_end = residualMoment(robot, plan, k, rowInverseDynamics(robot, id, plan, k, *ph));
        push += at_end * dt;
        if (plan.t2 - t <= 0.02) last_20ms += at_end * dt;
      }
      std::cout << task << (stance_momentum ? " (stance momentum)" : "")
                << ": base moment at the last row " << at_end << " Nm, integral over the push "
                << push << ", over its last 20 ms " << last_20ms << " kg m^2/s\n";
      if (stance_momentum)
        EXPECT_LT(std::abs(push), 0.05);  // the E(t) interpolation's, as the planner test
      else
        EXPECT_GT(push, 0.3);  // the rigid-body stance leaves out the legs' momentum
      EXPECT_GT(last_20ms, 0.0);
    }
}

/// The robot client's service's settings (config/planner_settings.yaml) with the flight's
/// feed-forward, and the drive-limited tuck or the smoothstep's.
planner::PlannerSettings serviceSettings(bool drive_limited_tuck) {
  planner::PlannerSettings s =
      planner::PlannerSettings::fromYaml(std::string(WJ_CONFIG_DIR) + "/planner_settings.yaml");
  s.flight_feedforward = true;
  s.drive_limited_tuck = drive_limited_tuck;
  return s;
}

/// The base's nose-up pitch rate at the plan's row k that gives the whole robot the plan's
/// flight momentum (the wheels as point masses), by the 3D model's central momentum (linear in
/// the rate).
double flightPitchRate(const model::RobotModel& robot, const planner::JumpPlan& plan, int k) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(-plan.centroidal[k].pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::VectorXd q = plan.q.row(k).transpose(), qd = plan.qd.row(k).transpose();
  auto nose_up = [&](double rate) {
    return -model::calcCentralAngularMomentum(robot, R, Eigen::Vector3d(0.0, -rate, 0.0), q, qd,
                                              model::WheelSpin::Excluded)
                .y();
  };
  const double h0 = nose_up(0.0);
  return (plan.predicted.takeoff.momentum - h0) / (nose_up(1.0) - h0);
}

/// The inverse dynamics of the plan's flight row k: no ground force; the base's motion from the
/// rows (its pitch rate the momentum balance's, flightPitchRate) and the joints' accelerations
/// by central differences; each wheel's acceleration the one that needs no wheel torque (a free
/// wheel; the inverse dynamics is affine in it).
nmpc::InverseDynamicsResult flightRowInverseDynamics(const model::RobotModel& robot,
                                                     const nmpc::InverseDynamics& id,
                                                     const planner::JumpPlan& plan, int k) {
  const double dt = plan.dt;
  const planner::PlanarState& s = plan.centroidal[k];
  const JointVec q = plan.q.row(k).transpose(), qd = plan.qd.row(k).transpose();
  JointVec qdd = (plan.qd.row(k + 1) - plan.qd.row(k - 1)).transpose() / (2 * dt);
  const double pitch_rate = flightPitchRate(robot, plan, k);
  const double pitch_dd =
      (flightPitchRate(robot, plan, k + 1) - flightPitchRate(robot, plan, k - 1)) / (2 * dt);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(-s.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const nmpc::BaseMotion base = rowBaseMotion(robot, plan, k, R, pitch_rate, pitch_dd);
  const std::array<nmpc::WheelForce, model::kNumLegs> no_force{};
  const Eigen::Vector3d gravity_B =
      R.transpose() * Eigen::Vector3d(0.0, 0.0, -planner::PlannerSettings{}.gravity);
  nmpc::InverseDynamicsResult at0, at1, out;
  for (const model::Leg leg : model::kLegs)
    qdd[model::jointIndex(leg, model::JointKind::Wheel)] = 0;
  id.calc(gravity_B, base, q, qd, qdd, no_force, at0);
  for (const model::Leg leg : model::kLegs)
    qdd[model::jointIndex(leg, model::JointKind::Wheel)] = 1;
  id.calc(gravity_B, base, q, qd, qdd, no_force, at1);
  for (const model::Leg leg : model::kLegs) {
    const int w = model::jointIndex(leg, model::JointKind::Wheel);
    qdd[w] = -at0.tau[w] / (at1.tau[w] - at0.tau[w]);
  }
  id.calc(gravity_B, base, q, qd, qdd, no_force, out);
  return out;
}

/// Whether the references bend at row k: a joint's acceleration steps there (the drive-limited
/// tuck's switches, the braking's end), which the rows' 1 ms central differences smear.
bool kinkAt(const planner::JumpPlan& plan, int k) {
  for (int j = 0; j < model::kNumJoints; ++j) {
    if (model::isWheel(j)) continue;
    const double before = plan.qd(k, j) - plan.qd(k - 1, j),
                 after = plan.qd(k + 1, j) - plan.qd(k, j);
    const double prev = plan.qd(k - 1, j) - plan.qd(k - 2, j),
                 next = plan.qd(k + 2, j) - plan.qd(k + 1, j);
    if (std::abs(after - before) > 0.05 || std::abs(before - prev) > 0.05 ||
        std::abs(next - after) > 0.05)
      return true;
  }
  return false;
}

// The flight's feed-forward (physics.flight_feedforward; docs/planner.md, "The flight's
// feed-forward"): the plan's flight rows carry the legs' Newton-Euler torques along the
// references, with the base flying as the plan's. The robot client's recursive Newton-Euler
// (the 3D URDF tree, an independent model) must give the same torques for the rows' motion.
// Without the feed-forward the rows carry the braking's torque and then nothing, tens of Nm off.
TEST(TakeoffDynamics, FlightTorquesMatchTheInverseDynamics) {
  const auto robot = model::RobotModel::loadDefault();
  const nmpc::InverseDynamics id(robot);
  for (const char* task : {"forward_hw", "forward", "vertical", "platform"}) {
    SCOPED_TRACE(task);
    const planner::JumpPlan plan = presetPlan(robot, serviceSettings(true), task, 7);
    const double dt = plan.dt;
    double worst = 0.0, largest = 0.0;
    std::string worst_at;
    std::vector<double> differences;  // each row's largest [Nm]
    int rows = 0, smeared = 0;
    for (int k = static_cast<int>(std::ceil(plan.t2 / dt)) + 2;
         k + 2 < plan.numSamples() && (k + 2) * dt < plan.t3; ++k) {
      if (kinkAt(plan, k)) {
        ++smeared;
        continue;
      }
      const nmpc::InverseDynamicsResult out = flightRowInverseDynamics(robot, id, plan, k);
      double row_worst = 0.0;
      for (const model::Leg leg : model::kLegs)
        for (const model::JointKind kind :
             {model::JointKind::HAA, model::JointKind::HFE, model::JointKind::KFE}) {
          const int j = model::jointIndex(leg, kind);
          if (std::abs(plan.tau(k, j) - out.tau[j]) > worst) {
            worst = std::abs(plan.tau(k, j) - out.tau[j]);
            worst_at = "t - t2 " + std::to_string(k * dt - plan.t2) + " s, joint " +
                       std::to_string(j) + ": plan " + std::to_string(plan.tau(k, j)) +
                       " Nm, inverse dynamics " + std::to_string(out.tau[j]);
          }
          largest = std::max(largest, std::abs(out.tau[j]));
          row_worst = std::max(row_worst, std::abs(plan.tau(k, j) - out.tau[j]));
        }
      differences.push_back(row_worst);
      ++rows;
    }
    std::sort(differences.begin(), differences.end());
    const double p95 = differences.empty() ? 0.0 : differences[differences.size() * 95 / 100];
    std::cout << task << ": " << rows << " flight rows (95 % within " << p95 << " Nm; " << smeared
              << " at a kink left out), largest torque " << largest << " Nm, largest difference "
              << worst << " Nm (" << worst_at << ")\n";
    EXPECT_GT(rows, 150);
    EXPECT_GT(largest, 10.0);  // the tuck and the extension need torque
    // Seed 7: 95 % of the rows within 0.007-0.037 Nm; up to 1.6 Nm next to a kink, which the
    // rows' 1 ms differences smear over their neighbours (the base's acceleration too).
    EXPECT_LT(p95, 0.1);
    EXPECT_LT(worst, 3.0);
  }
}

// The drive-limited tuck (postures.drive_limited_tuck): along the service's flights every leg
// joint's feed-forward stays within its drive's envelope at the row's speed. The smoothstep tuck
// done by 15 % of the flight asks the front pair for more than the drives have (session 33: up
// to 60 rad/s and hundreds of Nm), which is why the legs did not follow it in Simbody.
TEST(TakeoffDynamics, DriveLimitedTuckStaysWithinTheEnvelope) {
  const auto robot = model::RobotModel::loadDefault();
  for (const bool drive_limited : {true, false}) {
    double worst_all = 0.0;  // the most negative envelope margin over the presets [Nm]
    for (const char* task : {"forward_hw", "forward", "vertical", "platform"}) {
      SCOPED_TRACE(std::string(task) + (drive_limited ? " drive-limited" : " smoothstep"));
      const planner::JumpPlan plan = presetPlan(robot, serviceSettings(drive_limited), task, 7);
      // From where each joint's braking ends (it stops or turns back): the tuck, the hold and
      // the extension. (The braking is JointBrake's, at 0.8 of the envelope, in its own test.)
      const int k2 = static_cast<int>(std::ceil(plan.t2 / plan.dt));
      double worst = 0.0, fastest = 0.0;
      std::string worst_at;
      std::array<bool, model::kNumJoints> braked{};
      for (int k = k2; k < plan.numSamples() && k * plan.dt < plan.t3; ++k)
        for (int j = 0; j < model::kNumJoints; ++j) {
          if (model::isWheel(j)) continue;
          braked[j] =
              braked[j] || plan.qd(k, j) * plan.qd(k2, j) <= 0.0 || std::abs(plan.qd(k, j)) < 0.05;
          if (!braked[j]) continue;
          const model::ActuatorEnvelope& env = robot.joints()[j].actuator;
          const double margin = env.torqueMargin(plan.tau(k, j), plan.qd(k, j));
          if (margin < worst) {
            worst = margin;
            worst_at = "t - t2 " + std::to_string(k * plan.dt - plan.t2) + " s, joint " +
                       std::to_string(j) + ", tau " + std::to_string(plan.tau(k, j)) + " Nm, qd " +
                       std::to_string(plan.qd(k, j)) + " rad/s";
          }
          fastest = std::max(fastest, std::abs(plan.qd(k, j)) / env.no_load_speed_rad_s);
        }
      std::cout << task << (drive_limited ? " (drive-limited)" : " (smoothstep)")
                << ": worst envelope margin " << worst << " Nm (" << worst_at << "), fastest joint "
                << fastest << " of its no-load speed\n";
      if (drive_limited) {
        // Seed 7: within the envelope but for a few milliseconds near the knees' peak speed
        // (0.71-0.75 of the no-load speed), where the envelope has fallen below the 0.8 share
        // of the peak torque the acceleration assumes, and at forward's hind hip as its tuck
        // starts, where the knee's acceleration adds to the hip's (the fixed-base figure is
        // each joint's own inertia): 3.3-8.9 Nm over.
        EXPECT_GE(worst, -10.0);
        EXPECT_LE(fastest, 0.8 + 1e-6);
      }
      worst_all = std::min(worst_all, worst);
    }
    if (!drive_limited) {
      EXPECT_LT(worst_all, -100.0);  // seed 7: 161-828 Nm past the envelope
    }
  }
}

}  // namespace
}  // namespace wj::sim
