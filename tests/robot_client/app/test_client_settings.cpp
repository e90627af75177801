#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "error_of.h"
#include "planner/jump_planner.h"
#include "planner/planner_settings.h"
#include "planner/presets.h"
#include "robot_client/client_settings.h"
#include "robot_client/plan_requester.h"
#include "robot_model/robot_model.h"
#include "text_edit.h"

namespace wj::robot_client {
namespace {

using wj::test::replaceFirst;

// The texts below are the shipped configuration, edited: their executor_file is beside it.
const std::string kOrigin = std::string(WJ_CONFIG_DIR) + "/robot_client.yaml";

std::string shippedConfig() {
  std::ifstream in(std::string(WJ_CONFIG_DIR) + "/robot_client.yaml");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// What parsing `text` (beside the shipped configuration) throws, as E's message (test::errorOf).
template <class E = std::exception>
std::string parseError(const std::string& text) {
  return test::errorOf<E>([&] { return parseClientSettings(text, kOrigin); });
}

TEST(ClientSettings, ShippedConfigParsesAndValidates) {
  const ClientSettings s = parseClientSettings(shippedConfig(), kOrigin);
  EXPECT_DOUBLE_EQ(s.loop.period_s, 0.001);
  EXPECT_DOUBLE_EQ(s.scenario("forward").run_up_speed_m_s, 3.0);
  EXPECT_DOUBLE_EQ(s.scenario("forward").wall_height_m, 0.25);
  EXPECT_EQ(s.scenario("vertical").event, planner::TargetEvent::Apex);
  EXPECT_EQ(s.scenarios.front().name, "forward");
  EXPECT_EQ(s.scenario("forward").after_landing, AfterLanding::RollOn);
  EXPECT_DOUBLE_EQ(s.scenario("forward").roll_on_speed_m_s, 3.0);
  EXPECT_EQ(s.scenario("vertical").after_landing, AfterLanding::Stop);
  EXPECT_THAT(test::errorOf<std::invalid_argument>([&] { return s.scenario("moonwalk"); }),
              test::HasSubstr("'moonwalk' is not one of forward, vertical"));
}

TEST(ClientSettings, UnknownKeyIsNamed) {
  const std::string text = replaceFirst(shippedConfig(), "  cpu: -1 ", "  cpu: -1\n  cpus: 2 ");
  EXPECT_THAT(parseError<std::runtime_error>(text), test::HasSubstr("unknown key 'loop.cpus'"));
}

TEST(ClientSettings, MissingKeyIsNamed) {
  const std::string text = replaceFirst(shippedConfig(), "  damping_kd: 1.5", "");
  EXPECT_THAT(parseError<std::runtime_error>(text),
              test::HasSubstr("missing key 'safety.damping_kd'"));
}

TEST(ClientSettings, OutOfRangeValueNamesFieldAndRange) {
  const std::string text = replaceFirst(shippedConfig(), "period_s: 0.001", "period_s: 0.5");
  EXPECT_THAT(parseError<std::invalid_argument>(text),
              test::HasSubstr("loop.period_s must be in [0.0001, 0.01]"));
}

TEST(ClientSettings, TheLegsIntegralIsReadAndBounded) {
  const ClientSettings s = parseClientSettings(shippedConfig(), kOrigin);
  EXPECT_DOUBLE_EQ(s.posture_integral.gain_n_per_m_s, 1000.0);
  EXPECT_DOUBLE_EQ(s.posture_integral.max_force_n, 40.0);
  EXPECT_TRUE(s.jump_leg_support);
  const std::string big = replaceFirst(shippedConfig(), "max_force_n: 40.0", "max_force_n: 400.0");
  EXPECT_THAT(parseError<std::invalid_argument>(big),
              test::HasSubstr("nmpc.posture_integral.max_force_n must be in [0, 200]"));
  const std::string missing = replaceFirst(shippedConfig(), "    band_m: 0.05", "");
  EXPECT_THAT(parseError<std::runtime_error>(missing),
              test::HasSubstr("missing key 'nmpc.posture_integral.band_m'"));
}

TEST(ClientSettings, TheRouteIsReadAndBounded) {
  const ClientSettings s = parseClientSettings(shippedConfig(), kOrigin);
  EXPECT_DOUBLE_EQ(s.route.lateral_gain_rad_per_m, 0.3);
  EXPECT_DOUBLE_EQ(s.route.max_heading_offset_rad, 0.15);
  EXPECT_DOUBLE_EQ(s.route.min_speed_m_s, 0.5);
  const std::string wide =
      replaceFirst(shippedConfig(), "max_heading_offset_rad: 0.15", "max_heading_offset_rad: 0.9");
  EXPECT_THAT(parseError<std::invalid_argument>(wide),
              test::HasSubstr("nmpc.route.max_heading_offset_rad must be in [0, 0.5]"));
  const std::string missing = replaceFirst(shippedConfig(), "    min_speed_m_s: 0.5", "");
  EXPECT_THAT(parseError<std::runtime_error>(missing),
              test::HasSubstr("missing key 'nmpc.route.min_speed_m_s'"));
}

TEST(ClientSettings, ANewScenarioIsAYamlEntryAndIsValidatedUnderItsName) {
  const std::string config = shippedConfig();
  const auto begin = config.find("  vertical:");
  ASSERT_NE(begin, std::string::npos);
  // The vertical entry alone: up to the next line indented as a scenario name, if any.
  std::size_t end = begin + 1;
  do {
    end = config.find("\n  ", end + 1);
  } while (end != std::string::npos && config[end + 3] == ' ');
  std::string hop = config.substr(begin, end == std::string::npos ? end : end + 1 - begin);
  hop.replace(0, std::string("  vertical:").size(), "  hop:");
  const std::size_t shipped = parseClientSettings(config, kOrigin).scenarios.size();
  const ClientSettings s = parseClientSettings(config + hop, kOrigin);
  ASSERT_EQ(s.scenarios.size(), shipped + 1);
  EXPECT_EQ(s.scenarios.back().name, "hop");
  EXPECT_EQ(s.scenario("hop").event, planner::TargetEvent::Apex);
  const std::string bad = replaceFirst(hop, "stand_s: 1.0", "stand_s: -1.0");
  EXPECT_THAT(parseError<std::invalid_argument>(config + bad),
              test::HasSubstr("scenarios.hop.stand_s"));
}

TEST(ClientSettings, AfterLandingModeIsOneOfStopAndRollOn) {
  const std::string text = replaceFirst(shippedConfig(), "mode: roll_on", "mode: hover");
  EXPECT_THAT(parseError<std::runtime_error>(text),
              test::HasSubstr("'hover' is not one of stop, roll_on"));
  const std::string fast = replaceFirst(shippedConfig(), "speed_m_s: 3.0\n", "speed_m_s: 9.0\n");
  EXPECT_THROW((void)parseClientSettings(fast, kOrigin), std::invalid_argument);
}

TEST(ClientSettings, PlanRetriesAreReadAndBounded) {
  const ClientSettings s = parseClientSettings(shippedConfig(), kOrigin);
  EXPECT_EQ(s.planner.retries, 4);
  const std::string many = replaceFirst(shippedConfig(), "  retries: 4 ", "  retries: 9 ");
  EXPECT_THAT(parseError<std::invalid_argument>(many), test::HasSubstr("planner.retries"));
}

// The executor's gains are config/jump_executor.yaml, found beside the configuration (the file
// the planning service's verifier reads too; its own reader is tested in tests/sim).
TEST(ClientSettings, TheExecutorIsTheJumpExecutorFileBesideTheConfiguration) {
  const ClientSettings s = parseClientSettings(shippedConfig(), kOrigin);
  EXPECT_EQ(s.executor_file, std::string(WJ_CONFIG_DIR) + "/jump_executor.yaml");
  const sim::ExecutorSettings file = sim::loadExecutorSettings(s.executor_file);
  EXPECT_DOUBLE_EQ(s.executor.touchdown_pitch_placement, file.touchdown_pitch_placement);
  EXPECT_DOUBLE_EQ(s.executor.flight_kp, file.flight_kp);
  EXPECT_DOUBLE_EQ(s.executor.takeoff_momentum_kp, file.takeoff_momentum_kp);
  EXPECT_DOUBLE_EQ(s.executor.two_step_flight_kp, file.two_step_flight_kp);
  // The shipped gains: the leg placement at the plan's angle, no take-off momentum feedback.
  EXPECT_DOUBLE_EQ(s.executor.touchdown_pitch_placement, 1.0);
  EXPECT_DOUBLE_EQ(s.executor.takeoff_momentum_kp, 0.0);
  EXPECT_DOUBLE_EQ(s.executor.flight_kp, 200.0);
  // Elsewhere: relative to another configuration's folder, or absolute.
  EXPECT_THAT(test::errorOf<std::runtime_error>(
                  [&] { return parseClientSettings(shippedConfig(), "/nonexistent/client.yaml"); }),
              test::HasSubstr("cannot open /nonexistent/jump_executor.yaml"));
  const std::string absolute =
      replaceFirst(shippedConfig(), "executor_file: jump_executor.yaml",
                   "executor_file: " + std::string(WJ_CONFIG_DIR) + "/jump_executor.yaml");
  EXPECT_EQ(parseClientSettings(absolute, "/nonexistent/client.yaml").executor_file,
            s.executor_file);
  // The inline section of the configurations before the file is refused by name.
  const std::string inline_section = replaceFirst(
      shippedConfig(), "executor_file: jump_executor.yaml", "executor:\n  flight_kp: 80.0");
  EXPECT_THAT(parseError<std::runtime_error>(inline_section), test::HasSubstr("executor_file"));
}

TEST(ClientSettings, APlatformIsAWallTheTargetLandsOn) {
  const ClientSettings s = parseClientSettings(shippedConfig(), kOrigin);
  EXPECT_TRUE(s.scenario("platform").landsOnWall());
  EXPECT_FALSE(s.scenario("forward").landsOnWall());
  EXPECT_FALSE(s.scenario("vertical").landsOnWall());
  EXPECT_TRUE(s.scenario("vertical").accept_closest_approach);
  EXPECT_FALSE(s.scenario("forward").accept_closest_approach);
  EXPECT_TRUE(s.scenario("platform").accept_closest_approach);
  // Landing on top of it needs a CoM height above its top.
  const std::string low =
      replaceFirst(shippedConfig(), "com_height_m: 0.519", "com_height_m: 0.26");
  EXPECT_THAT(parseError<std::invalid_argument>(low),
              test::HasSubstr("scenarios.platform.target.com_height_m"));
  // The roll-on's margin to the platform's far end: optional (0.5 m), and bounded.
  EXPECT_DOUBLE_EQ(s.scenario("platform").edge_margin_m, 0.5);
  EXPECT_DOUBLE_EQ(s.scenario("forward").edge_margin_m, 0.5);
  const std::string bad =
      replaceFirst(shippedConfig(), "edge_margin_m: 0.5", "edge_margin_m: -0.2");
  EXPECT_THAT(parseError<std::invalid_argument>(bad),
              test::HasSubstr("scenarios.platform.after_landing.edge_margin_m must be in [0, 10]"));
}

// A touchdown target's CoM height is where the planner's own presets put it: the CoM of the robot
// standing on the ground in the landing posture (JumpModel::standingComHeight, the planner's
// z_land), plus the platform's top and its hind-wheel drop when the robot lands on one. Computed
// here with the service's planner settings (config/planner_settings.yaml, as
// config/planner_server.yaml names them) on the robot of actuators.yaml, so that a change of the
// landing posture, of the model or of the config shows. The shipped forward and course targets
// were 0.266 m until session 16: a touchdown base height of 0.36 m less the CoM's 0.094 m offset
// (the scenario's first form), 2.6 mm below z_land (0.26856 m), as if the wheels were to land
// 2.6 mm below the ground.
TEST(ClientSettings, TouchdownTargetsAreThePlannersLandingHeight) {
  const ClientSettings s = parseClientSettings(shippedConfig(), kOrigin);
  const planner::JumpPlanner planner(
      model::RobotModel::loadDefault(),
      planner::PlannerSettings::fromYaml(std::string(WJ_CONFIG_DIR) + "/planner_settings.yaml"));
  const double z_land = planner::makePreset(planner, "forward").task.target.height;
  const double on_platform = planner::makePreset(planner, "platform").task.target.height;
  ASSERT_GT(z_land, 0.2);
  constexpr double kTolerance = 0.5e-3;  // the config's values are given to 0.1-1 mm
  for (const char* name : {"forward", "course"}) {
    const ScenarioSettings& sc = s.scenario(name);
    EXPECT_EQ(sc.event, planner::TargetEvent::Touchdown) << name;
    EXPECT_NEAR(sc.target_com_height_m, z_land, kTolerance) << name;
  }
  EXPECT_NEAR(s.scenario("platform").target_com_height_m, on_platform, kTolerance);
}

TEST(ClientSettings, WallTooCloseForTheRunUpIsRefused) {
  const std::string text =
      replaceFirst(shippedConfig(), "x_m: 14.0, thickness_m: 0.1, height_m: 0.25}\n    takeoff",
                   "x_m: 4.0, thickness_m: 0.1, height_m: 0.25}\n    takeoff");
  EXPECT_THROW((void)parseClientSettings(text, kOrigin), std::invalid_argument);
}

TEST(ClientSettings, ACourseListsItsWallsInOrder) {
  const ClientSettings s = parseClientSettings(shippedConfig(), kOrigin);
  const ScenarioSettings& course = s.scenario("course");
  ASSERT_EQ(course.wall_x_m.size(), 2u);
  EXPECT_DOUBLE_EQ(course.wallX(0), 14.0);
  EXPECT_DOUBLE_EQ(course.wallX(1), 24.0);
  EXPECT_EQ(course.jumps(), 2);
  EXPECT_EQ(s.scenario("forward").jumps(), 1);
  EXPECT_EQ(s.scenario("vertical").jumps(), 1);
  // Out of order (or too close to the previous wall's far face).
  EXPECT_THAT(parseError(replaceFirst(shippedConfig(), "x_m: [14.0, 24.0]", "x_m: [14.0, 15.0]")),
              test::HasSubstr("scenarios.course.wall.x_m[1]"));
  EXPECT_THAT(parseError(replaceFirst(shippedConfig(), "x_m: [14.0, 24.0]", "x_m: []")),
              test::HasSubstr("scenarios.course.wall.x_m must name at least one wall"));
  EXPECT_THAT(parseError(replaceFirst(shippedConfig(), "x_m: [14.0, 24.0]", "x_m: [14.0, far]")),
              test::HasSubstr("course.wall.x_m' has the wrong type"));
}

TEST(ClientSettings, TheBackflipIsATwoStepFullTurnOnTheRobotItNames) {
  const ClientSettings s = parseClientSettings(shippedConfig(), kOrigin);
  const ScenarioSettings& flip = s.scenario("backflip");
  EXPECT_EQ(flip.mode, planner::TakeoffMode::TwoStep);
  EXPECT_NEAR(flip.target_pitch_change_rad, 2.0 * M_PI, 1e-3);
  EXPECT_LT(flip.target_dx_m, 0.0);               // lands behind the start
  EXPECT_DOUBLE_EQ(flip.run_up_speed_m_s, -1.0);  // rolling backward into it
  EXPECT_FALSE(flip.has_wall);
  // The robot is chosen by configuration: the paper's 57 Nm knee (docs/backflip.md).
  EXPECT_EQ(flip.actuators_file, "actuators-57nm.yaml");
  EXPECT_EQ(s.scenario("forward").actuators_file, "actuators.yaml");
  // The same flip on the real robot: only the actuators differ.
  const ScenarioSettings& real = s.scenario("backflip_42nm");
  EXPECT_EQ(real.actuators_file, "actuators.yaml");
  EXPECT_EQ(real.mode, flip.mode);
  EXPECT_DOUBLE_EQ(real.target_pitch_change_rad, flip.target_pitch_change_rad);
  EXPECT_DOUBLE_EQ(real.target_dx_m, flip.target_dx_m);
  EXPECT_DOUBLE_EQ(real.run_up_speed_m_s, flip.run_up_speed_m_s);
  EXPECT_DOUBLE_EQ(real.speed_tolerance_m_s, flip.speed_tolerance_m_s);
  EXPECT_TRUE(real.has_takeoff_posture);
  EXPECT_DOUBLE_EQ(real.takeoff_hfe_rad, flip.takeoff_hfe_rad);
  EXPECT_DOUBLE_EQ(real.takeoff_kfe_rad, flip.takeoff_kfe_rad);
}

TEST(ClientSettings, ABackwardRunUpIsBoundedAndHasNoWall) {
  // The shipped backflip rolls backward at 1 m/s, the planner's lowest v0 (a request measured
  // past it is clamped to it: ClientRequest.SpeedIsClampedToThePlannersLowest).
  const std::string anchor = "(issue 17, docs/backflip.md)\n    run_up_speed_m_s: ";
  const std::string back = shippedConfig();
  ASSERT_NE(back.find(anchor + "-1.0"), std::string::npos);
  EXPECT_DOUBLE_EQ(parseClientSettings(back, kOrigin).scenario("backflip").run_up_speed_m_s, -1.0);
  const std::string too_fast = replaceFirst(back, anchor + "-1.0", anchor + "-1.2");
  EXPECT_THAT(parseError<std::invalid_argument>(too_fast),
              test::HasSubstr("scenarios.backflip.run_up_speed_m_s must be in [-1, 5]"))
      << parseError<std::invalid_argument>(too_fast);
  // Walls stand ahead: a forward scenario's wall with a backward run-up is refused.
  const std::string into_wall =
      replaceFirst(shippedConfig(), "run_up_speed_m_s: 3.0", "run_up_speed_m_s: -0.5");
  ASSERT_NE(into_wall, shippedConfig());
  EXPECT_THAT(parseError<std::invalid_argument>(into_wall),
              test::HasSubstr("needs wall.enabled false"))
      << parseError<std::invalid_argument>(into_wall);
}

// A backward run-up measured past the planner's lowest speed is requested at it, along the
// base's heading (yawed, pitched); slower speeds and the other components are sent as measured.
TEST(ClientRequest, SpeedIsClampedToThePlannersLowest) {
  const Eigen::Quaterniond q_WB(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()));
  const Eigen::Vector3d h(std::cos(0.7), std::sin(0.7), 0.0);
  const Eigen::Vector3d side(-std::sin(0.7), std::cos(0.7), 0.0);
  const Eigen::Vector3d fast = -1.03 * h + 0.2 * side + Eigen::Vector3d(0.0, 0.0, 0.1);
  const Eigen::Vector3d sent = requestVelocity(fast, q_WB);
  EXPECT_NEAR(sent.dot(h), kPlannerLowestSpeedMS + kRequestSpeedMarginMS, 1e-12);
  EXPECT_GT(sent.dot(h), kPlannerLowestSpeedMS);
  EXPECT_NEAR(sent.dot(side), 0.2, 1e-12);
  EXPECT_NEAR(sent.z(), 0.1, 1e-12);
  const Eigen::Vector3d slow = -0.97 * h + 0.2 * side;
  EXPECT_TRUE(requestVelocity(slow, q_WB).isApprox(slow, 1e-15));
  const Eigen::Vector3d forward = 3.0 * h;
  EXPECT_TRUE(requestVelocity(forward, q_WB).isApprox(forward, 1e-15));
}

// The backflip is requested from its take-off posture when the measured crouch is near it: every
// HFE and KFE replaced, the wheels and hip abductions untouched; one leg beyond the offset and
// the measured angles go out unchanged. Without the key, nothing changes.
TEST(ClientRequest, TheTakeoffPostureReplacesANearbyCrouch) {
  const ScenarioSettings flip = parseClientSettings(shippedConfig(), kOrigin).scenario("backflip");
  ASSERT_TRUE(flip.has_takeoff_posture);
  EXPECT_DOUBLE_EQ(flip.takeoff_hfe_rad, 1.0);
  EXPECT_DOUBLE_EQ(flip.takeoff_kfe_rad, -2.0);
  std::array<double, model::kNumJoints> measured{};
  for (const model::Leg leg : model::kLegs) {
    measured[model::jointIndex(leg, model::JointKind::HAA)] = 0.004;
    measured[model::jointIndex(leg, model::JointKind::HFE)] = 1.0115;
    measured[model::jointIndex(leg, model::JointKind::KFE)] = -1.9947;
    measured[model::jointIndex(leg, model::JointKind::Wheel)] = -8.4;
  }
  std::array<double, model::kNumJoints> q = measured;
  EXPECT_TRUE(applyTakeoffPosture(flip, q));
  for (const model::Leg leg : model::kLegs) {
    EXPECT_DOUBLE_EQ(q[model::jointIndex(leg, model::JointKind::HFE)], 1.0);
    EXPECT_DOUBLE_EQ(q[model::jointIndex(leg, model::JointKind::KFE)], -2.0);
    EXPECT_DOUBLE_EQ(q[model::jointIndex(leg, model::JointKind::HAA)], 0.004);
    EXPECT_DOUBLE_EQ(q[model::jointIndex(leg, model::JointKind::Wheel)], -8.4);
  }
  // One knee 0.04 rad off (beyond max_offset_rad 0.03): sent as measured.
  q = measured;
  q[model::jointIndex(model::Leg::RH, model::JointKind::KFE)] = -2.04;
  const auto before = q;
  EXPECT_FALSE(applyTakeoffPosture(flip, q));
  EXPECT_EQ(q, before);
  // The forward scenario has none.
  q = measured;
  EXPECT_FALSE(
      applyTakeoffPosture(parseClientSettings(shippedConfig(), kOrigin).scenario("forward"), q));
  EXPECT_EQ(q, measured);
}

TEST(ClientSettings, TheTakeoffPostureIsBoundedAndComplete) {
  const std::string shipped = shippedConfig();
  const std::string far = replaceFirst(shipped, "max_offset_rad: 0.03", "max_offset_rad: 0.3");
  ASSERT_NE(far, shipped);
  EXPECT_THAT(parseError<std::invalid_argument>(far),
              test::HasSubstr("scenarios.backflip.takeoff_posture.max_offset_rad must be in"))
      << parseError<std::invalid_argument>(far);
  const std::string knee = replaceFirst(shipped, "      kfe_rad: -2.0", "      kfe_rad: -3.0");
  ASSERT_NE(knee, shipped);
  EXPECT_THAT(parseError<std::invalid_argument>(knee),
              test::HasSubstr("takeoff_posture.kfe_rad must be in"))
      << parseError<std::invalid_argument>(knee);
  const std::string missing = replaceFirst(shipped, "      hfe_rad: 1.0", "      hfe_radius: 1.0");
  ASSERT_NE(missing, shipped);
  EXPECT_THAT(parseError<std::runtime_error>(missing),
              test::HasSubstr("missing key 'scenarios.backflip.takeoff_posture.hfe_rad'"));
}

TEST(ClientSettings, TlsNeedsItsCaAndCertificateWithKey) {
  const std::string on = replaceFirst(shippedConfig(), "    enabled: false\n    root_ca_file",
                                      "    enabled: true\n    root_ca_file");
  EXPECT_THAT(parseError<std::invalid_argument>(on), test::HasSubstr("planner.tls.root_ca_file"));
  const std::string cert_only =
      replaceFirst(shippedConfig(), "cert_file: \"\"", "cert_file: \"robot.pem\"");
  EXPECT_THROW((void)parseClientSettings(cert_only, kOrigin), std::invalid_argument);
  const std::string full =
      replaceFirst(replaceFirst(replaceFirst(on, "root_ca_file: \"\"", "root_ca_file: \"ca.pem\""),
                                "cert_file: \"\"", "cert_file: \"robot.pem\""),
                   "key_file: \"\"", "key_file: \"robot.key\"");
  const ClientSettings s = parseClientSettings(full, kOrigin);
  EXPECT_TRUE(s.planner.tls);
  EXPECT_EQ(s.planner.tls_root_ca_file, "ca.pem");
  EXPECT_EQ(s.planner.tls_key_file, "robot.key");
}

TEST(ClientSettings, BadEnumListsTheChoices) {
  const std::string text = replaceFirst(shippedConfig(), "event: touchdown", "event: landing");
  EXPECT_THAT(parseError<std::runtime_error>(text),
              test::HasSubstr("is not one of apex, touchdown"));
}

}  // namespace
}  // namespace wj::robot_client
