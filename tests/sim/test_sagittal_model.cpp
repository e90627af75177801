// The sagittal model (SimModel::Sagittal): a planar base and the left legs standing for both
// sides. For a mirror-symmetric robot, simulation and plan it must reproduce the full 3-D
// model (same ground truth to round-off, same verdicts); it must refuse what it cannot
// represent, and the verifier must fall back to the full model then.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "sim/reference_plans.h"
#include "sim/statics.h"
#include "sim/symmetry.h"
#include "sim/verifier.h"
#include "test_robot.h"

namespace wj::sim {
namespace {

constexpr double kG = 9.81;

std::filesystem::path modelsDir() {
  return WJ_MODELS_DIR;
}

using wj::test::loadRobot;

planner::JumpPlan verticalJump(const model::RobotModel& m, double v0) {
  VerticalJumpSpec spec;
  spec.v0_m_s = v0;
  return makeVerticalJumpPlan(m, spec, ContactSettings{}, kG);
}

// The robot standing on its wheels at posture q, with the PD commands that hold it there.
struct Standing {
  RobotPlacement placement;
  model::JointCommands hold{};
};

Standing standing(const model::RobotModel& m) {
  JointVector q = JointVector::Zero();
  for (const model::Leg leg : model::kLegs) {
    q[model::jointIndex(leg, model::JointKind::HFE)] = 0.8;
    q[model::jointIndex(leg, model::JointKind::KFE)] = -1.6;
  }
  const StandingStatics statics = calcStandingStatics(m, q, kG);
  Standing s;
  s.placement.q = q;
  // 2 mm into the ground, and rolling forward at 0.5 m/s: contact and slip from the start.
  s.placement.X_WB.translation() = Eigen::Vector3d(0.0, 0.0, statics.base_height_m - 0.002);
  s.placement.v_WB = Eigen::Vector3d(0.5, 0.0, 0.0);
  for (int j = 0; j < model::kNumJoints; ++j) {
    s.placement.qd[j] = model::isWheel(j) ? 0.5 / m.wheelRadius() : 0.0;
    s.hold[j] = {q[j], s.placement.qd[j], 150.0, 3.0, statics.tau[j]};
    if (model::isWheel(j)) s.hold[j] = {0.0, s.placement.qd[j], 0.0, 1.0, 0.0};
  }
  return s;
}

TEST(SagittalModel, TheProjectRobotIsMirrorSymmetric) {
  EXPECT_EQ(findAsymmetry(loadRobot()), "");
  for (int j = 0; j < model::kNumJoints; ++j) {
    EXPECT_EQ(mirrorJoint(mirrorJoint(j)), j);
    EXPECT_NE(isLeftJoint(j), isLeftJoint(mirrorJoint(j)));
  }
}

TEST(SagittalModel, AnAsymmetricRobotIsNamed) {
  std::ifstream in(modelsDir() / "wheeljump.urdf");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string urdf = ss.str();
  const std::string rf_hip = "<origin xyz=\"0.19 -0.06 0\" rpy=\"0 0 0\"/>";
  const auto at = urdf.find(rf_hip);
  ASSERT_NE(at, std::string::npos);
  urdf.replace(at, rf_hip.size(), "<origin xyz=\"0.19 -0.07 0\" rpy=\"0 0 0\"/>");
  const auto dir = std::filesystem::temp_directory_path() / "wj_sagittal_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "asymmetric.urdf") << urdf;
  const auto robot =
      model::RobotModel::load(dir / "asymmetric.urdf", modelsDir() / "actuators.yaml");
  EXPECT_NE(findAsymmetry(robot).find("RF_HAA"), std::string::npos) << findAsymmetry(robot);
  EXPECT_THROW(SimRobot(robot, SimSettings{}, SimModel::Sagittal), std::invalid_argument);
  // The verifier runs it on the full model.
  const VerificationReport r =
      Verifier(robot, VerifierSettings{}).verify(verticalJump(robot, 0.0), Scenario{});
  EXPECT_EQ(r.model, SimModel::Full);
}

TEST(SagittalModel, RefusesWhatBreaksTheSymmetry) {
  const auto robot = loadRobot();
  SimSettings noisy;
  noisy.noise.enabled = true;
  EXPECT_THROW(SimRobot(robot, noisy, SimModel::Sagittal), std::invalid_argument);
  SimSettings payload;
  payload.plant.payload.mass_kg = 1.0;
  EXPECT_THROW(SimRobot(robot, payload, SimModel::Sagittal), std::invalid_argument);
  SimSettings side_box;
  side_box.terrain.boxes.push_back({{1.0, 0.0, 0.0}, {2.0, 1.0, 0.2}, true});
  EXPECT_THROW(SimRobot(robot, side_box, SimModel::Sagittal), std::invalid_argument);

  SimRobot sagittal(robot, SimSettings{}, SimModel::Sagittal);
  Standing s = standing(robot);
  sagittal.reset(s.placement);
  model::JointCommands lopsided = s.hold;
  lopsided[model::jointIndex(model::Leg::RF, model::JointKind::KFE)].tau_ff += 1.0;
  EXPECT_THROW(sagittal.write(lopsided), AsymmetryError);
  RobotPlacement rolled = s.placement;
  rolled.X_WB.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_THROW(sagittal.reset(rolled), AsymmetryError);
  RobotPlacement splayed = s.placement;
  splayed.q[model::jointIndex(model::Leg::RH, model::JointKind::HAA)] = 0.1;
  EXPECT_THROW(sagittal.reset(splayed), AsymmetryError);
}

// Driving on the ground at contact and with slip: the sagittal model's ground truth is the full
// model's to integration round-off, with the right legs the left ones' mirror images, and the
// energy (kinetic, gravity, contact) the same.
TEST(SagittalModel, ReproducesTheFullModelOnTheGround) {
  const auto robot = loadRobot();
  SimRobot full(robot, SimSettings{}, SimModel::Full);
  SimRobot sagittal(robot, SimSettings{}, SimModel::Sagittal);
  EXPECT_EQ(sagittal.kind(), SimModel::Sagittal);
  const Standing s = standing(robot);
  full.reset(s.placement);
  sagittal.reset(s.placement);
  EXPECT_NEAR(full.calcMechanicalEnergy(), sagittal.calcMechanicalEnergy(),
              1e-9 * std::abs(full.calcMechanicalEnergy()));
  GroundTruth a, b;
  model::SensorData sa, sb;
  bool touched = false;
  for (int k = 0; k < 300; ++k) {
    full.write(s.hold);
    sagittal.write(s.hold);
    full.advance();
    sagittal.advance();
    full.calcGroundTruth(a);
    sagittal.calcGroundTruth(b);
    full.read(sa);
    sagittal.read(sb);
    ASSERT_EQ(a.t, b.t);
    ASSERT_NEAR((a.p_WC - b.p_WC).norm(), 0.0, 1e-8) << "t = " << a.t;
    ASSERT_NEAR((a.v_WC - b.v_WC).norm(), 0.0, 1e-7) << "t = " << a.t;
    ASSERT_NEAR((a.w_WB - b.w_WB).norm(), 0.0, 1e-7) << "t = " << a.t;
    ASSERT_NEAR((a.q - b.q).norm(), 0.0, 1e-7) << "t = " << a.t;
    ASSERT_NEAR((a.tau - b.tau).norm(), 0.0, 1e-4) << "t = " << a.t;
    for (int l = 0; l < model::kNumLegs; ++l) {
      ASSERT_EQ(a.wheels[l].in_contact, b.wheels[l].in_contact) << "t = " << a.t;
      ASSERT_NEAR((a.wheels[l].force_W - b.wheels[l].force_W).norm(), 0.0, 1e-3)
          << "leg " << l << ", t = " << a.t;
      touched = touched || b.wheels[l].in_contact;
    }
    for (int j = 0; j < model::kNumJoints; ++j) ASSERT_NEAR(sa.joints[j].q, sb.joints[j].q, 1e-7);
    ASSERT_NEAR((sa.imu.accel_B - sb.imu.accel_B).norm(), 0.0, 1e-4);
  }
  EXPECT_TRUE(touched);
  // The right wheels carry the left ones' load, mirrored.
  EXPECT_GT(b.wheels[1].force_W.z(), 10.0);
  EXPECT_EQ(b.wheels[1].force_W.z(), b.wheels[0].force_W.z());
  EXPECT_EQ(b.wheels[1].force_W.y(), -b.wheels[0].force_W.y());
  EXPECT_NEAR(b.X_WB.translation().y(), 0.0, 1e-15);  // the planar frames' round-off
  EXPECT_EQ(b.p_WC.y(), 0.0);
  EXPECT_NEAR(full.calcMechanicalEnergy(), sagittal.calcMechanicalEnergy(),
              1e-6 * std::abs(full.calcMechanicalEnergy()));
  EXPECT_THROW(sagittal.calcCompositeInertia(), std::logic_error);
}

void expectSameVerdict(const VerificationReport& s, const VerificationReport& f) {
  EXPECT_EQ(s.passed, f.passed);
  EXPECT_EQ(s.failures, f.failures);
  EXPECT_EQ(s.reasons.size(), f.reasons.size());
  EXPECT_EQ(s.took_off, f.took_off);
  EXPECT_EQ(s.touched_down, f.touched_down);
  EXPECT_NEAR(s.measured.apex.state.z, f.measured.apex.state.z, 1e-5);
  EXPECT_NEAR(s.measured.touchdown.state.x, f.measured.touchdown.state.x, 1e-5);
  EXPECT_NEAR(s.measured.touchdown.t, f.measured.touchdown.t, 1.5e-3);
  EXPECT_NEAR(s.max_envelope_ratio, f.max_envelope_ratio, 1e-4);
  EXPECT_NEAR(s.final_pitch_rad, f.final_pitch_rad, 1e-4);
  EXPECT_NEAR(s.final_base_height_m, f.final_base_height_m, 1e-5);
  EXPECT_NEAR(s.final_roll_rad, 0.0, 1e-15);  // the rotation matrix's round-off
}

// A jump in the air and a landing: the verifier runs the sagittal model by default and
// judges as on the full one; over an obstacle too (a wall spanning y).
TEST(SagittalModel, VerifierAgreesWithTheFullModel) {
  const auto robot = loadRobot();
  VerifierSettings full_settings;
  full_settings.model = VerificationModel::Full;
  const Verifier sagittal(robot, VerifierSettings{});
  const Verifier full(robot, full_settings);
  for (const double v0 : {0.0, 1.0}) {
    const planner::JumpPlan plan = verticalJump(robot, v0);
    const VerificationReport s = sagittal.verify(plan, Scenario{});
    const VerificationReport f = full.verify(plan, Scenario{});
    EXPECT_EQ(s.model, SimModel::Sagittal);
    EXPECT_EQ(f.model, SimModel::Full);
    EXPECT_TRUE(s.took_off);
    SCOPED_TRACE("v0 = " + std::to_string(v0));
    expectSameVerdict(s, f);
    Scenario wall;
    wall.terrain = Terrain::wall(0.3, 0.4, 0.05);
    const VerificationReport sw = sagittal.verify(plan, wall);
    const VerificationReport fw = full.verify(plan, wall);
    EXPECT_EQ(sw.model, SimModel::Sagittal);
    expectSameVerdict(sw, fw);
    EXPECT_NEAR(sw.measured.min_obstacle_clearance, fw.measured.min_obstacle_clearance, 1e-5);
  }
}

// What the sagittal model cannot represent runs on the full model.
TEST(SagittalModel, VerifierFallsBackToTheFullModel) {
  const auto robot = loadRobot();
  const Verifier verifier(robot, VerifierSettings{});
  planner::JumpPlan plan = verticalJump(robot, 0.0);
  // An asymmetric initial posture: the placement is refused, the full model runs.
  InitialState initial = initialStateFromPlan(robot, plan);
  initial.q[model::jointIndex(model::Leg::RF, model::JointKind::HAA)] += 0.05;
  EXPECT_EQ(verifier.verify(plan, initial, Scenario{}).model, SimModel::Full);
  // An asymmetric plan.
  plan.q_landing[model::jointIndex(model::Leg::RH, model::JointKind::KFE)] += 0.05;
  EXPECT_EQ(verifier.verify(plan, Scenario{}).model, SimModel::Full);
  // A non-nominal plant.
  VerifierSettings heavy;
  heavy.sim.plant.payload.mass_kg = 1.0;
  EXPECT_EQ(Verifier(robot, heavy).verify(verticalJump(robot, 0.0), Scenario{}).model,
            SimModel::Full);
}

// verifyUnless(): the same report as verify() while not stopped, nothing once stopped.
TEST(VerifierStop, StopsWhenAskedAndOnlyThen) {
  const auto robot = loadRobot();
  const Verifier verifier(robot, VerifierSettings{});
  const planner::JumpPlan plan = verticalJump(robot, 0.0);
  std::atomic<bool> stop{false};
  const auto r = verifier.verifyUnless(plan, Scenario{}, stop);
  ASSERT_TRUE(r.has_value());
  const VerificationReport v = verifier.verify(plan, Scenario{});
  EXPECT_EQ(r->passed, v.passed);
  EXPECT_EQ(r->final_time_s, v.final_time_s);
  EXPECT_EQ(r->measured.apex.state.z, v.measured.apex.state.z);
  stop = true;
  EXPECT_FALSE(verifier.verifyUnless(plan, Scenario{}, stop).has_value());
}

}  // namespace
}  // namespace wj::sim
