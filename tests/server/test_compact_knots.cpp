// The compact knots of the contract (planner_client/compact_knots.h): what a plan's columns
// become, the exact way back, and the refusal of malformed messages.
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

TEST(CompactKnots, SendsEachDistinctColumnOnceAndComesBackBitForBit) {
  const v1::TrajectoryKnots knots = symmetricKnots(52, 7);
  v1::CompactKnots compact;
  compactKnots(knots, &compact);
  const int n = knots.t_s_size();
  // Positions: the 4 HAA constant, RF and RH HFE/KFE refer to LF and LH; 2 x 2 + 4 wheels sent.
  EXPECT_EQ(compact.positions_rad().columns_size(), 8 * n);
  for (const int haa : {0, 4, 8, 12}) EXPECT_EQ(compact.positions_rad().source(haa), 0);
  EXPECT_EQ(compact.positions_rad().constant(4), -0.0081f);
  EXPECT_EQ(compact.positions_rad().source(5), compact.positions_rad().source(1));
  // Velocities: HAA zero, the right legs' columns all refer to the left ones'.
  EXPECT_EQ(compact.velocities_rad_s().columns_size(), 6 * n);
  // Torques: the right HAA is the negated left HAA.
  EXPECT_EQ(compact.torques_nm().columns_size(), 8 * n);
  EXPECT_EQ(compact.torques_nm().source(4), -compact.torques_nm().source(0));
  // 22 of the 48 joint columns: about 0.55 of the knots' bytes.
  EXPECT_LT(compact.ByteSizeLong() * 10, knots.ByteSizeLong() * 6);

  v1::TrajectoryKnots back;
  ASSERT_EQ(expandKnots(compact, &back), "");
  EXPECT_EQ(back.SerializeAsString(), knots.SerializeAsString());
}

TEST(CompactKnots, ZerosKeepTheirSign) {
  v1::TrajectoryKnots knots = symmetricKnots(4, 1);
  // LF HAA torque: 0, -0, 1, 2; RF HAA torque its negation: -0, 0, -1, -2.
  const float lf[] = {0.0f, -0.0f, 1.0f, 2.0f};
  for (int i = 0; i < 4; ++i) {
    knots.set_torques_nm(16 * i + 0, lf[i]);
    knots.set_torques_nm(16 * i + 4, -lf[i]);
  }
  v1::CompactKnots compact;
  compactKnots(knots, &compact);
  EXPECT_EQ(compact.torques_nm().source(4), -compact.torques_nm().source(0));
  v1::TrajectoryKnots back;
  ASSERT_EQ(expandKnots(compact, &back), "");
  EXPECT_EQ(back.SerializeAsString(), knots.SerializeAsString());
  EXPECT_TRUE(std::signbit(back.torques_nm(4)));
  EXPECT_FALSE(std::signbit(back.torques_nm(20)));
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
  EXPECT_EQ(problem([](v1::CompactKnots&) {}), "");
  EXPECT_NE(problem([](v1::CompactKnots& c) {
              c.add_t_s(0.2);
            }).find("compact_knots.centroidal must hold 36 values (6 x 6 knots), got 30"),
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
              c.mutable_velocities_rad_s()->mutable_columns()->RemoveLast();
            }).find("compact_knots.velocities_rad_s.columns must hold K x C values for K = 5"),
            std::string::npos);
  // More columns than joints is no compaction (and would overrun the expansion's row).
  EXPECT_NE(
      problem([](v1::CompactKnots& c) {
        c.mutable_torques_nm()->mutable_columns()->Resize(5 * 17, 0.5f);
      }).find("compact_knots.torques_nm.columns must hold at most 16 columns per knot, got 17"),
      std::string::npos);
}

}  // namespace
}  // namespace wj::client
