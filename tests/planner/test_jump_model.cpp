// The planar jump model against closed forms and direct integration, and its constraint
// evaluators on hand-made cases (the planner's search: test_jump_planner.cpp; its settings
// file: test_planner_settings.cpp).
#include <gtest/gtest.h>

#include <random>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "test_robot.h"

namespace wj::planner {
namespace {

using model::JointKind;
using model::Leg;

using wj::test::robot;
JumpPlanner makePlanner(PlannerSettings s = {}) {
  return JumpPlanner(robot(), s);
}

// A candidate in the middle of the box, with a healthy upward take-off.
Eigen::VectorXd nominalU(const JumpModel& m) {
  Eigen::VectorXd u = 0.5 * (m.lowerBounds() + m.upperBounds());
  u[kT1] = 0.25;
  u[kTakeoffDz] = 0.08;
  u[kTakeoffVz] = 2.0;
  u[kTakeoffDvx] = 0.0;
  u[kTakeoffDx] = 0.0;
  u[kTakeoffDpitch] = 0.05;
  u[kTakeoffRate] = 0.2;
  if (m.task().mode == TakeoffMode::TwoStep) {
    u[kT1] = 0.2;
    u[kT2MinusT1] = 0.1;
    u[kMidDz] = 0.0;
    u[kMidDx] = 0.0;
    u[kMidDpitch] = 0.0;
  }
  return u;
}

// Integrates the planar rigid body with the plan's force polynomials applied at the wheel
// contacts, whose positions come from the plan's joint angles through forward kinematics:
// an independent check of the linear solve, the kinematics and the closed-form trajectory.
// After a simultaneous take-off's t2 the force at t2 falls linearly to zero over the
// settings' takeoff_unload_s after the executor's hold (the unloading tail, an impulse at t2 in the
// model).
PlanarState integrate(const JumpPlan& plan, const JumpModel& m, double t_end) {
  const PlanarLeg leg{robot().legGeometry(Leg::LF).thigh_length,
                      robot().legGeometry(Leg::LF).shank_length};
  auto hfe = [&](Leg l) {
    const auto& g = robot().legGeometry(l);
    const Eigen::Vector3d h = g.p_BH + g.p_HT;
    return Eigen::Vector2d(h.x(), h.z());
  };
  const Eigen::Vector2d hfe_h = hfe(Leg::LH), hfe_f = hfe(Leg::LF);
  auto jointsAt = [&](double t, Leg l) {
    const double k = std::clamp(t / plan.dt, 0.0, plan.q.rows() - 1.0);
    const int k0 = std::min(static_cast<int>(k), static_cast<int>(plan.q.rows()) - 2);
    const double a = k - k0;
    const int j = model::jointIndex(l, JointKind::HFE);
    return Eigen::Vector2d((1 - a) * plan.q(k0, j) + a * plan.q(k0 + 1, j),
                           (1 - a) * plan.q(k0, j + 1) + a * plan.q(k0 + 1, j + 1));
  };
  auto jointsFull = [&](double t) {
    Eigen::VectorXd q = plan.q_initial;
    for (const Leg l : model::kLegs) {
      const Eigen::Vector2d qs = jointsAt(t, l);
      q[model::jointIndex(l, JointKind::HFE)] = qs[0];
      q[model::jointIndex(l, JointKind::KFE)] = qs[1];
    }
    return q;
  };
  auto accel = [&](double t, const Eigen::Matrix<double, 6, 1>& y) {
    Eigen::Vector2d fh = Eigen::Vector2d::Zero(), ff = Eigen::Vector2d::Zero();
    for (const auto& ph : plan.force_phases)
      if (t >= ph.t_start && t <= ph.t_end) {
        const double tau = t - ph.t_start;
        fh = {ph.hind.fx(tau), ph.hind.fz(tau)};
        ff = {ph.front.fx(tau), ph.front.fz(tau)};
        break;
      }
    // The tail: the force at t2 holds until the executor's first control instant after t2
    // (kExecutorControlPeriod), then falls linearly to zero over takeoff_unload_s.
    const double unload = m.settings().takeoff_unload_s;
    const double release =
        (std::floor(plan.t2 / kExecutorControlPeriod + 1e-9) + 1.0) * kExecutorControlPeriod;
    if (t > plan.t2 && plan.mode == TakeoffMode::Simultaneous && unload > 0.0 &&
        t < release + unload) {
      const auto& ph = plan.force_phases.back();
      const double tau = ph.t_end - ph.t_start,
                   share = t < release ? 1.0 : 1.0 - (t - release) / unload;
      fh = share * Eigen::Vector2d(ph.hind.fx(tau), ph.hind.fz(tau));
      ff = share * Eigen::Vector2d(ph.front.fx(tau), ph.front.fz(tau));
    } else if (t > plan.t2) {
      fh = ff = Eigen::Vector2d::Zero();
    }
    const double c = std::cos(y[2]), s = std::sin(y[2]);
    // The CoM moves in the base with the posture: axle - CoM = R (hfe + fk(q) - c(q)).
    const Eigen::VectorXd q_full = jointsFull(t);
    const Eigen::Vector3d com3 = robot().calcCompositeInertia(q_full).com;
    const Eigen::Vector2d com_b(com3.x(), com3.z());
    auto axleX = [&](const Eigen::Vector2d& h, Leg l) {
      const Eigen::Vector2d b = h + leg.forward(jointsAt(t, l)) - com_b;
      return y[0] + c * b.x() - s * b.y();
    };
    const double moment = (axleX(hfe_h, Leg::LH) - y[0]) * fh.y() +
                          (axleX(hfe_f, Leg::LF) - y[0]) * ff.y() + y[1] * (fh.x() + ff.x());
    Eigen::Matrix<double, 6, 1> d;
    d << y[3], y[4], y[5], (fh.x() + ff.x()) / m.mass(),
        (fh.y() + ff.y()) / m.mass() - m.settings().gravity, moment / m.pitchInertia();
    return d;
  };
  const PlanarState& s0 = plan.initial;
  Eigen::Matrix<double, 6, 1> y;
  y << s0.x, s0.z, s0.pitch, s0.vx, s0.vz, s0.pitch_rate;
  const int n = 4000;
  const double h = t_end / n;
  for (int i = 0; i < n; ++i) {
    const double t = i * h;
    const auto k1 = accel(t, y), k2 = accel(t + h / 2, y + h / 2 * k1),
               k3 = accel(t + h / 2, y + h / 2 * k2), k4 = accel(t + h, y + h * k3);
    y += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  return {y[0], y[1], y[2], y[3], y[4], y[5]};
}

class DirectIntegration : public ::testing::TestWithParam<TakeoffMode> {};

TEST_P(DirectIntegration, ForcePolynomialsReproduceTheSampledStates) {
  const JumpPlanner planner = makePlanner();
  Scenario sc = makePreset(planner, "vertical");
  sc.initial.v0 = 1.0;
  sc.task.mode = GetParam();
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  // The check needs a candidate whose wheels stay within the legs' reach (the inverse
  // kinematics projects unreachable axle positions, which then differ from the model's).
  PlanOptions o;
  o.max_evaluations = 3000;
  o.polish = false;
  const Eigen::VectorXd u = planner.plan(sc.task, sc.initial, o).u;
  Evaluation ev;
  m.evaluate(u, ev);
  ASSERT_GE(ev.margins[static_cast<int>(ConstraintClass::JointPosition)].worst, 0.0);
  const JumpPlan plan = m.buildPlan(u);
  const Eigen::VectorXd D = plan.decision;
  if (GetParam() == TakeoffMode::TwoStep) {
    const PlanarState mid = integrate(plan, m, D[9] / 2);
    EXPECT_NEAR(mid.x, D[0], 2e-4);
    EXPECT_NEAR(mid.z, D[1], 2e-4);
    EXPECT_NEAR(mid.pitch, D[2], 2e-3);
  }
  const PlanarState to = integrate(plan, m, D[10]);
  EXPECT_NEAR(to.x, D[3], 2e-4);
  EXPECT_NEAR(to.z, D[4], 2e-4);
  EXPECT_NEAR(to.pitch, D[5], 2e-3);
  EXPECT_NEAR(to.vz, u[kTakeoffVz], 2e-3);
  // Through the flight the joint-sample interpolation error (1 kHz) accumulates a little.
  const PlanarState td = integrate(plan, m, D[11]);
  EXPECT_NEAR(td.x, D[6], 2e-3);
  EXPECT_NEAR(td.z, D[7], 2e-3);
  // The flight attitude includes the legs' momentum (checked by the angular momentum test);
  // this rigid-body integration only checks the ballistic CoM through the flight.
  // t3 is the first wheel down, no later than the CoM at the standing height.
  EXPECT_GE(td.z, m.landingHeight() - 2e-3);
}

INSTANTIATE_TEST_SUITE_P(Modes, DirectIntegration,
                         ::testing::Values(TakeoffMode::Simultaneous, TakeoffMode::TwoStep));

TEST(JumpModel, ConstantForceTakeoffMatchesItsAnalyticSolution) {
  const JumpPlanner planner = makePlanner();
  Scenario sc = makePreset(planner, "vertical");
  sc.initial.v0 = 0.5;
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  // Half-way between two control instants, where a take-off with the unloading tail ends.
  const double T = 0.2005, Fx = 40.0, Fz = 500.0, g = m.settings().gravity, M = m.mass();
  Eigen::VectorXd u = nominalU(m);
  u[kT1] = T;
  u[kTakeoffDx] = Fx / M * T * T / 2;  // x(T) - v0 T
  u[kTakeoffDvx] = Fx / M * T;
  u[kTakeoffDz] = (Fz / M - g) * T * T / 2;
  u[kTakeoffVz] = (Fz / M - g) * T;
  const JumpPlan plan = m.buildPlan(u);
  ASSERT_EQ(plan.force_phases.size(), 1u);
  const auto& ph = plan.force_phases[0];
  for (const double t : {0.0, 0.05, 0.13, T}) {
    EXPECT_NEAR(ph.hind.fx(t) + ph.front.fx(t), Fx, 1e-6);
    EXPECT_NEAR(ph.hind.fz(t) + ph.front.fz(t), Fz, 1e-6);
  }
}

// The lift-off's unloading tail: the force at t2 held until the executor's next control
// instant (half a period: t2 is half-way between two) and then falling linearly to zero over
// takeoff_unload_s adds its impulse to the flight's CoM velocity (closed form with a constant
// push), and nothing without the tail.
TEST(JumpModel, UnloadingTailAddsTheHeldAndFallingLiftOffForceImpulse) {
  Scenario sc = makePreset(makePlanner(), "vertical");
  sc.initial.v0 = 0.5;
  for (const double unload : {0.0, 0.003, 0.01}) {
    PlannerSettings s = makePlanner().settings();
    s.takeoff_unload_s = unload;
    const JumpModel m(robot(), s, sc.task, sc.initial);
    const double T = 0.2005, Fx = 40.0, Fz = 500.0, g = s.gravity, M = m.mass();
    const double w = unload > 0.0 ? 0.5 * kExecutorControlPeriod + 0.5 * unload : 0.0;
    Eigen::VectorXd u = nominalU(m);
    u[kT1] = T;
    u[kTakeoffDx] = Fx / M * T * T / 2;
    u[kTakeoffDvx] = Fx / M * T;
    u[kTakeoffDz] = (Fz / M - g) * T * T / 2;
    u[kTakeoffVz] = (Fz / M - g) * T;
    const JumpPlan plan = m.buildPlan(u);
    SCOPED_TRACE(unload);
    EXPECT_NEAR(plan.t2, T, 1e-12);
    EXPECT_NEAR(plan.predicted.takeoff.state.vx, 0.5 + Fx / M * T + w * Fx / M, 1e-9);
    EXPECT_NEAR(plan.predicted.takeoff.state.vz, (Fz / M - g) * T + w * Fz / M, 1e-9);
    // The push itself is u's (the tail comes after it).
    EXPECT_NEAR(plan.centroidal[100].vz, (Fz / M - g) * 100 * plan.dt, 1e-6);
  }
}

// How long the force at t2 acts on after it: until the first control instant after t2 (the
// row at t2 itself is the push's), then half the unloading time; nothing without the tail.
TEST(JumpModel, UnloadingTailWeightHoldsToTheNextControlInstant) {
  const double dt = 0.001, d = 0.003;
  EXPECT_NEAR(unloadingTailWeight(0.2005, dt, d), 0.0005 + 0.0015, 1e-12);
  EXPECT_NEAR(unloadingTailWeight(0.2009, dt, d), 0.0001 + 0.0015, 1e-12);
  EXPECT_NEAR(unloadingTailWeight(0.2001, dt, d), 0.0009 + 0.0015, 1e-12);
  EXPECT_NEAR(unloadingTailWeight(0.2, dt, d), 0.001 + 0.0015, 1e-12);  // the row at t2: push
  EXPECT_NEAR(unloadingTailWeight(0.3, 0.002, d), 0.002 + 0.0015, 1e-12);
  EXPECT_EQ(unloadingTailWeight(0.2005, dt, 0.0), 0.0);
}

// With the tail, a simultaneous take-off's t2 is half-way between two control instants
// whatever u's t1 (so that the executor's hold is half a period, away from both edges of its
// sawtooth); without it, u's t1 as it is. A two-step take-off keeps u's times.
TEST(JumpModel, TakeoffEndsHalfWayBetweenControlInstantsWithTheTail) {
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "vertical");
  for (const double unload : {0.0, 0.003}) {
    PlannerSettings s = planner.settings();
    s.takeoff_unload_s = unload;
    const JumpModel m(robot(), s, sc.task, sc.initial);
    for (const double t1 : {0.3, 0.3003, 0.30099, 0.3011}) {
      Eigen::VectorXd u = nominalU(m);
      u[kT1] = t1;
      const double expected =
          unload > 0.0 ? (std::floor(t1 / kExecutorControlPeriod) + 0.5) * kExecutorControlPeriod
                       : t1;
      SCOPED_TRACE(t1);
      EXPECT_NEAR(m.buildPlan(u).t2, expected, 1e-12);
      // The executors' period, not the plan's sample period.
      PlannerSettings fine = s;
      fine.output_dt_s = 0.0005;
      EXPECT_NEAR(JumpModel(robot(), fine, sc.task, sc.initial).buildPlan(u).t2, expected, 1e-12);
    }
  }
  Scenario flip = makePreset(planner, "backflip");
  const JumpModel mf(robot(), planner.settings(), flip.task, flip.initial);
  Eigen::VectorXd u = nominalU(mf);
  u[kT1] = 0.2003;
  EXPECT_NEAR(mf.buildPlan(u).t1, 0.2003, 1e-12);
}

// Total angular momentum about the CoM, from the plan's samples through the URDF tree (3D
// link poses, central differences): an independent check of the flight attitude model. Wheels
// spin freely in flight, so only their mass counts (their spin momentum is their own).
double angularMomentumY(const JumpPlan& plan, int k) {
  auto linkPoses = [&](int i, Eigen::Vector3d& com) {
    Eigen::VectorXd q = plan.q.row(i).transpose();
    for (const Leg l : model::kLegs) q[model::jointIndex(l, JointKind::Wheel)] = 0.0;
    const model::Inertia ci = robot().calcCompositeInertia(q);
    const PlanarState& s = plan.centroidal[i];
    Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
    X_WB.linear() = Eigen::AngleAxisd(-s.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
    com = Eigen::Vector3d(s.x, 0.0, s.z);
    X_WB.translation() = com - X_WB.linear() * ci.com;
    auto X = robot().calcLinkPoses(q);
    for (auto& x : X) x = X_WB * x;
    return X;
  };
  Eigen::Vector3d c_prev, c_next, c;
  const auto Xp = linkPoses(k - 1, c_prev), Xn = linkPoses(k + 1, c_next), X = linkPoses(k, c);
  const Eigen::Vector3d v_c = (c_next - c_prev) / (2 * plan.dt);
  double h = 0.0;
  for (std::size_t i = 0; i < X.size(); ++i) {
    const auto& link = robot().links()[i];
    const bool wheel =
        link.parent_joint >= 0 && robot().joints()[link.parent_joint].kind == JointKind::Wheel;
    const Eigen::Vector3d p = X[i] * link.inertia.com;
    const Eigen::Vector3d v = (Xn[i] * link.inertia.com - Xp[i] * link.inertia.com) / (2 * plan.dt);
    h += link.inertia.mass * (p - c).cross(v - v_c).y();
    if (wheel) continue;
    const Eigen::Matrix3d dR = Xn[i].linear() * Xp[i].linear().transpose();
    const double w = std::atan2(dR(0, 2), dR(0, 0)) / (2 * plan.dt);
    const Eigen::Matrix3d Iw = X[i].linear() * link.inertia.inertia_com * X[i].linear().transpose();
    h += Iw(1, 1) * w;
  }
  return h;
}

TEST(JumpModel, BallisticApexAndConservedAngularMomentum) {
  PlannerSettings fine;
  fine.samples_flight = 128;  // the attitude table's resolution bounds the check's accuracy
  const JumpPlanner planner = makePlanner(fine);
  const Scenario sc = makePreset(planner, "vertical");
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  const Eigen::VectorXd u = nominalU(m);
  Evaluation ev;
  m.evaluate(u, ev);
  ASSERT_TRUE(ev.valid);
  const PlanarState& to = ev.predicted.takeoff.state;
  const double g = m.settings().gravity;
  EXPECT_NEAR(ev.predicted.apex.state.z, to.z + to.vz * to.vz / (2 * g), 1e-12);
  EXPECT_NEAR(ev.predicted.apex.t - ev.predicted.takeoff.t, to.vz / g, 1e-12);
  // The first wheel touches down no later than the CoM reaches the standing height.
  EXPECT_GE(ev.predicted.touchdown.state.z, m.landingHeight() - 1e-9);
  const JumpPlan plan = m.buildPlan(u);
  // From just after the lift-off to the end (every tenth row), against the take-off's last
  // rows. (Row by row within the legs' braking the rows' momentum is off by up to 0.023, 3 %:
  // their pitch rate is interpolated between the attitude table's samples.)
  const int k2 = static_cast<int>(plan.t2 / plan.dt);
  const int k0 = k2 + 3, k1 = plan.numSamples() - 3;
  ASSERT_GT(k1 - k0, 100);
  const double h0 = angularMomentumY(plan, k0);
  // The take-off's momentum at t2, extrapolated from its last three rows (each uses its
  // neighbours, so none may be the last take-off row), plus the unloading tail's: its rate
  // there times the tail's weight (docs/planner.md, "The balanced stance").
  const double h_a = angularMomentumY(plan, k2 - 3), h_b = angularMomentumY(plan, k2 - 2),
               h_c = angularMomentumY(plan, k2 - 1);
  const double x = plan.t2 / plan.dt - (k2 - 1);  // 0 at row k2 - 1
  const double h_t2 = h_c + (h_c - h_b) * x + 0.5 * (h_c - 2 * h_b + h_a) * x * (x + 1);
  const double rate_t2 = ((h_c - h_b) + (h_c - 2 * h_b + h_a) * (x + 0.5)) / plan.dt;
  const double tail =
      unloadingTailWeight(plan.t2, kExecutorControlPeriod, planner.settings().takeoff_unload_s) *
      rate_t2;
  EXPECT_GT(std::abs(tail), 0.02);  // the legs' momentum at the push's end: 20-30 Nm
  EXPECT_NEAR(h_t2 + tail, h0, 0.02);
  double pitch_rate_change = 0.0;
  for (int k = k0; k < k1; k += 10) {
    EXPECT_NEAR(angularMomentumY(plan, k), h0, 0.015) << "t = " << k * plan.dt;  // ~2 %
    pitch_rate_change = std::max(pitch_rate_change, std::abs(plan.centroidal[k].pitch_rate -
                                                             plan.centroidal[k0].pitch_rate));
    EXPECT_NEAR(plan.centroidal[k].vx, to.vx, 1e-12);
  }
  // The legs' motion does turn the body: the conservation is not a constant pitch rate.
  EXPECT_GT(pitch_rate_change, 0.05);
}

// The lift-off correction (docs/planner.md, "The lift-off correction") is an impulse at t2:
// the push's rows stay the candidate's, the flight starts with the CoM velocity and the angular
// momentum moved by exactly the correction, and flies on from there (ballistic apex, more
// nose-up momentum turns more). The plan's flight momentum (JumpEvent::momentum, the wheels as
// point masses) is the flight rows' own, through the URDF tree. Out-of-range corrections are
// refused by name.
TEST(JumpModel, LiftOffCorrectionIsAnImpulseAtLiftOff) {
  PlannerSettings fine;
  fine.samples_flight = 128;
  const JumpPlanner planner = makePlanner(fine);
  const Scenario sc = makePreset(planner, "vertical");
  const LiftOffCorrection c{0.05, -0.08, 0.1};
  const JumpModel m0(robot(), planner.settings(), sc.task, sc.initial);
  const JumpModel m1(robot(), planner.settings(), sc.task, sc.initial, c);
  const Eigen::VectorXd u = nominalU(m0);
  const JumpPlan p0 = m0.buildPlan(u), p1 = m1.buildPlan(u);
  EXPECT_TRUE(p0.liftoff_correction.isZero());
  EXPECT_EQ(p1.liftoff_correction.vz, c.vz);
  const int k2 = static_cast<int>(p0.t2 / p0.dt);
  ASSERT_EQ(p1.t2, p0.t2);
  for (int k = 0; k <= k2; ++k) {
    EXPECT_EQ(p1.centroidal[k].vz, p0.centroidal[k].vz) << k;
    EXPECT_EQ(p1.q.row(k), p0.q.row(k)) << k;
  }
  const JumpEvent &a = p0.predicted.takeoff, &b = p1.predicted.takeoff;
  EXPECT_NEAR(b.state.vx - a.state.vx, c.vx, 1e-12);
  EXPECT_NEAR(b.state.vz - a.state.vz, c.vz, 1e-12);
  EXPECT_NEAR(b.momentum - a.momentum, c.momentum, 1e-12);
  const double g = planner.settings().gravity;
  EXPECT_NEAR(p1.predicted.apex.state.z, b.state.z + b.state.vz * b.state.vz / (2 * g), 1e-12);
  EXPECT_GT(p1.predicted.touchdown.state.pitch - p0.predicted.touchdown.state.pitch, 0.02);
  // The flight rows' momentum through the URDF tree (about +y; nose-up is about -y).
  const int k0 = k2 + 3;
  EXPECT_NEAR(-angularMomentumY(p0, k0), a.momentum, 0.015);
  EXPECT_NEAR(-angularMomentumY(p1, k0), b.momentum, 0.015);
  const auto refused = [&](LiftOffCorrection bad, const std::string& field) {
    try {
      JumpModel(robot(), planner.settings(), sc.task, sc.initial, bad);
      ADD_FAILURE() << field << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  refused({0.0, 1.5, 0.0}, "liftoff_correction.vz");
  refused({-1.01, 0.0, 0.0}, "liftoff_correction.vx");
  refused({0.0, 0.0, std::nan("")}, "liftoff_correction.momentum");
}

// The legs' references at the lift-off (issue 22, the dead stop): the flight's, and for a
// two-step take-off the lifted front pair's after t1, start at the take-off joint speeds and
// brake within the drives' envelopes, coming to rest short of the joint limits; the flight
// feed-forward is that braking torque and nothing once at rest. At a 1 m/s run-up the hind
// knees leave the ground at 38-39 rad/s, near their no-load speed, where the envelope leaves
// a few Nm to brake with: before the flight's braking was checked from the converged take-off
// state (sweepFlight), the plan's own references ran the hind knee 0.29 rad past its stop.
struct LiftOffCase {
  TakeoffMode mode;
  double v0;
};

class LiftOffBraking : public ::testing::TestWithParam<LiftOffCase> {};

TEST_P(LiftOffBraking, LegsBrakeFromTheirTakeoffSpeeds) {
  const JumpPlanner planner = makePlanner();
  Scenario sc = makePreset(planner, "vertical", GetParam().v0);
  sc.task.mode = GetParam().mode;
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  PlanOptions o;
  o.max_evaluations = 3000;
  o.polish = false;
  const Eigen::VectorXd u = planner.plan(sc.task, sc.initial, o).u;
  const JumpPlan plan = m.buildPlan(u);
  const bool two_step = GetParam().mode == TakeoffMode::TwoStep;
  const int k2 = static_cast<int>(std::floor(plan.t2 / plan.dt));
  const int k1 = static_cast<int>(std::floor(plan.t1 / plan.dt));
  double fastest = 0.0, strongest = 0.0;
  for (const Leg leg : model::kLegs) {
    const bool front = model::isFront(leg);
    const int lift = two_step && front ? k1 : k2;  // the pair's last row in contact
    for (const JointKind kind : {JointKind::HFE, JointKind::KFE}) {
      const int j = model::jointIndex(leg, kind);
      const auto& spec = robot().joints()[j];
      fastest = std::max(fastest, std::abs(plan.qd(lift, j)));
      // Speed continuous at the lift-off: at most one row of braking (< 6000 rad/s^2; the hind
      // knee of the two-step take-off brakes at up to ~4900, the cubic's peak; a dead stop
      // would be the whole 15-30 rad/s in one row).
      EXPECT_NEAR(plan.qd(lift + 1, j), plan.qd(lift, j), 6000.0 * plan.dt) << spec.name;
      double rest = -1.0;
      for (int k = lift + 1; k < plan.numSamples(); ++k) {
        const double tau = plan.tau(k, j), qd = plan.qd(k, j);
        EXPECT_LE(std::abs(tau), spec.actuator.torqueLimit(qd) + 1e-9) << spec.name << " " << k;
        EXPECT_GE(plan.q(k, j), spec.lower_rad + 0.02) << spec.name << " row " << k;
        EXPECT_LE(plan.q(k, j), spec.upper_rad - 0.02) << spec.name << " row " << k;
        if (k > lift + 1 && tau != 0.0) {
          EXPECT_LE(tau * qd, 0.0) << "brakes " << spec.name;
        }
        strongest = std::max(strongest, std::abs(tau));
        if (rest < 0.0 && tau == 0.0) rest = (k - lift) * plan.dt;
      }
      // At rest within 50 ms (the two-step take-off's hind hip: 47 ms).
      EXPECT_GT(rest, 0.0) << spec.name;
      EXPECT_LT(rest, 0.05) << spec.name;
    }
  }
  EXPECT_GT(fastest, 3.0);    // there was something to brake
  EXPECT_GT(strongest, 2.0);  // ... and a feed-forward that does it
}

INSTANTIATE_TEST_SUITE_P(Modes, LiftOffBraking,
                         ::testing::Values(LiftOffCase{TakeoffMode::Simultaneous, 0.0},
                                           LiftOffCase{TakeoffMode::TwoStep, 0.0},
                                           LiftOffCase{TakeoffMode::Simultaneous, 1.0}));

// Hand-made candidates that violate one thing each.
TEST(JumpModel, ConstraintEvaluatorsOnHandMadeCases) {
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "vertical");
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  auto worst = [&](const Eigen::VectorXd& u, ConstraintClass c) {
    Evaluation ev;
    m.evaluate(u, ev);
    EXPECT_TRUE(ev.valid);
    return ev.margins[static_cast<int>(c)].worst;
  };
  Eigen::VectorXd u = nominalU(m);
  // A gentle take-off satisfies everything.
  u[kTakeoffVz] = 1.0;
  Evaluation ok;
  m.evaluate(u, ok);
  EXPECT_TRUE(ok.constraints_ok) << ok.margins[0].worst;
  // Dipping 3 cm and leaving at 2 m/s within 0.1 s needs the ground to pull at first.
  Eigen::VectorXd down = u;
  down[kT1] = 0.1;
  down[kTakeoffDz] = -0.03;
  down[kTakeoffVz] = 2.0;
  EXPECT_LT(worst(down, ConstraintClass::NormalForce), 0.0);
  // A violent forward acceleration leaves the friction cone and the wheels' envelope.
  Eigen::VectorXd slide = u;
  slide[kT1] = 0.1;
  slide[kTakeoffDvx] = 2.5;
  slide[kTakeoffDx] = 0.12;
  EXPECT_LT(worst(slide, ConstraintClass::FrictionCone), 0.0);
  EXPECT_LT(worst(slide, ConstraintClass::WheelTraction), 0.0);
  // A very short, very fast push breaks the knee's torque-speed envelope.
  Eigen::VectorXd fast = u;
  fast[kT1] = 0.08;
  fast[kTakeoffVz] = 4.0;
  fast[kTakeoffDz] = 0.15;
  EXPECT_LT(worst(fast, ConstraintClass::ActuatorEnvelope), 0.0);
  // Raising the CoM beyond the legs' reach.
  Eigen::VectorXd reach = u;
  reach[kTakeoffDz] = 0.3;
  EXPECT_LT(worst(reach, ConstraintClass::JointPosition), 0.0);
  // No obstacle: no obstacle margin at all.
  EXPECT_TRUE(std::isinf(worst(u, ConstraintClass::ObstacleClearance)));
}

TEST(JumpModel, ObstacleInTheWayIsReported) {
  const JumpPlanner planner = makePlanner();
  Scenario sc = makePreset(planner, "vertical");
  sc.task.obstacle = BoxObstacle{0.35, 0.45, 0.3};  // right in front of the front wheels
  sc.initial.v0 = 2.0;
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  Eigen::VectorXd u = nominalU(m);
  Evaluation ev;
  m.evaluate(u, ev);
  ASSERT_TRUE(ev.valid);
  EXPECT_LT(ev.margins[static_cast<int>(ConstraintClass::ObstacleClearance)].worst, 0.0);
  EXPECT_LT(ev.predicted.min_obstacle_clearance, 0.0);
}

// A wall keeps obstacle_margin_m, a platform (a touchdown target over the box) keeps
// platform_margin_m: each margin moves its own task's obstacle rows and not the other's, and the
// predicted clearance (a distance) moves with neither.
TEST(JumpModel, WallAndPlatformKeepTheirOwnClearanceMargins) {
  for (const char* task : {"forward", "platform"}) {
    SCOPED_TRACE(task);
    const bool platform = std::string(task) == "platform";
    // A jump the task's planner finds (the box's nominal candidate does not reach the platform).
    const JumpPlanner planner = makePlanner();
    const Scenario sc = makePreset(planner, task);
    EXPECT_EQ(sc.task.landsOnObstacle(), platform);
    PlanOptions o;
    o.seed = 1;
    o.threads = 1;
    o.polish = false;
    const Eigen::VectorXd u = planner.plan(sc.task, sc.initial, o).u;
    auto obstacleRows = [&](double wall_margin, double platform_margin) {
      PlannerSettings s;
      s.obstacle_margin_m = wall_margin;
      s.platform_margin_m = platform_margin;
      const JumpModel m(robot(), s, sc.task, sc.initial);
      Evaluation ev;
      m.evaluate(u, ev);
      EXPECT_TRUE(ev.valid);
      return std::pair{ev.margins[static_cast<int>(ConstraintClass::ObstacleClearance)].worst,
                       ev.predicted.min_obstacle_clearance};
    };
    const auto [base, clearance] = obstacleRows(0.02, 0.02);
    ASSERT_TRUE(std::isfinite(base));
    const auto [wall, wall_clearance] = obstacleRows(0.05, 0.02);
    const auto [top, top_clearance] = obstacleRows(0.02, 0.05);
    EXPECT_NEAR(wall, platform ? base : base - 0.03, 1e-12);
    EXPECT_NEAR(top, platform ? base - 0.03 : base, 1e-12);
    EXPECT_NEAR(wall_clearance, clearance, 1e-12);
    EXPECT_NEAR(top_clearance, clearance, 1e-12);
  }
}

TEST(JumpModel, PenaltyFollowsThePrioritizedForm) {
  // Paper Eq. 10: a violated class n adds W_n (10^(n+3) + 10^n sigma_n).
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "vertical");
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  Eigen::VectorXd u = nominalU(m);
  u[kT1] = 0.1;
  u[kTakeoffDz] = -0.03;
  u[kTakeoffVz] = 2.0;
  Evaluation ev;
  m.evaluate(u, ev);
  double expected = 0.0;
  for (int i = 0; i < kNumConstraintClasses; ++i) {
    const auto c = static_cast<ConstraintClass>(i);
    const double w = ev.margins[i].worst;
    if (w < 0) {
      const int n = JumpModel::classPriority(c);
      expected += std::pow(10.0, n + 3) + std::pow(10.0, n) * (-w / JumpModel::classScale(c));
    }
  }
  EXPECT_GT(expected, 0.0);
  EXPECT_DOUBLE_EQ(ev.penalty, expected);
  EXPECT_NEAR(ev.cost, ev.penalty + ev.target_cost + m.settings().energy_weight * ev.energy_j,
              1e-9 * ev.cost);
}

TEST(JumpModel, BuildPlanReusesTheCallersEvaluation) {
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "forward");
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  const Eigen::VectorXd u = nominalU(m);
  Evaluation ev;
  m.evaluate(u, ev);
  ASSERT_TRUE(ev.valid);
  const JumpPlan own = m.buildPlan(u);
  const JumpPlan reused = m.buildPlan(u, &ev);
  EXPECT_EQ(own.decision, reused.decision);
  EXPECT_EQ(own.decision, m.decisionVector(u));
  EXPECT_EQ(own.predicted.apex.state.z, reused.predicted.apex.state.z);
  EXPECT_EQ(own.predicted.touchdown.state.x, reused.predicted.touchdown.state.x);
  EXPECT_EQ(own.predicted.touchdown.t, reused.predicted.touchdown.t);
  EXPECT_EQ(own.q, reused.q);
  // A cut-off evaluation is partial: it is not used.
  Evaluation partial;
  m.evaluate(u, partial, 0.0);
  ASSERT_TRUE(partial.cut_off);
  EXPECT_EQ(m.buildPlan(u, &partial).predicted.apex.state.z, own.predicted.apex.state.z);
}

TEST(JumpModel, CutOffEvaluationBoundsTheFullCostFromBelow) {
  // evaluate() with a cut-off either runs in full (the same numbers as without one) or stops
  // with a cost above the cut-off and at most the full cost.
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "forward");
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  std::mt19937_64 rng(5);
  int cut = 0, full = 0;
  for (int trial = 0; trial < 300; ++trial) {
    Eigen::VectorXd u(m.dimension());
    for (int j = 0; j < m.dimension(); ++j)
      u[j] = std::uniform_real_distribution<double>(m.lowerBounds()[j], m.upperBounds()[j])(rng);
    Evaluation reference, bounded;
    m.evaluate(u, reference);
    EXPECT_FALSE(reference.cut_off);
    if (!reference.valid) continue;
    // Cut-offs from far below to above the cost, in log steps.
    const double cutoff = reference.cost * std::pow(10.0, -3.0 + 3.5 * (trial % 8) / 7.0);
    m.evaluate(u, bounded, cutoff);
    if (bounded.cut_off) {
      ++cut;
      EXPECT_GT(bounded.cost, cutoff);
      EXPECT_LE(bounded.cost, reference.cost);
      EXPECT_FALSE(bounded.feasible);
    } else {
      ++full;
      EXPECT_EQ(bounded.cost, reference.cost);
      EXPECT_EQ(bounded.feasible, reference.feasible);
      EXPECT_EQ(bounded.energy_j, reference.energy_j);
    }
    if (cutoff >= reference.cost) {
      EXPECT_FALSE(bounded.cut_off) << "cut-off above the cost";
    }
  }
  EXPECT_GT(cut, 20);
  EXPECT_GT(full, 20);
}

TEST(JumpModel, PlanarCompositeCoMMatchesTheUrdfTree) {
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "vertical");
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  for (const auto& [qh, qf] : {std::pair{Eigen::Vector2d(1.0, -2.0), Eigen::Vector2d(1.0, -2.0)},
                               {Eigen::Vector2d(0.3, -0.6), Eigen::Vector2d(1.4, -2.6)},
                               {Eigen::Vector2d(-0.5, -1.0), Eigen::Vector2d(0.8, -1.6)}}) {
    Eigen::VectorXd q = Eigen::VectorXd::Zero(model::kNumJoints);
    for (const Leg l : model::kLegs) {
      const Eigen::Vector2d& qs = model::isFront(l) ? qf : qh;
      q[model::jointIndex(l, JointKind::HFE)] = qs[0];
      q[model::jointIndex(l, JointKind::KFE)] = qs[1];
    }
    const Eigen::Vector3d com = robot().calcCompositeInertia(q).com;
    EXPECT_TRUE(m.comInBase(qh, qf).isApprox(Eigen::Vector2d(com.x(), com.z()), 1e-12))
        << m.comInBase(qh, qf).transpose() << " vs " << com.transpose();
  }
}

