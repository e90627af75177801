// The backflip (docs/backflip.md): its search box and initial guess, their settings, and a
// planned flip on the paper's 57 Nm knee (models/actuators-57nm.yaml).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "error_of.h"
#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "robot_model/momentum.h"

namespace wj::planner {
namespace {

const model::RobotModel& robot57() {
  static const model::RobotModel r = model::RobotModel::loadDefault("actuators-57nm.yaml");
  return r;
}

// A backflip uses the flip box; any other two-step take-off keeps the two-step box.
TEST(Backflip, FlipBoxReplacesTheTwoStepBounds) {
  const PlannerSettings s;
  const JumpPlanner planner(robot57(), s);
  const Scenario flip = makePreset(planner, "backflip");
  ASSERT_TRUE(flip.task.isBackflip());
  const JumpModel m(planner.robot(), s, flip.task, flip.initial);
  const std::pair<int, std::array<double, 2>> flip_box[] = {
      {kT1, s.flip_t1_s},
      {kT2MinusT1, s.flip_t2_minus_t1_s},
      {kTakeoffDpitch, s.flip_takeoff_dpitch_rad},
      {kTakeoffRate, s.flip_takeoff_pitch_rate_rad_s},
      {kTakeoffVz, s.flip_takeoff_vz_m_s}};
  for (const auto& [i, b] : flip_box) {
    EXPECT_DOUBLE_EQ(m.lowerBounds()[i], b[0]) << i;
    EXPECT_DOUBLE_EQ(m.upperBounds()[i], b[1]) << i;
  }
  // The flips the model has at 57 Nm lift off after a longer hind-only push and pitched up
  // further than the two-step box allows (docs/backflip.md).
  EXPECT_GT(s.flip_t2_minus_t1_s[1], s.t2_minus_t1_s[1]);
  EXPECT_GT(s.flip_takeoff_dpitch_rad[1], s.two_step_takeoff_dpitch_rad[1]);

  JumpTask half_turn = flip.task;  // not a flip: the two-step box
  half_turn.target.pitch_change = 1.0;
  EXPECT_FALSE(half_turn.isBackflip());
  const JumpModel h(planner.robot(), s, half_turn, flip.initial);
  EXPECT_DOUBLE_EQ(h.upperBounds()[kT2MinusT1], s.t2_minus_t1_s[1]);
  EXPECT_DOUBLE_EQ(h.upperBounds()[kTakeoffDpitch], s.two_step_takeoff_dpitch_rad[1]);
  EXPECT_DOUBLE_EQ(h.upperBounds()[kTakeoffVz], s.takeoff_vz_m_s[1]);
  JumpTask simultaneous = flip.task;  // a full turn asked of a simultaneous take-off
  simultaneous.mode = TakeoffMode::Simultaneous;
  EXPECT_FALSE(simultaneous.isBackflip());
}

TEST(Backflip, SettingsAreReadAndCheckedByName) {
  const PlannerSettings s = PlannerSettings::fromYamlString(
      "flip: {t2_minus_t1_s: [0.2, 0.9], initial_guess: [0, 0, 0, 0, 0.1, 2.5, -1, 2, 11, 0.2, "
      "0.5]}\n");
  EXPECT_DOUBLE_EQ(s.flip_t2_minus_t1_s[1], 0.9);
  ASSERT_EQ(s.flip_initial_guess.size(), 11u);
  EXPECT_DOUBLE_EQ(s.flip_initial_guess[5], 2.5);
  EXPECT_TRUE(
      PlannerSettings::fromYamlString("flip: {initial_guess: []}\n").flip_initial_guess.empty());
  const auto expectError = [](const std::string& yaml, const std::string& field) {
    EXPECT_THAT(test::errorOf([&] { return PlannerSettings::fromYamlString(yaml); }),
                test::HasSubstr(field));
  };
  expectError("flip: {initial_guess: [1, 2, 3]}\n", "flip.initial_guess");
  expectError("flip: {initial_guess: 3}\n", "flip.initial_guess");
  expectError("flip: {t1_s: [0.3, 0.1]}\n", "flip.t1_s");
  expectError("flip: {takeoff_vz_m_s: [0.0, 3.0]}\n", "flip.takeoff_vz_m_s");
  expectError("flip: {t2_minus_t1: [0.3, 0.8]}\n", "flip.t2_minus_t1");
  const PlannerSettings t = PlannerSettings::fromYamlString(
      "flip: {hind_knee_clearance_rad: 0.25, front_brake_share: 0.6}\n");
  EXPECT_DOUBLE_EQ(t.flip_hind_knee_clearance_rad, 0.25);
  EXPECT_DOUBLE_EQ(t.flip_front_brake_share, 0.6);
  expectError("flip: {hind_knee_clearance_rad: -0.1}\n", "flip.hind_knee_clearance_rad");
  expectError("flip: {front_brake_share: 0.0}\n", "flip.front_brake_share");
  expectError("flip: {front_brake_share: 1.2}\n", "flip.front_brake_share");
}

// The paper's result in this model: with the knee's peak torque at 57 Nm (every other actuator
// the robot's) a cold search plans a full backward turn landing 0.55 m behind, within the
// target's tolerances and every constraint.
// Rolling backward at 1 m/s: since the hind contact's roll starts from its phase-1 speed
// (session 12, docs/backflip.md) the standing start plans none.
TEST(Backflip, PlannedOnThe57NmKnee) {
  const JumpPlanner planner(robot57(), PlannerSettings{});
  Scenario sc = makePreset(planner, "backflip");
  sc.initial.v0 = -1.0;
  PlanOptions o;
  o.seed = 2;
  o.threads = 2;
  const PlannerResult r = planner.plan(sc.task, sc.initial, o);
  ASSERT_TRUE(r.evaluation.feasible) << r.summary;
  const JumpOutcome& p = r.evaluation.predicted;
  EXPECT_NEAR(p.touchdown.state.pitch, 2.0 * M_PI, 0.25);
  EXPECT_NEAR(p.touchdown.state.x, -0.55, 0.05);
  EXPECT_GT(p.takeoff.state.pitch, 2.0);  // a flip lifts off pitched far up (the flip box)
  // Rolling back, since the sweep chains from the take-off (session 13) this seed's knees stay
  // under the robot's 42 Nm (40.3 Nm); the hips, at their 42 Nm, and the knees' envelope bind.
  EXPECT_LE(r.evaluation.max_abs_torque_nm[2], 57.0 + 1e-9);
  // The plan's references turn the body through the full turn too.
  EXPECT_NEAR(r.plan.centroidal.back().pitch, 2.0 * M_PI, 0.25);
}

// A warm start does not replace the flip's guess (the service warm-starts a miss from its
// cached neighbours, for a flip often infeasible answers): from a poor warm start (the search
// box's lower corner) seed 1 still plans a flip, as it does cold from the guess (until session
// 14 a warm start took the guess's place).
TEST(Backflip, AWarmStartKeepsTheFlipGuess) {
  const JumpPlanner planner(robot57(), PlannerSettings{});
  Scenario sc = makePreset(planner, "backflip");
  sc.initial.v0 = -1.0;
  const JumpModel m(planner.robot(), planner.settings(), sc.task, sc.initial);
  PlanOptions o;
  o.seed = 1;
  o.threads = 2;
  o.warm_start = m.lowerBounds();
  const PlannerResult r = planner.plan(sc.task, sc.initial, o);
  ASSERT_TRUE(r.evaluation.feasible) << r.summary;
  EXPECT_NEAR(r.evaluation.predicted.touchdown.state.pitch, 2.0 * M_PI, 0.25);
}

/// The 57 Nm flip of the default guess, rolling back at 1 m/s, under `s`: its pitch rate steps
/// at t1 by the front pair's momentum relative to the body over the pitch inertia.
void expectFrontPairHandoverAtT1(const PlannerSettings& s) {
  const JumpPlanner planner(robot57(), s);
  Scenario sc = makePreset(planner, "backflip");
  sc.initial.v0 = -1.0;
  const JumpModel m(planner.robot(), s, sc.task, sc.initial);
  const Eigen::Map<const Eigen::VectorXd> u(s.flip_initial_guess.data(),
                                            static_cast<Eigen::Index>(s.flip_initial_guess.size()));
  const JumpPlan plan = m.buildPlan(u);
  const int k = static_cast<int>(std::floor(plan.t1 / plan.dt + 1e-9));  // last four-wheel row
  ASSERT_GT(plan.numSamples(), k + 2);
  const PlanarState& c = plan.centroidal[k];
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(-c.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d w(0.0, -c.pitch_rate, 0.0);
  const Eigen::VectorXd q = plan.q.row(k).transpose();
  Eigen::VectorXd qd = plan.qd.row(k).transpose();
  const auto noseUp = [&](const Eigen::VectorXd& rates) {
    return -model::calcCentralAngularMomentum(planner.robot(), R, w, q, rates).y();
  };
  const double moving = noseUp(qd);
  for (const model::Leg leg : {model::Leg::LF, model::Leg::RF})
    for (const model::JointKind kind : {model::JointKind::HFE, model::JointKind::KFE})
      qd[model::jointIndex(leg, kind)] = 0.0;
  const double handover = moving - noseUp(qd);
  ASSERT_GT(std::abs(handover), 0.5);  // the flip's front legs extend fast at t1
  const double inertia = planner.robot().calcCompositeInertia(plan.q_initial).inertia_com(1, 1);
  // The step over one sample, less the ground moment's change of rate over it (the slope on
  // either side).
  const double slope = plan.centroidal[k + 2].pitch_rate - plan.centroidal[k + 1].pitch_rate;
  const double step = plan.centroidal[k + 1].pitch_rate - c.pitch_rate - slope;
  EXPECT_NEAR(step, handover / inertia, 0.05 * std::abs(handover / inertia)) << handover;
}

// At t1 the lifted front pair brakes to rest relative to the body with no ground force on it:
// the whole robot's angular momentum about the CoM holds, so the body's I theta' takes the
// pair's momentum relative to the body (docs/backflip.md, "Session 13"). Checked against the
// multibody momentum of the plan's own references (model::calcCentralAngularMomentum) at the
// last four-wheel sample: the plan's pitch rate steps by (H - H with the front legs at rest) / I.
// The same with the take-off's pitch on the whole robot's momentum (stance_momentum), where E
// falls by the handover at t1: before session 31 its phase-2 E started from the moving front
// legs' and spread the handover over the hind push (the pitch rate did not step at t1).
TEST(Backflip, FrontPairMomentumGoesToTheBodyAtT1) {
  for (const bool stance_momentum : {false, true}) {
    SCOPED_TRACE(stance_momentum ? "stance_momentum" : "rigid pitch");
    PlannerSettings s;
    s.stance_momentum = stance_momentum;
    expectFrontPairHandoverAtT1(s);
  }
}

// A backflip's hind knee pushes settings.flip_hind_knee_clearance_rad short of its extension
// stop (-0.5 rad; 0.1 by default, 0.25 in config/backflip-42nm.yaml): a 42 Nm flip planned
// without that clearance straightened the hind knee to 0.008 rad from the stop in the hind-only
// push, and Simbody's knee chattered on it (docs/backflip.md, "A 42 Nm flip, verified in
// Simbody"). That flip's search vector now violates the joint range by the clearance less its
// 0.008 rad, at the hind knee, in the push.
TEST(Backflip, HindKneePushesClearOfItsExtensionStop) {
  for (const double clearance : {0.1, 0.25}) {
    SCOPED_TRACE(clearance);
    PlannerSettings s;
    s.flip_hind_knee_clearance_rad = clearance;
    const model::RobotModel robot42 = model::RobotModel::loadDefault("actuators.yaml");
    const JumpPlanner planner(robot42, s);
    Scenario sc = makePreset(planner, "backflip");
    sc.initial.v0 = -1.0;
    const JumpModel m(planner.robot(), s, sc.task, sc.initial);
    Eigen::VectorXd u(11);
    u << -0.000363, 0.019808, 0.132334, 0.400000, 0.270433, 2.539553, 0.272052, 1.500000, 12.246117,
        0.145947, 0.499993;
    Evaluation ev;
    m.evaluate(u, ev);
    const ClassMargin& pos = ev.margins[static_cast<int>(ConstraintClass::JointPosition)];
    const JumpPlan plan = m.buildPlan(u);
    const int knee = model::jointIndex(model::Leg::LH, model::JointKind::KFE);
    double straightest = -10.0;  // the hind knee's largest angle while the hind wheels push
    for (int k = 0; k < plan.numSamples() && k * plan.dt < plan.t2; ++k)
      straightest = std::max(straightest, plan.q(k, knee));
    ASSERT_GT(straightest, -0.52);  // the flip that chattered: within 0.02 rad of the stop
    EXPECT_EQ(pos.location, knee);
    EXPECT_GT(pos.t, plan.t1);
    EXPECT_LT(pos.t, plan.t2);
    EXPECT_NEAR(pos.worst, -0.5 - clearance - straightest, 0.005);
  }
}

// A backflip's lifted front pair brakes at settings.flip_front_brake_share of its drives'
// torque (0.8 by default, as every other lift-off; 0.6 in config/backflip-42nm.yaml: the front
// knees extend at 26-28 rad/s into t1, and braked at 0.8 Simbody's joint controllers had no
// room from perturbed starts; docs/backflip.md, "From perturbed starts"). The 42 Nm flip of
// that file (its initial_guess): the front knee's planned torque in the 50 ms after t1, the
// brake's plus the leg's dynamics, is 33 Nm at 0.8 and at most 0.7 x 42 Nm at 0.6.
TEST(Backflip, LiftedFrontPairBrakesAtItsShare) {
  const model::RobotModel robot42 = model::RobotModel::loadDefault("actuators.yaml");
  const int knee = model::jointIndex(model::Leg::LF, model::JointKind::KFE);
  const double peak = robot42.joints()[knee].actuator.peak_torque_nm;
  const auto frontBraking = [&](double share) {
    PlannerSettings s;
    s.flip_front_brake_share = share;
    const JumpPlanner planner(robot42, s);
    Scenario sc = makePreset(planner, "backflip");
    sc.initial.v0 = -1.0;
    const JumpModel m(planner.robot(), s, sc.task, sc.initial);
    Eigen::VectorXd u(11);
    u << -0.002259, 0.020900, 0.127477, 0.400000, 0.269652, 2.540581, 0.296040, 1.500000, 11.789795,
        0.156749, 0.499423;
    const JumpPlan plan = m.buildPlan(u);
    double braking = 0.0;  // the front knee's largest |torque| in the 50 ms after t1
    for (int k = 0; k < plan.numSamples(); ++k)
      if (k * plan.dt > plan.t1 + 1e-9 && k * plan.dt < plan.t1 + 0.05)
        braking = std::max(braking, std::abs(plan.tau(k, knee)));
    return braking;
  };
  EXPECT_GT(frontBraking(0.8), 0.75 * peak);
  const double gentle = frontBraking(0.6);
  EXPECT_LE(gentle, 0.7 * peak);
  EXPECT_GT(gentle, 0.5 * peak);
}

}  // namespace
}  // namespace wj::planner
