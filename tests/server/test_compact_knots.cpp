// The compact knots of the contract (planner_client/compact_knots.h): what a plan's columns
// become, the error of the quantization, and the refusal of malformed messages.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "planner_client/compact_knots.h"

namespace wj::client {
namespace {

namespace v1 = wheeljump::planner::v1;

// Knots shaped like a symmetric jump's: per leg HAA constant, HFE and KFE equal on the left and
// right, the wheel positions of each side their own; velocities zero at the HAA; HAA torques of
// the right legs the negation of the left ones'.
v1::TrajectoryKnots symmetricKnots(int n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-30.0f, 30.0f);
  v1::TrajectoryKnots k;
  for (int i = 0; i < n; ++i) {
    k.add_t_s(0.02 * i);
    for (int c = 0; c < 6; ++c) k.add_centroidal(u(rng) / 30.0f);
    float left[3][4];  // positions, velocities, torques of the front (row) legs
    for (auto& a : left)
      for (float& v : a) v = u(rng);
    for (int leg = 0; leg < 4; ++leg) {  // LF, RF, LH, RH
      const bool right = leg % 2 == 1;
      for (int j = 0; j < 4; ++j) {
        const float p = j == 0            ? (right ? -0.0081f : -0.0053f)
                        : j == 3 && right ? u(rng)
                                          : left[0][j];
        k.add_positions_rad(p + (leg >= 2 ? 1.0f : 0.0f) * (j == 0 ? 0.0f : 0.5f));
        k.add_velocities_rad_s(j == 0 ? 0.0f : left[1][j] + (leg >= 2 ? 2.0f : 0.0f));
        k.add_torques_nm((right && j == 0 ? -1.0f : 1.0f) * left[2][j] * (leg >= 2 ? 0.5f : 1.0f));
      }
    }
  }
  return k;
}

// Largest |a - b| over a column, relative to the column's range in a (0 for a constant one).
double errorOverRange(const google::protobuf::RepeatedField<float>& a,
                      const google::protobuf::RepeatedField<float>& b, int width, int column) {
  float lo = 1e30f, hi = -1e30f;
  double err = 0.0;
  for (int i = column; i < a.size(); i += width) {
    lo = std::min(lo, a[i]);
    hi = std::max(hi, a[i]);
    err = std::max(err, std::abs(static_cast<double>(a[i]) - static_cast<double>(b[i])));
  }
  return hi > lo ? err / (static_cast<double>(hi) - static_cast<double>(lo)) : err;
}

TEST(CompactKnots, SendsEachDistinctColumnOnceAndComesBackWithinHalfAStep) {
  const v1::TrajectoryKnots knots = symmetricKnots(52, 7);
  v1::CompactKnots compact;
  compactKnots(knots, &compact);
  // Positions: the 4 HAA constant, RF and RH HFE/KFE refer to LF and LH; 2 x 2 + 4 wheels sent.
  EXPECT_EQ(compact.positions_rad().columns().offset_size(), 8);
  for (const int haa : {0, 4, 8, 12}) EXPECT_EQ(compact.positions_rad().source(haa), 0);
  EXPECT_EQ(compact.positions_rad().constant(4), -0.0081f);
  EXPECT_EQ(compact.positions_rad().source(5), compact.positions_rad().source(1));
  // Velocities: HAA zero, the right legs' columns all refer to the left ones'.
  EXPECT_EQ(compact.velocities_rad_s().columns().offset_size(), 6);
  // Torques: the right HAA is the negated left HAA.
  EXPECT_EQ(compact.torques_nm().columns().offset_size(), 8);
  EXPECT_EQ(compact.torques_nm().source(4), -compact.torques_nm().source(0));
  // A third of the bytes of the float32 knots, or less.
  EXPECT_LT(compact.ByteSizeLong() * 3, knots.ByteSizeLong());

  v1::TrajectoryKnots back;
  ASSERT_EQ(expandKnots(compact, &back), "");
  ASSERT_EQ(back.t_s_size(), knots.t_s_size());
  for (int i = 0; i < knots.t_s_size(); ++i) EXPECT_EQ(back.t_s(i), knots.t_s(i));
  ASSERT_EQ(back.positions_rad_size(), knots.positions_rad_size());
  ASSERT_EQ(back.centroidal_size(), knots.centroidal_size());
  const double half_step = 0.5 / 65534.0 * (1.0 + 1e-4);  // float32 rounding of offset and step
  for (int c = 0; c < 6; ++c)
    EXPECT_LE(errorOverRange(knots.centroidal(), back.centroidal(), 6, c), half_step) << c;
  for (int j = 0; j < 16; ++j) {
    EXPECT_LE(errorOverRange(knots.positions_rad(), back.positions_rad(), 16, j), half_step) << j;
    EXPECT_LE(errorOverRange(knots.velocities_rad_s(), back.velocities_rad_s(), 16, j), half_step)
        << j;
    EXPECT_LE(errorOverRange(knots.torques_nm(), back.torques_nm(), 16, j), half_step) << j;
  }
  // Columns that were equal (or opposite) still are, bit for bit; constants are exact.
  for (int i = 0; i < knots.t_s_size(); ++i) {
    EXPECT_EQ(back.positions_rad(16 * i + 5), back.positions_rad(16 * i + 1));
    EXPECT_EQ(back.positions_rad(16 * i + 4), -0.0081f);
    EXPECT_EQ(back.velocities_rad_s(16 * i + 8), 0.0f);
    EXPECT_EQ(back.torques_nm(16 * i + 4), -back.torques_nm(16 * i + 0));
  }
}

TEST(CompactKnots, TheExtremesOfAColumnComeBack) {
  v1::TrajectoryKnots knots = symmetricKnots(3, 1);
  // Centroidal x: its two extremes (q = -32767 and 32767) and the middle (q = 0).
  knots.set_centroidal(0, -2.0f);
  knots.set_centroidal(6, 2.0f);
  knots.set_centroidal(12, 0.0f);
  v1::CompactKnots compact;
  compactKnots(knots, &compact);
  v1::TrajectoryKnots back;
  ASSERT_EQ(expandKnots(compact, &back), "");
  EXPECT_NEAR(back.centroidal(0), -2.0f, 1e-6);
  EXPECT_NEAR(back.centroidal(6), 2.0f, 1e-6);
  EXPECT_NEAR(back.centroidal(12), 0.0f, 1e-6);
}

TEST(CompactKnots, NoKnotsIsNoColumns) {
  v1::CompactKnots compact;
  compactKnots(v1::TrajectoryKnots{}, &compact);
  EXPECT_EQ(compact.ByteSizeLong(), 0u);
  v1::TrajectoryKnots back;
  EXPECT_EQ(expandKnots(compact, &back), "");
  EXPECT_EQ(back.ByteSizeLong(), 0u);
}

TEST(CompactKnots, InconsistentKnotsAreRefused) {
  v1::TrajectoryKnots knots = symmetricKnots(4, 2);
  knots.add_torques_nm(1.0f);
  v1::CompactKnots compact;
  EXPECT_THROW(compactKnots(knots, &compact), std::invalid_argument);
}

TEST(CompactKnots, MalformedMessagesNameTheField) {
  v1::CompactKnots good;
  compactKnots(symmetricKnots(5, 3), &good);
  v1::TrajectoryKnots back;
  const auto problem = [&](auto&& spoil) {
    v1::CompactKnots c = good;
    spoil(c);
    return expandKnots(c, &back);
  };
  EXPECT_NE(problem([](v1::CompactKnots& c) { c.add_t_s(0.2); }).find("centroidal.values"),
            std::string::npos);
  EXPECT_NE(problem([](v1::CompactKnots& c) {
              c.mutable_centroidal()->add_offset(0.0f);
            }).find("compact_knots.centroidal.offset and .scale"),
            std::string::npos);
  EXPECT_NE(problem([](v1::CompactKnots& c) {
              c.mutable_centroidal()->set_scale(2, std::nanf(""));
            }).find("compact_knots.centroidal column 2"),
            std::string::npos);
  EXPECT_NE(problem([](v1::CompactKnots& c) {
              c.mutable_positions_rad()->set_source(3, 99);
            }).find("compact_knots.positions_rad.source[3] must be in [-8, 8], got 99"),
            std::string::npos);
  EXPECT_NE(problem([](v1::CompactKnots& c) {
              c.mutable_torques_nm()->add_source(1);
            }).find("compact_knots.torques_nm.source and .constant must have 16 entries"),
            std::string::npos);
  EXPECT_NE(problem([](v1::CompactKnots& c) {
              c.mutable_velocities_rad_s()->set_constant(0, INFINITY);
            }).find("compact_knots.velocities_rad_s.constant[0] must be finite"),
            std::string::npos);
  EXPECT_NE(problem([](v1::CompactKnots& c) {
              c.mutable_velocities_rad_s()->mutable_columns()->mutable_values()->pop_back();
            }).find("compact_knots.velocities_rad_s.columns.values must hold"),
            std::string::npos);
}

}  // namespace
}  // namespace wj::client
