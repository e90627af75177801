// The server configuration: strict YAML (unknown and missing keys are errors), the effective
// configuration round-trips, the sample file is valid, plaintext only on loopback.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "error_of.h"
#include "robot_model/robot_model.h"
#include "server/config.h"
#include "server/plan_verifier.h"

namespace wj::server {
namespace {

std::string replaceLine(std::string yaml, const std::string& key_line, const std::string& with) {
  const auto at = yaml.find(key_line);
  EXPECT_NE(at, std::string::npos) << key_line;
  const auto eol = yaml.find('\n', at);
  return yaml.replace(at, eol - at, with);
}

// What ServerConfig says about `yaml`, or "accepted".
std::string errorOf(const std::string& yaml) {
  return wj::test::errorOf<std::runtime_error>(
      [&] { return ServerConfig::fromYamlString(yaml, "<test>"); });
}

TEST(ServerConfig, DefaultsRoundTripThroughTheirYaml) {
  ServerConfig c;
  c.cache.path = "/tmp/x.sqlite";
  c.cache.v0_bin_m_s = 0.1;
  c.tls.client_ca_file = "ca \"quoted\".pem";
  const ServerConfig back = ServerConfig::fromYamlString(c.toYaml(), "<round trip>");
  EXPECT_EQ(back.toYaml(), c.toYaml());
  EXPECT_EQ(back.cache.v0_bin_m_s, 0.1);
  EXPECT_EQ(back.tls.client_ca_file, "ca \"quoted\".pem");
  EXPECT_EQ(back.listen, "127.0.0.1:50051");
}

TEST(ServerConfig, SampleFileIsValidAndNucLike) {
  const auto c = ServerConfig::fromYamlFile(WJ_CONFIG_DIR "/planner_server.yaml");
  EXPECT_EQ(c.listen, "127.0.0.1:50051");
  EXPECT_EQ(c.tls.mode, TlsMode::Insecure);
  EXPECT_EQ(c.planner.de_threads, 2);
  EXPECT_EQ(c.cache.max_memory_entries, 100000);
  EXPECT_DOUBLE_EQ(c.cache.v0_bin_m_s, 0.05);
  // 500 Hz references: half the regeneration and the bytes of a hit (docs/service.md).
  EXPECT_DOUBLE_EQ(c.planner.output_dt_s, 0.002);
  // Its planner settings file is named relative to it, and found beside it whatever the
  // working directory.
  EXPECT_EQ(std::filesystem::path(c.planner.settings_file),
            (std::filesystem::path(WJ_CONFIG_DIR) / "planner_settings.yaml").lexically_normal());
  EXPECT_TRUE(std::filesystem::exists(c.planner.settings_file));
  // So is the robot client's executor, which the verifier flies the plans with.
  EXPECT_EQ(std::filesystem::path(c.verification.jump_executor_file),
            (std::filesystem::path(WJ_CONFIG_DIR) / "jump_executor.yaml").lexically_normal());
  EXPECT_TRUE(std::filesystem::exists(c.verification.jump_executor_file));
}

// The verifier flies plans with the robot client's executor file when the configuration names
// one: a different controller is a different verdict, so the verifier's settings hash (the
// cache's tag of stored verdicts) takes the file's text. Without the key: the built-in gains.
TEST(ServerConfig, TheVerifierReadsTheJumpExecutorFileAndTagsItsVerdictsWithIt) {
  const std::string base = ServerConfig{}.toYaml();
  EXPECT_EQ(ServerConfig::fromYamlString(replaceLine(base, "  jump_executor_file:", ""), "<test>")
                .verification.jump_executor_file,
            "");
  if (!simVerifierAvailable()) GTEST_SKIP() << "built without the sim component";
  const model::RobotModel robot = model::RobotModel::loadDefault();
  VerificationConfig v;
  const std::uint64_t builtin = makeSimVerifier(robot, v)->settingsHash();
  v.jump_executor_file = WJ_CONFIG_DIR "/jump_executor.yaml";
  const std::uint64_t shipped = makeSimVerifier(robot, v)->settingsHash();
  EXPECT_NE(shipped, builtin);
  EXPECT_EQ(makeSimVerifier(robot, v)->settingsHash(), shipped);
  // Another gain, another tag.
  const auto dir = std::filesystem::temp_directory_path() / "wj_test_config_executor";
  std::filesystem::create_directories(dir);
  std::ifstream in(v.jump_executor_file);
  std::stringstream text;
  text << in.rdbuf();
  std::string edited = replaceLine(text.str(), "flight_kp:", "flight_kp: 81.0");
  std::ofstream(dir / "gains.yaml") << edited;
  v.jump_executor_file = (dir / "gains.yaml").string();
  EXPECT_NE(makeSimVerifier(robot, v)->settingsHash(), shipped);
  // Errors name the key, the file and the field.
  std::ofstream(dir / "bad.yaml") << replaceLine(edited, "flight_kd:", "flight_kd: -2.0");
  v.jump_executor_file = (dir / "bad.yaml").string();
  EXPECT_THAT(wj::test::errorOf<std::invalid_argument>(
                  [&] { return makeSimVerifier(robot, v)->settingsHash(); }),
              wj::test::HasSubstr("bad.yaml: executor settings: flight_kd"));
  v.jump_executor_file = (dir / "absent.yaml").string();
  EXPECT_THAT(wj::test::errorOf<std::runtime_error>(
                  [&] { return makeSimVerifier(robot, v)->settingsHash(); }),
              wj::test::HasSubstr("verification.jump_executor_file: cannot open"));
}

TEST(ServerConfig, RelativeSettingsFilesAreBesideTheConfigAndAbsoluteOnesUnchanged) {
  const auto dir = std::filesystem::temp_directory_path() / "wj_test_config_paths";
  std::filesystem::create_directories(dir);
  std::string text = replaceLine(ServerConfig{}.toYaml(),
                                 "  settings_file:", "  settings_file: \"sub/planner.yaml\"");
  text = replaceLine(text, "  sim_settings_file:", "  sim_settings_file: \"/abs/sim.yaml\"");
  std::ofstream(dir / "server.yaml") << text;
  const auto c = ServerConfig::fromYamlFile(dir / "server.yaml");
  EXPECT_EQ(c.planner.settings_file, (dir / "sub/planner.yaml").string());
  EXPECT_EQ(c.verification.sim_settings_file, "/abs/sim.yaml");
  // A string stays as written (no file to be beside).
  EXPECT_EQ(ServerConfig::fromYamlString(text, "<test>").planner.settings_file, "sub/planner.yaml");
}

// On by default (64 MB), also in a configuration written before the key; 0 turns it off.
TEST(ServerConfig, HotResponsesAreOptionalOnByDefaultAndBounded) {
  EXPECT_EQ(ServerConfig{}.cache.hot_responses_mb, 64.0);
  const std::string base = ServerConfig{}.toYaml();
  const auto without =
      ServerConfig::fromYamlString(replaceLine(base, "  hot_responses_mb:", ""), "<test>");
  EXPECT_EQ(without.cache.hot_responses_mb, 64.0);
  const auto off = ServerConfig::fromYamlString(
      replaceLine(base, "  hot_responses_mb:", "  hot_responses_mb: 0"), "<test>");
  EXPECT_EQ(off.cache.hot_responses_mb, 0.0);
  const auto with = ServerConfig::fromYamlString(
      replaceLine(base, "  hot_responses_mb:", "  hot_responses_mb: 16"), "<test>");
  EXPECT_DOUBLE_EQ(with.cache.hot_responses_mb, 16.0);
  for (const char* bad : {"-1", "5000", ".nan"}) {
    const std::string error = errorOf(
        replaceLine(base, "  hot_responses_mb:", std::string("  hot_responses_mb: ") + bad));
    EXPECT_THAT(error, wj::test::HasSubstr("cache.hot_responses_mb")) << bad;
    EXPECT_THAT(error, wj::test::HasSubstr("[0, 4096]")) << bad;
  }
}

TEST(ServerConfig, OutputSamplePeriodIsOptionalAndBounded) {
  const std::string base = ServerConfig{}.toYaml();
  // Left out (configurations written before it): the planner settings' own period.
  const auto without =
      ServerConfig::fromYamlString(replaceLine(base, "  output_dt_s:", ""), "<test>");
  EXPECT_EQ(without.planner.output_dt_s, 0.0);
  const auto with = ServerConfig::fromYamlString(
      replaceLine(base, "  output_dt_s:", "  output_dt_s: 0.002"), "<test>");
  EXPECT_DOUBLE_EQ(with.planner.output_dt_s, 0.002);
  // Slower than the contract's 500 Hz is refused.
  EXPECT_THAT(errorOf(replaceLine(base, "  output_dt_s:", "  output_dt_s: 0.004")),
              wj::test::HasSubstr("planner.output_dt_s"));
}

// The lift-off correction's rounds: optional (configurations written before it mean 0, off),
// bounded, and part of the verifier's settings hash only when on (a cache written without it
// keeps its tag).
TEST(ServerConfig, LiftOffCorrectionRoundsAreOptionalBoundedAndTagTheVerdicts) {
  const std::string base = ServerConfig{}.toYaml();
  EXPECT_EQ(ServerConfig{}.verification.liftoff_correction_rounds, 0);
  EXPECT_EQ(
      ServerConfig::fromYamlString(replaceLine(base, "  liftoff_correction_rounds:", ""), "<test>")
          .verification.liftoff_correction_rounds,
      0);
  EXPECT_EQ(ServerConfig::fromYamlString(
                replaceLine(base, "  liftoff_correction_rounds:", "  liftoff_correction_rounds: 2"),
                "<test>")
                .verification.liftoff_correction_rounds,
            2);
  for (const char* bad : {"-1", "11"}) {
    const std::string error = errorOf(replaceLine(
        base, "  liftoff_correction_rounds:", std::string("  liftoff_correction_rounds: ") + bad));
    EXPECT_THAT(error, wj::test::HasSubstr("verification.liftoff_correction_rounds")) << bad;
    EXPECT_THAT(error, wj::test::HasSubstr("[0, 10]")) << bad;
  }
  if (!simVerifierAvailable()) GTEST_SKIP() << "built without the sim component";
  const model::RobotModel robot = model::RobotModel::loadDefault();
  VerificationConfig v;
  const std::uint64_t off = makeSimVerifier(robot, v)->settingsHash();
  v.liftoff_correction_rounds = 2;
  const std::uint64_t two = makeSimVerifier(robot, v)->settingsHash();
  v.liftoff_correction_rounds = 3;
  EXPECT_NE(two, off);
  EXPECT_NE(makeSimVerifier(robot, v)->settingsHash(), two);
}

TEST(ServerConfig, UnknownKeyIsAnErrorNamingIt) {
  const std::string yaml =
      replaceLine(ServerConfig{}.toYaml(), "  v0_bin_m_s:", "  v0_bin_m_s: 0.05\n  v0_bins: 3");
  const std::string e = errorOf(yaml);
  EXPECT_THAT(e, wj::test::HasSubstr("unknown key 'cache.v0_bins'")) << e;
}

TEST(ServerConfig, MissingKeyIsAnErrorNamingIt) {
  const std::string yaml = replaceLine(ServerConfig{}.toYaml(), "  hit_queue:", "");
  const std::string e = errorOf(yaml);
  EXPECT_THAT(e, wj::test::HasSubstr("missing key 'executor.hit_queue'")) << e;
  const std::string top = replaceLine(ServerConfig{}.toYaml(), "shutdown_grace_s:", "");
  EXPECT_THAT(errorOf(top), wj::test::HasSubstr("missing key 'shutdown_grace_s'"));
}

TEST(ServerConfig, WrongTypeAndOutOfRangeAreErrors) {
  const std::string base = ServerConfig{}.toYaml();
  EXPECT_THAT(errorOf(replaceLine(base, "  plan_workers:", "  plan_workers: many")),
              wj::test::HasSubstr("executor.plan_workers"));
  EXPECT_THAT(errorOf(replaceLine(base, "  plan_workers:", "  plan_workers: 0")),
              wj::test::HasSubstr("executor.plan_workers must be in [1, 64]"));
  EXPECT_THAT(errorOf(replaceLine(base, "  v0_bin_m_s:", "  v0_bin_m_s: .nan")),
              wj::test::HasSubstr("v0_bin_m_s"));
  EXPECT_THAT(errorOf(replaceLine(base, "  mode:", "  mode: ssl")),
              wj::test::HasSubstr("tls.mode"));
  EXPECT_THAT(errorOf("[1, 2]"), wj::test::HasSubstr("must be a map"));
  EXPECT_THAT(errorOf("listen: ["), wj::test::HasSubstr("cannot parse"));
}

TEST(ServerConfig, PlaintextOnlyOnLoopbackUnlessAllowed) {
  const std::string base = ServerConfig{}.toYaml();
  const std::string open = replaceLine(base, "listen:", "listen: \"0.0.0.0:50051\"");
  EXPECT_THAT(errorOf(open), wj::test::HasSubstr("not a loopback address"));
  const std::string allowed =
      replaceLine(open, "  allow_insecure_non_loopback:", "  allow_insecure_non_loopback: true");
  EXPECT_EQ(errorOf(allowed), "accepted");
  std::string tls = replaceLine(open, "  mode:", "  mode: tls");
  EXPECT_THAT(errorOf(tls), wj::test::HasSubstr("tls.server_cert_file"));
  tls = replaceLine(tls, "  server_cert_file:", "  server_cert_file: c.pem");
  tls = replaceLine(tls, "  server_key_file:", "  server_key_file: k.pem");
  EXPECT_EQ(errorOf(tls), "accepted");
  EXPECT_THAT(errorOf(replaceLine(tls, "  mode:", "  mode: mutual_tls")),
              wj::test::HasSubstr("tls.client_ca_file"));
}

TEST(ServerConfig, LoopbackAddresses) {
  for (const char* a : {"127.0.0.1:1", "127.1.2.3:50051", "localhost:9", "[::1]:50051"})
    EXPECT_TRUE(isLoopbackListenAddress(a)) << a;
  for (const char* a : {"0.0.0.0:1", "192.168.1.2:50051", "[::]:1", "127.0.0.1.evil.com:1",
                        "example.com:80", "128.0.0.1:5"})
    EXPECT_FALSE(isLoopbackListenAddress(a)) << a;
}

}  // namespace
}  // namespace wj::server
