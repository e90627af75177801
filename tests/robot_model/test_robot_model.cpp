// The robot description: the URDF read through urdfdom must carry the paper's figures.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "error_of.h"
#include "robot_model/momentum.h"
#include "robot_model/robot_model.h"

namespace wj::model {
namespace {

const std::filesystem::path kModels = WJ_MODELS_DIR;

RobotModel loadModel() {
  return RobotModel::load(kModels / "wheeljump.urdf", kModels / "actuators.yaml");
}

TEST(RobotModel, PaperFigures) {
  const RobotModel m = loadModel();
  EXPECT_NEAR(m.totalMass(), 22.5, 1e-9);      // paper: about 22.5 kg
  EXPECT_NEAR(m.wheelRadius(), 0.085, 1e-12);  // paper: 0.085 m
  EXPECT_EQ(m.joints().size(), 16u);           // 16 actuated, 6 + 16 = 22 DoF
  EXPECT_EQ(m.links().size(), 17u);
  for (const Leg leg : kLegs) {
    const LegGeometry& g = m.legGeometry(leg);
    EXPECT_NEAR(g.thigh_length, 0.2, 1e-12);  // paper: each link about 0.2 m
    EXPECT_NEAR(g.shank_length, 0.2, 1e-12);
    const LinkSpec& wheel = m.links()[m.joint(leg, JointKind::Wheel).child_link];
    EXPECT_NEAR(wheel.inertia.mass, 1.5, 1e-12);  // paper: wheel module 1.5 kg
  }
}

TEST(RobotModel, JointsAndActuatorLimits) {
  const RobotModel m = loadModel();
  for (int i = 0; i < kNumJoints; ++i) {
    const JointSpec& j = m.joints()[i];
    EXPECT_EQ(jointIndex(j.leg, j.kind), i);
    EXPECT_EQ(j.name, std::string(toString(j.leg)) + "_" + std::string(toString(j.kind)));
    EXPECT_DOUBLE_EQ(j.actuator.peak_torque_nm, 42.0) << j.name;       // paper: 42 Nm
    EXPECT_DOUBLE_EQ(j.actuator.no_load_speed_rad_s, 40.0) << j.name;  // paper: 40 rad/s
    EXPECT_DOUBLE_EQ(j.actuator.gear_ratio, 9.0) << j.name;            // paper: 9:1
    if (j.kind == JointKind::Wheel) {
      EXPECT_TRUE(j.continuous);
      EXPECT_TRUE(std::isinf(j.lower_rad) && std::isinf(j.upper_rad));
    } else {
      EXPECT_FALSE(j.continuous);
      EXPECT_LT(j.lower_rad, j.upper_rad);
    }
  }
  EXPECT_DOUBLE_EQ(m.joint(Leg::LF, JointKind::HAA).lower_rad, -0.6);
  EXPECT_DOUBLE_EQ(m.joint(Leg::RH, JointKind::HFE).upper_rad, 2.6);
  EXPECT_DOUBLE_EQ(m.joint(Leg::LH, JointKind::KFE).upper_rad, -0.5);
}

TEST(ActuatorEnvelope, CornerAndNoLoad) {
  const ActuatorEnvelope env{42.0, 20.0, 40.0, 9.0};
  EXPECT_DOUBLE_EQ(env.torqueLimit(0.0), 42.0);
  EXPECT_DOUBLE_EQ(env.torqueLimit(-20.0), 42.0);
  EXPECT_DOUBLE_EQ(env.torqueLimit(30.0), 21.0);  // halfway down the linear segment
  EXPECT_DOUBLE_EQ(env.torqueLimit(40.0), 0.0);
  EXPECT_DOUBLE_EQ(env.torqueLimit(55.0), 0.0);
  // Driving (torque along the motion): the envelope.
  EXPECT_DOUBLE_EQ(env.torqueMargin(25.0, 30.0), -4.0);
  EXPECT_DOUBLE_EQ(env.torqueMargin(-25.0, -30.0), -4.0);
  EXPECT_DOUBLE_EQ(env.saturate(25.0, 30.0), 21.0);
  EXPECT_DOUBLE_EQ(env.saturate(-25.0, -30.0), -21.0);
  EXPECT_DOUBLE_EQ(env.saturate(10.0, 30.0), 10.0);
  EXPECT_DOUBLE_EQ(env.speedMargin(-35.0), 5.0);
  // Braking (against the motion): the peak torque at any speed, even past the no-load speed
  // (a load back-driving the joint).
  EXPECT_EQ(env.braking, Braking::Peak);
  EXPECT_DOUBLE_EQ(env.torqueLimit(-25.0, 30.0), 42.0);
  EXPECT_DOUBLE_EQ(env.torqueMargin(-25.0, 30.0), 17.0);
  EXPECT_DOUBLE_EQ(env.saturate(-50.0, 30.0), -42.0);
  EXPECT_DOUBLE_EQ(env.saturate(50.0, -45.0), 42.0);
  EXPECT_DOUBLE_EQ(env.torqueLimit(25.0, 30.0), env.torqueLimit(30.0));
  EXPECT_DOUBLE_EQ(env.torqueLimit(5.0, 0.0), 42.0);
  // A drive that does not regenerate brakes within its driving envelope.
  const ActuatorEnvelope plain{42.0, 20.0, 40.0, 9.0, Braking::Envelope};
  EXPECT_DOUBLE_EQ(plain.torqueMargin(-25.0, 30.0), -4.0);
  EXPECT_DOUBLE_EQ(plain.saturate(-25.0, 30.0), -21.0);
  EXPECT_DOUBLE_EQ(plain.saturate(50.0, -45.0), 0.0);
  EXPECT_THROW((ActuatorEnvelope{42.0, 45.0, 40.0, 9.0}.validate("x")), std::invalid_argument);
  EXPECT_THROW((ActuatorEnvelope{0.0, 20.0, 40.0, 9.0}.validate("x")), std::invalid_argument);
}

TEST(RobotModel, CompositeInertiaClosedForm) {
  const RobotModel m = loadModel();
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(kNumJoints);
  const Inertia I = m.calcCompositeInertia(q);
  EXPECT_NEAR(I.mass, 22.5, 1e-12);
  // Symmetric robot, legs straight down: CoM on the x-z mid plane and centred in x.
  EXPECT_NEAR(I.com.x(), 0.0, 1e-12);
  EXPECT_NEAR(I.com.y(), 0.0, 1e-12);
  // z of the CoM by hand: per leg hip 0, thigh 0.6*-0.08, shank 0.4*-0.3, wheel 1.5*-0.4.
  EXPECT_NEAR(I.com.z(), 4.0 * (0.6 * -0.08 + 0.4 * -0.3 + 1.5 * -0.4) / 22.5, 1e-12);
  EXPECT_TRUE(I.inertia_com.isApprox(I.inertia_com.transpose(), 1e-12));
  EXPECT_GT(I.inertia_com(1, 1), m.base().inertia.inertia_com(1, 1));  // legs add pitch inertia
  // Rotating a wheel does not move the CoM (wheel CoM on its axle).
  Eigen::VectorXd q2 = q;
  q2[jointIndex(Leg::LF, JointKind::Wheel)] = 1.3;
  EXPECT_TRUE(m.calcCompositeInertia(q2).com.isApprox(I.com, 1e-12));
}

TEST(RobotModel, CentralAngularMomentumClosedForm) {
  const RobotModel m = loadModel();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(kNumJoints);
  for (const Leg leg : kLegs) {
    q[jointIndex(leg, JointKind::HFE)] = 1.0;
    q[jointIndex(leg, JointKind::KFE)] = -2.0;
  }
  const Eigen::Matrix3d R = Eigen::AngleAxisd(-2.4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d w(0.3, -11.0, 0.2);
  // Rigid (joints at rest): the composite inertia about the CoM times the body rate.
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(kNumJoints);
  const Eigen::Matrix3d I_W = R * m.calcCompositeInertia(q).inertia_com * R.transpose();
  EXPECT_TRUE(calcCentralAngularMomentum(m, R, w, q, rest).isApprox(I_W * w, 1e-9));
  // Base at rest, one wheel spinning: the wheel's own inertia about its axle (its CoM is on
  // the axle, so the robot's CoM does not move).
  Eigen::VectorXd qd = Eigen::VectorXd::Zero(kNumJoints);
  const int wheel = jointIndex(Leg::LH, JointKind::Wheel);
  qd[wheel] = 25.0;
  const JointSpec& js = m.joints()[wheel];
  const Eigen::Isometry3d X_BL = m.calcLinkPoses(q)[js.child_link];
  const Eigen::Matrix3d R_WL = R * X_BL.linear();
  const Eigen::Vector3d spin_W = R_WL * js.axis * qd[wheel];
  const Eigen::Vector3d H_wheel =
      R_WL * m.links()[js.child_link].inertia.inertia_com * R_WL.transpose() * spin_W;
  EXPECT_TRUE(
      calcCentralAngularMomentum(m, R, Eigen::Vector3d::Zero(), q, qd).isApprox(H_wheel, 1e-6));
  // Linear in (w, qd): a knee swing adds its own part to the rigid body's.
  Eigen::VectorXd knee = Eigen::VectorXd::Zero(kNumJoints);
  knee[jointIndex(Leg::LF, JointKind::KFE)] = 20.0;
  const Eigen::Vector3d sum = calcCentralAngularMomentum(m, R, w, q, rest) +
                              calcCentralAngularMomentum(m, R, Eigen::Vector3d::Zero(), q, knee);
  EXPECT_TRUE(calcCentralAngularMomentum(m, R, w, q, knee).isApprox(sum, 1e-7));
  EXPECT_GT(calcCentralAngularMomentum(m, R, Eigen::Vector3d::Zero(), q, knee).norm(), 0.05);
}

// Without the wheels' own rotation (WheelSpin::Excluded, the planner's flight convention): a
// spinning wheel adds nothing, and the total less the excluded form is every wheel's own
// inertia times its absolute angular velocity (the body's rate plus its spin).
TEST(RobotModel, CentralAngularMomentumWithoutTheWheelsSpin) {
  const RobotModel m = loadModel();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(kNumJoints), qd = Eigen::VectorXd::Zero(kNumJoints);
  for (const Leg leg : kLegs) {
    q[jointIndex(leg, JointKind::HFE)] = 0.8;
    q[jointIndex(leg, JointKind::KFE)] = -1.6;
    qd[jointIndex(leg, JointKind::Wheel)] = 30.0;
  }
  // (No leg joint turns: a knee's rate would turn its wheel link as well.)
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d w(0.1, -6.0, 0.2);
  Eigen::VectorXd spin_only = Eigen::VectorXd::Zero(kNumJoints);
  for (const Leg leg : kLegs) spin_only[jointIndex(leg, JointKind::Wheel)] = 30.0;
  EXPECT_LT(
      calcCentralAngularMomentum(m, R, Eigen::Vector3d::Zero(), q, spin_only, WheelSpin::Excluded)
          .norm(),
      1e-9);
  Eigen::Vector3d wheels_own = Eigen::Vector3d::Zero();
  const auto X = m.calcLinkPoses(q);
  for (const Leg leg : kLegs) {
    const JointSpec& js = m.joint(leg, JointKind::Wheel);
    const Eigen::Matrix3d R_WL = R * X[js.child_link].linear();
    const Eigen::Vector3d w_L = w + R_WL * js.axis * qd[jointIndex(leg, JointKind::Wheel)];
    wheels_own += R_WL * m.links()[js.child_link].inertia.inertia_com * R_WL.transpose() * w_L;
  }
  const Eigen::Vector3d all = calcCentralAngularMomentum(m, R, w, q, qd);
  const Eigen::Vector3d rest = calcCentralAngularMomentum(m, R, w, q, qd, WheelSpin::Excluded);
  EXPECT_TRUE((all - rest).isApprox(wheels_own, 1e-6));
  EXPECT_GT(wheels_own.norm(), 0.5);  // 4 x 0.0054 kg m^2 x 30 rad/s: the term is not small
}

// The control loop's calculator (buffers sized once) is the same arithmetic as the function,
// and the poses it keeps are calcLinkPoses' at its q; calcLinkPoses into a sized vector as well.
TEST(RobotModel, CentralMomentumCalculatorIsTheFunction) {
  const RobotModel m = loadModel();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(kNumJoints), qd = Eigen::VectorXd::Zero(kNumJoints);
  for (int j = 0; j < kNumJoints; ++j) {
    q[j] = 0.1 * j - 0.7;
    qd[j] = 3.0 - 0.4 * j;
  }
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
  const Eigen::Vector3d w(0.5, -4.0, 1.5);
  CentralMomentum calculator(m);
  for (int round = 0; round < 2; ++round)  // the second call reuses the buffers
    EXPECT_EQ(calculator.calc(R, w, q, qd), calcCentralAngularMomentum(m, R, w, q, qd));
  const std::vector<Eigen::Isometry3d> X = m.calcLinkPoses(q);
  std::vector<Eigen::Isometry3d> into(3);  // resized to the links
  m.calcLinkPoses(q, into);
  ASSERT_EQ(into.size(), X.size());
  for (std::size_t i = 0; i < X.size(); ++i) {
    EXPECT_EQ(into[i].matrix(), X[i].matrix()) << i;
    EXPECT_EQ(calculator.linkPoses()[i].matrix(), X[i].matrix()) << i;
  }
}

TEST(RobotModel, ForwardKinematicsOfTheWheel) {
  const RobotModel m = loadModel();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(kNumJoints);
  const double q1 = 0.8, q2 = -1.6;
  q[jointIndex(Leg::LF, JointKind::HFE)] = q1;
  q[jointIndex(Leg::LF, JointKind::KFE)] = q2;
  const auto X = m.calcLinkPoses(q);
  const int wheel_link = m.joint(Leg::LF, JointKind::Wheel).child_link;
  const LegGeometry& g = m.legGeometry(Leg::LF);
  // Rotation about +y by q maps (0,0,-l) to (-l sin q, 0, -l cos q).
  const Eigen::Vector3d expected = g.p_BH + g.p_HT + Eigen::Vector3d(0, g.wheel_lateral_offset, 0) +
                                   Eigen::Vector3d(-0.2 * std::sin(q1) - 0.2 * std::sin(q1 + q2), 0,
                                                   -0.2 * std::cos(q1) - 0.2 * std::cos(q1 + q2));
  EXPECT_TRUE(X[wheel_link].translation().isApprox(expected, 1e-12))
      << X[wheel_link].translation().transpose() << " vs " << expected.transpose();
}

TEST(RobotModel, ContentHashIsStable) {
  EXPECT_EQ(loadModel().contentHash(), loadModel().contentHash());
  EXPECT_NE(loadModel().contentHash(), 0u);
}

TEST(RobotModel, BadInputGivesClearErrors) {
  const auto dir = std::filesystem::temp_directory_path() / "wj_test_robot_model";
  std::filesystem::create_directories(dir);
  {
    std::ofstream(dir / "bad.yaml") << "actuator_types:\n  leg:\n    joint_kinds: [HAA, HFE, KFE]\n"
                                       "    gear_ratio: 9\n    corner_speed_rad_s: 20\n"
                                       "    braking: peak\n    cornr_speed: 3\n";
  }
  EXPECT_THAT(test::errorOf<std::runtime_error>(
                  [&] { return RobotModel::load(kModels / "wheeljump.urdf", dir / "bad.yaml"); }),
              test::HasSubstr("unknown key 'cornr_speed'"));
  {
    std::ofstream(dir / "missing.yaml")
        << "actuator_types:\n  leg:\n    joint_kinds: [HAA, HFE, KFE]\n"
           "    gear_ratio: 9\n    corner_speed_rad_s: 20\n    braking: peak\n";
  }
  EXPECT_THAT(test::errorOf<std::runtime_error>([&] {
                return RobotModel::load(kModels / "wheeljump.urdf", dir / "missing.yaml");
              }),
              test::HasSubstr("WHEEL has no actuator type"));
  // The braking limit is required and named: peak or envelope. `leg_braking`: the leg type's
  // braking line ("" for none), beside a wheel type that brakes at peak.
  const auto loadWith = [&](const std::string& file, const std::string& leg_braking) {
    std::ofstream(dir / file) << "actuator_types:\n  leg:\n    joint_kinds: [HAA, HFE, KFE]\n"
                                 "    gear_ratio: 9\n    corner_speed_rad_s: 20\n"
                              << leg_braking
                              << "  wheel:\n    joint_kinds: [WHEEL]\n    gear_ratio: 9\n"
                                 "    corner_speed_rad_s: 20\n    braking: peak\n";
    return RobotModel::load(kModels / "wheeljump.urdf", dir / file);
  };
  EXPECT_THAT(test::errorOf<std::runtime_error>([&] { return loadWith("no_braking.yaml", ""); }),
              test::HasSubstr("actuator_types.leg: missing key 'braking'"));
  EXPECT_THAT(test::errorOf<std::runtime_error>(
                  [&] { return loadWith("bad_braking.yaml", "    braking: regen\n"); }),
              test::HasSubstr("actuator_types.leg.braking: 'regen' is not one of peak, envelope"));
  const RobotModel plain = loadWith("envelope.yaml", "    braking: envelope\n");
  EXPECT_EQ(plain.joint(Leg::LH, JointKind::KFE).actuator.braking, Braking::Envelope);
  EXPECT_EQ(plain.joint(Leg::LH, JointKind::Wheel).actuator.braking, Braking::Peak);
  EXPECT_NE(plain.contentHash(), loadModel().contentHash());
  EXPECT_THROW((void)RobotModel::load(dir / "nope.urdf", kModels / "actuators.yaml"),
               std::runtime_error);
  std::filesystem::remove_all(dir);
}

// The 57 Nm actuator file raises the knees' peak torque and nothing else: every other figure,
// the envelope's corner and no-load speeds included, is the real robot's.
TEST(RobotModel, PeakTorqueOverrideRaisesTheKneesOnly) {
  const RobotModel base = loadModel();
  const RobotModel strong =
      RobotModel::load(kModels / "wheeljump.urdf", kModels / "actuators-57nm.yaml");
  for (int i = 0; i < kNumJoints; ++i) {
    const ActuatorEnvelope& a = base.joints()[i].actuator;
    const ActuatorEnvelope& b = strong.joints()[i].actuator;
    const bool knee = base.joints()[i].kind == JointKind::KFE;
    EXPECT_DOUBLE_EQ(b.peak_torque_nm, knee ? 57.0 : a.peak_torque_nm) << base.joints()[i].name;
    EXPECT_DOUBLE_EQ(b.corner_speed_rad_s, a.corner_speed_rad_s);
    EXPECT_DOUBLE_EQ(b.no_load_speed_rad_s, a.no_load_speed_rad_s);
    EXPECT_DOUBLE_EQ(b.gear_ratio, a.gear_ratio);
  }
  // Above the corner speed the envelope falls from the new peak to zero at the same no-load
  // speed: at the midpoint, half of 57 Nm.
  const ActuatorEnvelope& knee = strong.joint(Leg::LH, JointKind::KFE).actuator;
  EXPECT_NEAR(knee.torqueLimit(0.5 * (knee.corner_speed_rad_s + knee.no_load_speed_rad_s)), 28.5,
              1e-12);
  EXPECT_NE(strong.contentHash(), base.contentHash());  // a cached plan is per robot
  // Chosen by name in the models folder, as the configurations do.
  EXPECT_DOUBLE_EQ(RobotModel::loadDefault("actuators-57nm.yaml")
                       .joint(Leg::RF, JointKind::KFE)
                       .actuator.peak_torque_nm,
                   57.0);
  EXPECT_THROW((void)RobotModel::loadDefault("actuators-none.yaml"), std::invalid_argument);
  EXPECT_THROW((void)RobotModel::loadDefault(""), std::invalid_argument);
  // The same robot made in code (the knee-torque sweep): same actuators, its own hash.
  const RobotModel swept = base.withPeakTorque(JointKind::KFE, 57.0);
  for (int i = 0; i < kNumJoints; ++i)
    EXPECT_DOUBLE_EQ(swept.joints()[i].actuator.peak_torque_nm,
                     strong.joints()[i].actuator.peak_torque_nm);
  EXPECT_NE(swept.contentHash(), base.contentHash());
  EXPECT_EQ(swept.contentHash(), base.withPeakTorque(JointKind::KFE, 57.0).contentHash());
  EXPECT_THROW((void)base.withPeakTorque(JointKind::KFE, 0.0), std::invalid_argument);
  EXPECT_THROW((void)base.withPeakTorque(JointKind::KFE, 421.0), std::invalid_argument);
}

// Every malformed override is refused with the file and the field named.
TEST(RobotModel, PeakTorqueOverrideIsStrict) {
  const auto dir = std::filesystem::temp_directory_path() / "wj_test_peak_override";
  std::filesystem::create_directories(dir);
  const std::string types =
      "actuator_types:\n  leg:\n    joint_kinds: [HAA, HFE, KFE]\n    gear_ratio: 9\n"
      "    corner_speed_rad_s: 20\n    braking: peak\n  wheel:\n    joint_kinds: [WHEEL]\n"
      "    gear_ratio: 9\n    corner_speed_rad_s: 20\n    braking: peak\n";
  const auto expectError = [&](const std::string& overrides, const std::string& message) {
    std::ofstream(dir / "a.yaml") << types << overrides;
    {
      const std::string error = test::errorOf<std::runtime_error>(
          [&] { return RobotModel::load(kModels / "wheeljump.urdf", dir / "a.yaml"); });
      EXPECT_THAT(error, test::HasSubstr(message));
      EXPECT_THAT(error, test::HasSubstr("a.yaml"));
    }
  };
  expectError("peak_torque_override_nm:\n  KNEE: 57\n", "joint kind 'KNEE' is not one of");
  expectError("peak_torque_override_nm:\n  KFE: 0\n", "KFE must lie in (0, 420] Nm, got 0");
  expectError("peak_torque_override_nm:\n  KFE: -5\n", "must lie in (0, 420] Nm");
  expectError("peak_torque_override_nm:\n  KFE: 500\n", "must lie in (0, 420] Nm, got 500");
  expectError("peak_torque_override_nm:\n  KFE: .nan\n", "must lie in (0, 420] Nm");
  expectError("peak_torque_override_nm:\n  KFE: lots\n", "KFE must be a number");
  expectError("peak_torque_override_nm:\n  KFE: 57\n  KFE: 58\n", "KFE listed twice");
  expectError("peak_torque_override_nm: 57\n", "must be a map from joint kind");
  expectError("peak_torque_overide_nm:\n  KFE: 57\n", "unknown key 'peak_torque_overide_nm'");
  // A valid override applies to every joint of its kind, the URDF's figure to the others.
  std::ofstream(dir / "ok.yaml") << types << "peak_torque_override_nm:\n  HFE: 50.5\n";
  const RobotModel m = RobotModel::load(kModels / "wheeljump.urdf", dir / "ok.yaml");
  for (const Leg leg : kLegs) {
    EXPECT_DOUBLE_EQ(m.joint(leg, JointKind::HFE).actuator.peak_torque_nm, 50.5);
    EXPECT_DOUBLE_EQ(m.joint(leg, JointKind::KFE).actuator.peak_torque_nm, 42.0);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace wj::model