// The touchdown is the first wheel on the landing surface (docs/planner.md, "Touchdown"): in
// the plan's rows, through the robot model's own kinematics (not the planar model's), the lowest
// wheel is on the ground (forward, nose-up) or the platform's top at t3, and every wheel is
// above it 10 ms before, while the CoM is still above the standing height.
TEST(JumpModel, TouchdownIsTheFirstWheelOnTheLandingSurface) {
  const JumpPlanner planner = makePlanner();
  for (const char* task : {"forward", "platform"}) {
    SCOPED_TRACE(task);
    const Scenario sc = makePreset(planner, task);
    const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
    PlanOptions o;
    o.seed = 1;
    o.polish = false;
    const JumpPlan plan = m.buildPlan(planner.plan(sc.task, sc.initial, o).u);
    const double surface =
        sc.task.obstacle && sc.task.landsOnObstacle() ? sc.task.obstacle->height : 0.0;
    auto lowest_wheel = [&](int k) {
      const Eigen::VectorXd q = plan.q.row(k).transpose();
      const auto X = robot().calcLinkPoses(q);
      const Eigen::Vector3d com = robot().calcCompositeInertia(q).com;
      const Eigen::Matrix3d R =
          Eigen::AngleAxisd(-plan.centroidal[k].pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
      double z = 1e9;
      for (const Leg leg : model::kLegs)
        z = std::min(
            z,
            plan.centroidal[k].z +
                (R * (X[robot().joint(leg, JointKind::Wheel).child_link].translation() - com)).z());
      return z - m.constants().wheel_radius - surface;
    };
    const int last = plan.numSamples() - 1;
    EXPECT_NEAR(plan.t3, last * plan.dt, plan.dt);
    EXPECT_NEAR(lowest_wheel(last), 0.0, 2e-3);
    const int before = last - static_cast<int>(std::lround(0.01 / plan.dt));
    EXPECT_GT(lowest_wheel(before), 0.005);
    EXPECT_GT(plan.centroidal[last].z, m.landingHeight() + surface + 0.005);
  }
}

// Constraint samples of one channel are one margin along time: same class at every step.
TEST(JumpModel, ConstraintSamplesFormChannelsAlongTime) {
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "forward");
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  std::map<int, std::vector<int>> steps;
  for (int i = 0; i < m.numConstraintSamples(); ++i) {
    const auto o = m.constraintSampleOrigin(i);
    steps[o.channel].push_back(o.step);
  }
  // body, obstacle; landing; the legs' braking from the lift-off (HFE, KFE of each pair)
  const int per_contact = static_cast<int>(steps.size()) - 7;
  EXPECT_EQ(per_contact, 32);
  for (const auto& [channel, s] : steps)
    for (std::size_t k = 0; k < s.size(); ++k) EXPECT_EQ(s[k], static_cast<int>(k)) << channel;
  EXPECT_EQ(steps[0].size(), static_cast<std::size_t>(planner.settings().samples_phase1));
  EXPECT_THROW(m.constraintSampleOrigin(m.numConstraintSamples()), std::out_of_range);
}

