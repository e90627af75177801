// The MIT-mode codec: byte layout, round trips over the whole range within half a
// quantization step, clamping, special frames, malformed frames; the CAN settings reader.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "can/can_settings.h"
#include "can/mit_codec.h"
#include "error_of.h"

namespace wj::can {
namespace {

constexpr double kTiny = 1e-12;

MitCommand atCodes(const MitLimits& l, std::uint32_t p, std::uint32_t v, std::uint32_t kp,
                   std::uint32_t kd, std::uint32_t t) {
  return {mitDequantize(p, l.p_min, l.p_max, kMitPositionBits),
          mitDequantize(v, l.v_min, l.v_max, kMitVelocityBits),
          mitDequantize(kp, l.kp_min, l.kp_max, kMitGainBits),
          mitDequantize(kd, l.kd_min, l.kd_max, kMitGainBits),
          mitDequantize(t, l.t_min, l.t_max, kMitTorqueBits)};
}

TEST(MitCodec, CommandBytesFollowTheProtocolLayout) {
  const MitLimits l;
  CanFrame f;
  EXPECT_EQ(encodeCommand(l, 0x7, atCodes(l, 0x1234, 0x567, 0x89A, 0xBCD, 0xEF0), f), 0);
  EXPECT_EQ(f.id, 0x7u);
  EXPECT_EQ(f.dlc, 8);
  EXPECT_TRUE(f.isData());
  const std::array<std::uint8_t, 8> expected = {0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0xDE, 0xF0};
  EXPECT_EQ(f.data, expected);
}

TEST(MitCodec, ReplyBytesFollowTheProtocolLayout) {
  const MitLimits l;
  const MitState s{mitDequantize(0xABCD, l.p_min, l.p_max, 16),
                   mitDequantize(0x123, l.v_min, l.v_max, 12),
                   mitDequantize(0x456, l.t_min, l.t_max, 12)};
  CanFrame f;
  EXPECT_EQ(encodeReply(l, 0x0, 0x05, s, f), 0);
  EXPECT_EQ(f.id, 0x0u);
  EXPECT_EQ(f.dlc, 6);
  const std::array<std::uint8_t, 6> expected = {0x05, 0xAB, 0xCD, 0x12, 0x34, 0x56};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(f.data[i], expected[i]) << "byte " << i;
  MitReply r;
  ASSERT_EQ(decodeReply(l, f, r), MitDecodeStatus::Ok);
  EXPECT_EQ(r.motor_id, 5);
  EXPECT_NEAR(r.state.p, s.p, kTiny);
  EXPECT_NEAR(r.state.v, s.v, kTiny);
  EXPECT_NEAR(r.state.t, s.t, kTiny);
}

TEST(MitCodec, RangeEndsMapToFirstAndLastCode) {
  const MitLimits l;
  EXPECT_EQ(mitQuantize(l.p_min, l.p_min, l.p_max, 16), 0u);
  EXPECT_EQ(mitQuantize(l.p_max, l.p_min, l.p_max, 16), 0xFFFFu);
  EXPECT_EQ(mitQuantize(l.t_max, l.t_min, l.t_max, 12), 0xFFFu);
  EXPECT_DOUBLE_EQ(mitDequantize(0, l.v_min, l.v_max, 12), l.v_min);
  EXPECT_DOUBLE_EQ(mitDequantize(0xFFF, l.v_min, l.v_max, 12), l.v_max);
}

TEST(MitCodec, StepsOfTheDefaultRanges) {
  const MitSteps s = mitSteps(MitLimits{});
  EXPECT_NEAR(s.p, 25.0 / 65535.0, kTiny);
  EXPECT_NEAR(s.v, 90.0 / 4095.0, kTiny);
  EXPECT_NEAR(s.kp, 500.0 / 4095.0, kTiny);
  EXPECT_NEAR(s.kd, 5.0 / 4095.0, kTiny);
  EXPECT_NEAR(s.t, 96.0 / 4095.0, kTiny);
}

// Every field swept over its whole range (denser than the codes), the others varied too.
TEST(MitCodec, CommandRoundTripWithinHalfAStepOverTheWholeRange) {
  for (const MitLimits& l :
       {MitLimits{}, MitLimits{-3.0, 1.0, -10.0, 30.0, 1.0, 50.0, 0.5, 2.0, -5.0, 20.0}}) {
    const MitSteps st = mitSteps(l);
    const int n = 200003;  // not a multiple of any code count
    double worst[5] = {0, 0, 0, 0, 0};
    for (int i = 0; i <= n; ++i) {
      const double a = static_cast<double>(i) / n;
      const double b = std::fmod(a * 7.31, 1.0), c = std::fmod(a * 3.17, 1.0);
      const double d = std::fmod(a * 5.77, 1.0), e = std::fmod(a * 11.3, 1.0);
      const MitCommand in{l.p_min + a * (l.p_max - l.p_min), l.v_min + b * (l.v_max - l.v_min),
                          l.kp_min + c * (l.kp_max - l.kp_min),
                          l.kd_min + d * (l.kd_max - l.kd_min), l.t_min + e * (l.t_max - l.t_min)};
      CanFrame f;
      ASSERT_EQ(encodeCommand(l, 1, in, f), 0) << i;
      MitCommand out;
      ASSERT_EQ(decodeCommand(l, f, out), MitDecodeStatus::Ok) << i;
      worst[0] = std::max(worst[0], std::abs(out.p_des - in.p_des));
      worst[1] = std::max(worst[1], std::abs(out.v_des - in.v_des));
      worst[2] = std::max(worst[2], std::abs(out.kp - in.kp));
      worst[3] = std::max(worst[3], std::abs(out.kd - in.kd));
      worst[4] = std::max(worst[4], std::abs(out.t_ff - in.t_ff));
    }
    EXPECT_LE(worst[0], 0.5 * st.p + kTiny);
    EXPECT_LE(worst[1], 0.5 * st.v + kTiny);
    EXPECT_LE(worst[2], 0.5 * st.kp + kTiny);
    EXPECT_LE(worst[3], 0.5 * st.kd + kTiny);
    EXPECT_LE(worst[4], 0.5 * st.t + kTiny);
    // The bound is reached (the test would notice truncation instead of rounding).
    EXPECT_GT(worst[1], 0.45 * st.v);
  }
}

TEST(MitCodec, ReplyRoundTripWithinHalfAStepOverTheWholeRange) {
  const MitLimits l;
  const MitSteps st = mitSteps(l);
  const int n = 100003;
  for (int i = 0; i <= n; ++i) {
    const double a = static_cast<double>(i) / n;
    const MitState in{l.p_min + a * (l.p_max - l.p_min),
                      l.v_min + std::fmod(a * 7.31, 1.0) * (l.v_max - l.v_min),
                      l.t_min + std::fmod(a * 3.7, 1.0) * (l.t_max - l.t_min)};
    CanFrame f;
    ASSERT_EQ(encodeReply(l, 0, static_cast<std::uint8_t>(i % 255 + 1), in, f), 0);
    MitReply out;
    ASSERT_EQ(decodeReply(l, f, out), MitDecodeStatus::Ok);
    ASSERT_EQ(out.motor_id, i % 255 + 1);
    ASSERT_LE(std::abs(out.state.p - in.p), 0.5 * st.p + kTiny) << i;
    ASSERT_LE(std::abs(out.state.v - in.v), 0.5 * st.v + kTiny) << i;
    ASSERT_LE(std::abs(out.state.t - in.t), 0.5 * st.t + kTiny) << i;
  }
}

TEST(MitCodec, EveryCodeSurvivesDecodeAndEncode) {
  const MitLimits l;
  for (std::uint32_t code = 0; code <= 0xFFFF; ++code) {
    const MitCommand c = atCodes(l, code, code & 0xFFF, (code * 7) & 0xFFF, (code * 13) & 0xFFF,
                                 (code * 31) & 0xFFF);
    CanFrame f;
    encodeCommand(l, 1, c, f);
    ASSERT_EQ((std::uint32_t{f.data[0]} << 8) | f.data[1], code);
    ASSERT_EQ((std::uint32_t{f.data[6] & 0xFu} << 8) | f.data[7], (code * 31) & 0xFFF);
  }
}

TEST(MitCodec, OutOfRangeValuesAreClampedAndReported) {
  const MitLimits l;
  CanFrame f;
  MitCommand out;
  EXPECT_EQ(encodeCommand(l, 1, {20.0, 0, 0, 0, 0}, f), kClampPosition);
  decodeCommand(l, f, out);
  EXPECT_DOUBLE_EQ(out.p_des, l.p_max);
  EXPECT_EQ(encodeCommand(l, 1, {0, -50.0, 0, 0, 0}, f), kClampVelocity);
  decodeCommand(l, f, out);
  EXPECT_DOUBLE_EQ(out.v_des, l.v_min);
  EXPECT_EQ(encodeCommand(l, 1, {0, 0, -1.0, 8.0, -100.0}, f), kClampKp | kClampKd | kClampTorque);
  decodeCommand(l, f, out);
  EXPECT_DOUBLE_EQ(out.kp, l.kp_min);
  EXPECT_DOUBLE_EQ(out.kd, l.kd_max);
  EXPECT_DOUBLE_EQ(out.t_ff, l.t_min);
  // Exactly at the ends is not clamping.
  EXPECT_EQ(encodeCommand(l, 1, {l.p_min, l.v_max, l.kp_max, l.kd_min, l.t_max}, f), 0);
  // Replies clamp too.
  MitReply r;
  EXPECT_EQ(encodeReply(l, 0, 1, {-13.0, 0.0, 60.0}, f), kClampPosition | kClampTorque);
  decodeReply(l, f, r);
  EXPECT_DOUBLE_EQ(r.state.p, l.p_min);
  EXPECT_DOUBLE_EQ(r.state.t, l.t_max);
}

TEST(MitCodec, NonFiniteValuesBecomeHarmless) {
  const MitLimits l;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  CanFrame f;
  MitCommand out;
  const std::uint8_t bits = encodeCommand(l, 1, {nan, inf, nan, -inf, nan}, f);
  EXPECT_EQ(bits,
            kClampNonFinite | kClampPosition | kClampVelocity | kClampKp | kClampKd | kClampTorque);
  ASSERT_EQ(decodeCommand(l, f, out), MitDecodeStatus::Ok);
  const MitSteps st = mitSteps(l);
  EXPECT_NEAR(out.p_des, 0.0, 0.5 * st.p + 1e-9);
  EXPECT_NEAR(out.v_des, 0.0, 0.5 * st.v + 1e-9);
  EXPECT_DOUBLE_EQ(out.kp, 0.0);
  EXPECT_DOUBLE_EQ(out.kd, 0.0);
  EXPECT_NEAR(out.t_ff, 0.0, 0.5 * st.t + 1e-9);
}

TEST(MitCodec, SpecialFrames) {
  const std::array<std::pair<MitSpecial, std::uint8_t>, 3> cases = {
      {{MitSpecial::EnterMotorMode, 0xFC},
       {MitSpecial::ExitMotorMode, 0xFD},
       {MitSpecial::ZeroPosition, 0xFE}}};
  for (const auto& [special, last] : cases) {
    const CanFrame f = makeSpecialFrame(0x23, special);
    EXPECT_EQ(f.id, 0x23u);
    EXPECT_EQ(f.dlc, 8);
    for (int i = 0; i < 7; ++i) EXPECT_EQ(f.data[i], 0xFF);
    EXPECT_EQ(f.data[7], last);
    ASSERT_TRUE(parseSpecialFrame(f).has_value());
    EXPECT_EQ(*parseSpecialFrame(f), special);
    MitCommand c;
    EXPECT_EQ(decodeCommand(MitLimits{}, f, c), MitDecodeStatus::SpecialFrame);
  }
  CanFrame f = makeSpecialFrame(1, MitSpecial::ZeroPosition);
  f.data[7] = 0xFB;
  EXPECT_FALSE(parseSpecialFrame(f).has_value());
  f = makeSpecialFrame(1, MitSpecial::ZeroPosition);
  f.dlc = 7;
  EXPECT_FALSE(parseSpecialFrame(f).has_value());
  f = makeSpecialFrame(1, MitSpecial::ZeroPosition);
  f.data[3] = 0xFE;
  EXPECT_FALSE(parseSpecialFrame(f).has_value());
}

TEST(MitCodec, AnOrdinaryCommandNeverReadsAsASpecialFrame) {
  const MitLimits l;
  for (std::uint32_t t = 0xFFB; t <= 0xFFF; ++t) {
    CanFrame f;
    encodeCommand(l, 1, atCodes(l, 0xFFFF, 0xFFF, 0xFFF, 0xFFF, t), f);
    EXPECT_FALSE(parseSpecialFrame(f).has_value()) << t;
    MitCommand out;
    EXPECT_EQ(decodeCommand(l, f, out), MitDecodeStatus::Ok);
    EXPECT_NEAR(out.p_des, l.p_max, mitSteps(l).p + kTiny);
  }
}

TEST(MitCodec, MalformedFramesAreRejected) {
  const MitLimits l;
  CanFrame f;
  encodeCommand(l, 1, {}, f);
  MitCommand c;
  MitReply r;
  for (std::uint8_t dlc : {0, 1, 6, 7}) {
    f.dlc = dlc;
    EXPECT_EQ(decodeCommand(l, f, c), MitDecodeStatus::WrongLength) << int{dlc};
  }
  encodeReply(l, 0, 1, {}, f);
  for (std::uint8_t dlc : {0, 5, 7, 8}) {
    f.dlc = dlc;
    EXPECT_EQ(decodeReply(l, f, r), MitDecodeStatus::WrongLength) << int{dlc};
  }
  const CanFrame err = makeErrorFrame(0x40);
  EXPECT_EQ(decodeReply(l, err, r), MitDecodeStatus::ErrorFrame);
  EXPECT_EQ(decodeCommand(l, err, c), MitDecodeStatus::ErrorFrame);
  encodeReply(l, 0, 1, {}, f);
  f.flags = CanFrame::kFlagRtr;
  EXPECT_EQ(decodeReply(l, f, r), MitDecodeStatus::RemoteFrame);
  EXPECT_STREQ(toString(MitDecodeStatus::WrongLength), "wrong length");
}

TEST(MitLimits, ValidateNamesTheField) {
  EXPECT_NO_THROW(MitLimits{}.validate());
  const auto message = [](const MitLimits& l) {
    return test::errorOf<std::invalid_argument>([&] { return l.validate(); });
  };
  MitLimits l;
  l.p_min = 12.5;
  EXPECT_THAT(message(l), test::HasSubstr("p_min")) << message(l);
  l = {};
  l.kd_min = -1.0;
  EXPECT_THAT(message(l), test::HasSubstr("kd_min must be >= 0")) << message(l);
  l = {};
  l.t_max = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(message(l), test::HasSubstr("t_min/t_max must be finite")) << message(l);
}

// CAN settings ---------------------------------------------------------------------------------

std::string configText() {
  const std::filesystem::path file = std::filesystem::path(WJ_CONFIG_DIR) / "can.yaml";
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

model::RobotModel loadRobot() {
  const std::filesystem::path dir = WJ_MODELS_DIR;
  return model::RobotModel::load(dir / "wheeljump.urdf", dir / "actuators.yaml");
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) text.replace(pos, from.size(), to);
  return text;
}

std::string parseError(const std::string& text) {
  return test::errorOf([&] { return parseCanRobotSettings(text, "can.yaml"); });
}

TEST(CanSettings, ProjectConfigLoadsAndFitsTheRobot) {
  const CanRobotSettings s =
      loadCanRobotSettings(std::filesystem::path(WJ_CONFIG_DIR) / "can.yaml");
  EXPECT_NO_THROW(s.validateAgainst(loadRobot()));
  EXPECT_EQ(s.interfaces[2], "can2");
  EXPECT_EQ(s.reply_timeout_periods, 3);
  EXPECT_EQ(s.motors[model::jointIndex(model::Leg::RH, model::JointKind::KFE)].can_id, 3u);
  EXPECT_DOUBLE_EQ(s.limitsOf(model::jointIndex(model::Leg::LF, model::JointKind::Wheel)).t_max,
                   48.0);
  // The file and the defaults in code agree.
  const CanRobotSettings d;
  for (int k = 0; k < model::kJointsPerLeg; ++k) {
    EXPECT_DOUBLE_EQ(s.limits[k].p_max, d.limits[k].p_max);
    EXPECT_DOUBLE_EQ(s.limits[k].kp_max, d.limits[k].kp_max);
  }
}

TEST(CanSettings, UnknownMissingAndBadKeysAreRefused) {
  const std::string text = configText();
  EXPECT_THAT(parseError(replaced(text, "host_can_id: 0", "host_can_id: 0\nhost_id: 1")),
              test::HasSubstr("unknown key 'host_id'"));
  EXPECT_THAT(parseError(replaced(text, "    kd_max: 5.0", "    kd_maxx: 5.0")),
              test::HasSubstr("limits.HAA: unknown key 'kd_maxx'"));
  EXPECT_THAT(
      parseError(replaced(text, "  RH_WHEEL: {can_id: 4, direction: 1, offset_rad: 0.0}", "")),
      test::HasSubstr("missing key 'RH_WHEEL'"));
  EXPECT_THAT(parseError(replaced(text, "RF_KFE:   {can_id: 3", "RF_KFE:   {can_id: 2")),
              test::HasSubstr("also used by RF_HFE"));
  EXPECT_THAT(parseError(replaced(text, "LH_HFE:   {can_id: 2, direction: 1",
                                  "LH_HFE:   {can_id: 2, direction: 0.5")),
              test::HasSubstr("direction must be +1 or -1"));
  EXPECT_THAT(parseError(replaced(text, "reply_timeout_periods: 3", "reply_timeout_periods: x")),
              test::HasSubstr("reply_timeout_periods: has the wrong type"));
}

TEST(CanSettings, RangesMustCoverTheDrives) {
  const model::RobotModel m = loadRobot();
  CanRobotSettings s;
  s.limits[1].t_max = 30.0;
  EXPECT_THAT(test::errorOf<std::invalid_argument>([&] { return s.validateAgainst(m); }),
              test::HasSubstr("must cover the peak torque"));
  s = {};
  s.limits[2].v_min = -30.0;
  EXPECT_THROW(s.validateAgainst(m), std::invalid_argument);
  s = {};
  s.motors[2].offset_rad = 11.0;  // KFE limits -2.7 .. -0.5 map to -13.7 .. -11.5
  EXPECT_THROW(s.validateAgainst(m), std::invalid_argument);
  s = {};
  s.motors[3].offset_rad = 100.0;  // a wheel wraps: no position check
  EXPECT_NO_THROW(s.validateAgainst(m));
}

}  // namespace
}  // namespace wj::can
