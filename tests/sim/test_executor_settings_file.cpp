// The jump executor's gains as a file (config/jump_executor.yaml): strict keys, validated
// values, and the shipped file's gains.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "error_of.h"
#include "sim/executor_settings_file.h"
#include "text_edit.h"

namespace wj::sim {
namespace {

using wj::test::replaceFirst;

const std::filesystem::path kShipped = std::filesystem::path(WJ_CONFIG_DIR) / "jump_executor.yaml";

std::string shippedYaml() {
  std::ifstream in(kShipped);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(ExecutorSettingsFile, ShippedFileIsReadAndValid) {
  const ExecutorSettings s = loadExecutorSettings(kShipped);
  s.validate();
  // The robot client's gains, which differ from the executor's built-in defaults (those go
  // with the planner's default settings, the shipped ones with config/planner_settings.yaml).
  const ExecutorSettings d;
  EXPECT_DOUBLE_EQ(s.takeoff_momentum_kp, 0.0);
  EXPECT_GT(d.takeoff_momentum_kp, 0.0);
  EXPECT_DOUBLE_EQ(s.flight_kp, 200.0);
  EXPECT_DOUBLE_EQ(s.flight_kd, 4.0);
  EXPECT_LT(s.flight_kp, d.flight_kp);
  EXPECT_DOUBLE_EQ(s.touchdown_pitch_placement, 1.0);
  EXPECT_DOUBLE_EQ(s.landing_pitch_limit_rad, 0.4);
  EXPECT_DOUBLE_EQ(s.landing_nose_down_limit_rad, 0.15);
  EXPECT_DOUBLE_EQ(s.landing_pitch_kp, 40.0);
  EXPECT_DOUBLE_EQ(s.two_step_flight_kp, 400.0);
  EXPECT_TRUE(s.landing_gravity_feedforward);
  // The tyre is the planner's (PlanExecutor.TyreFiguresAreThePlannersOwn ties the defaults).
  EXPECT_DOUBLE_EQ(s.tyre_rolling_radius_ratio, d.tyre_rolling_radius_ratio);
  EXPECT_DOUBLE_EQ(s.tyre_slip_stiffness_n_s_m, d.tyre_slip_stiffness_n_s_m);
  // Text and file read the same.
  const ExecutorSettings t = parseExecutorSettings(shippedYaml(), "text");
  EXPECT_DOUBLE_EQ(t.takeoff_kp, s.takeoff_kp);
  EXPECT_DOUBLE_EQ(t.two_step_landing_wheel_decel_m_s2, s.two_step_landing_wheel_decel_m_s2);
}

TEST(ExecutorSettingsFile, UnknownAndMissingKeysAreNamedWithTheFile) {
  const std::string unknown =
      replaceFirst(shippedYaml(), "flight_kp: 200.0", "flight_kp: 200.0\nflight_kq: 1.0");
  EXPECT_THAT(
      test::errorOf<std::runtime_error>([&] { return parseExecutorSettings(unknown, "a.yaml"); }),
      test::HasSubstr("jump executor settings a.yaml: unknown key 'flight_kq'"));
  const std::string missing = replaceFirst(shippedYaml(), "flight_kd: 4.0", "");
  EXPECT_THAT(
      test::errorOf<std::runtime_error>([&] { return parseExecutorSettings(missing, "a.yaml"); }),
      test::HasSubstr("missing key 'flight_kd'"));
  EXPECT_THAT(
      test::errorOf<std::runtime_error>([&] { return parseExecutorSettings("[1, 2", "a.yaml"); }),
      test::HasSubstr("a.yaml: cannot parse YAML"));
  EXPECT_THAT(
      test::errorOf<std::runtime_error>([] { return loadExecutorSettings("/nonexistent.yaml"); }),
      test::HasSubstr("cannot open /nonexistent.yaml"));
}

TEST(ExecutorSettingsFile, OutOfRangeValuesNameTheFieldAndTheFile) {
  const std::string tyre = replaceFirst(shippedYaml(), "tyre_rolling_radius_ratio: 0.99",
                                        "tyre_rolling_radius_ratio: 2.0");
  EXPECT_THAT(
      test::errorOf<std::invalid_argument>([&] { return parseExecutorSettings(tyre, "a.yaml"); }),
      test::HasSubstr(
          "a.yaml: executor settings: tyre_rolling_radius_ratio must be in [0.8, 1.2]"));
  const std::string momentum =
      replaceFirst(shippedYaml(), "takeoff_momentum_kd: 0.0", "takeoff_momentum_kd: -1.0");
  EXPECT_THAT(test::errorOf<std::invalid_argument>(
                  [&] { return parseExecutorSettings(momentum, "a.yaml"); }),
              test::HasSubstr("takeoff_momentum_kd"));
  const std::string placement = replaceFirst(shippedYaml(), "touchdown_pitch_placement: 1.0",
                                             "touchdown_pitch_placement: 1.5");
  EXPECT_THAT(test::errorOf<std::invalid_argument>(
                  [&] { return parseExecutorSettings(placement, "a.yaml"); }),
              test::HasSubstr("touchdown_pitch_placement"));
}

}  // namespace
}  // namespace wj::sim