// The wheels' speed and envelope margins are the loaded tyre's: its joint turns 1 / ratio
// times the rigid wheel's rolling rate v_axle / r, plus the slip of its traction (tau / r over
// the slip stiffness, / r). At forward_hw's 3 m/s run-up the rigid wheel rolls at 35.3 rad/s:
// the tyre's 0.99 takes 0.36 rad/s more off the speed margin, its slip up to tau_max / (r^2 k).
TEST(JumpModel, WheelMarginsAreTheLoadedTyres) {
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "forward_hw");
  PlannerSettings rigid = planner.settings();
  rigid.tyre_rolling_radius_ratio = 1.0;
  rigid.tyre_slip_stiffness_n_s_m = 1e12;  // no slip to speak of
  const JumpModel loaded_model(robot(), planner.settings(), sc.task, sc.initial);
  const JumpModel rigid_model(robot(), rigid, sc.task, sc.initial);
  Evaluation loaded, ideal;
  const Eigen::VectorXd u = nominalU(loaded_model);
  loaded_model.evaluate(u, loaded);
  rigid_model.evaluate(u, ideal);
  ASSERT_TRUE(loaded.valid && ideal.valid);
  const auto worst = [](const Evaluation& ev, ConstraintClass c) {
    return ev.margins[static_cast<int>(c)].worst;
  };
  const double r = robot().wheelRadius();
  const double rolling = (1.0 / 0.99 - 1.0) * sc.initial.v0 / r;  // 0.36 rad/s at 3 m/s
  const double slip_max = 42.0 / (r * r * 370.0);                 // at the peak wheel torque
  const double dw =
      worst(ideal, ConstraintClass::WheelSpeed) - worst(loaded, ConstraintClass::WheelSpeed);
  EXPECT_GE(dw, 0.9 * rolling);
  EXPECT_LE(dw, 1.5 * rolling + slip_max);
  EXPECT_LT(worst(loaded, ConstraintClass::WheelTraction),
            worst(ideal, ConstraintClass::WheelTraction));
  // Everything else is the same model.
  EXPECT_EQ(worst(loaded, ConstraintClass::NormalForce),
            worst(ideal, ConstraintClass::NormalForce));
  EXPECT_EQ(loaded.energy_j, ideal.energy_j);
}

// The take-off margins of one candidate under `chain` and the given contact sample counts; the
// block of the take-off instant t2 (the last take-off sample) and the take-off energy.
struct TakeoffBlock {
  std::vector<double> margins;
  double energy = 0.0;
};

TakeoffBlock takeoffBlock(const Scenario& sc, const Eigen::VectorXd& u, ContactChain chain,
                          int samples_phase1, int samples_phase2) {
  PlannerSettings s;
  s.contact_chain = chain;
  s.samples_phase1 = samples_phase1;
  s.samples_phase2 = samples_phase2;
  const JumpModel m(robot(), s, sc.task, sc.initial);
  Eigen::VectorXd g(m.numConstraintSamples());
  Eigen::Vector4d e;
  TakeoffBlock b;
  EXPECT_TRUE(m.evaluateConstraints(u, g, e, &b.energy));
  const int last = samples_phase1 + (sc.task.mode == TakeoffMode::TwoStep ? samples_phase2 : 0) - 1;
  // The take-off rows come first, a block per sample in time order.
  int per_sample = 1;
  while (m.constraintSampleOrigin(per_sample).step == 0) ++per_sample;
  for (int i = last * per_sample; i < (last + 1) * per_sample; ++i) b.margins.push_back(g[i]);
  return b;
}

TEST(JumpModel, TakeoffChainIsExactAtTheTakeoffInstant) {
  // The one-step CoM-offset iteration converges to the exact posture as the samples get denser.
  // Chained from the converged take-off posture (from_takeoff), the take-off instant is exact
  // at any density; chained from t = 0 (from_start), it carries the chain's error, largest
  // there (the legs extend fastest). A backflip always chains from the take-off.
  const JumpPlanner planner = makePlanner();
  for (const std::string name : {"forward_hw", "backflip"}) {
    const Scenario sc = makePreset(planner, name);
    PlanOptions o;  // a searched candidate: a mid-box one can sit at a singular leg posture
    o.max_evaluations = 1000;
    o.polish = false;
    const Eigen::VectorXd u = planner.plan(sc.task, sc.initial, o).u;
    const TakeoffBlock fine = takeoffBlock(sc, u, ContactChain::FromStart, 960, 640);
    const TakeoffBlock start = takeoffBlock(sc, u, ContactChain::FromStart, 24, 16);
    const TakeoffBlock takeoff = takeoffBlock(sc, u, ContactChain::FromTakeoff, 24, 16);
    if (name == "backflip") {
      // A backflip chains from the take-off whatever the setting (docs/backflip.md, "Session
      // 13": from the start its lift-off sample missed the posture its flight starts from).
      EXPECT_EQ(start.margins, takeoff.margins);
      EXPECT_EQ(start.energy, takeoff.energy);
      continue;
    }
    ASSERT_EQ(fine.margins.size(), start.margins.size()) << name;
    ASSERT_EQ(fine.margins.size(), takeoff.margins.size()) << name;
    double err_start = 0.0, err_takeoff = 0.0;
    for (std::size_t k = 0; k < fine.margins.size(); ++k) {
      err_start = std::max(err_start, std::abs(start.margins[k] - fine.margins[k]));
      err_takeoff = std::max(err_takeoff, std::abs(takeoff.margins[k] - fine.margins[k]));
    }
    EXPECT_GT(err_start, 1e-3) << name;
    EXPECT_LT(err_takeoff, 0.05 * err_start) << name;
    // Same take-off energy to the trapezoid rule's accuracy either way (2.2 % on the backflip's
    // candidate: a 0.46 s push on the hind wheels, the legs moving most).
    EXPECT_NEAR(takeoff.energy, start.energy, 0.025 * start.energy) << name;
  }
}

}  // namespace
}  // namespace wj::planner
