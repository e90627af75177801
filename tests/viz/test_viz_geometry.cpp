// The drawn robot: the URDF's collision shapes posed by forward kinematics must sit where the
// leg's closed-form planar kinematics put them; the side outlines must be the shapes' true
// silhouettes; the strip and the GIF must pick the instants they promise.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "error_of.h"
#include "synthetic_run.h"
#include "viz/geometry.h"
#include "viz/side_view.h"

namespace wj::viz {
namespace {

using model::JointKind;
using model::Leg;

const model::RobotModel& robot() {
  static const model::RobotModel m = model::RobotModel::loadDefault();
  return m;
}

// Wheel centre in the world from the leg's planar closed form (no calcLinkPoses): base pitched
// nose-up by `pitch`, HFE angle a and KFE angle b swing the leg about +y.
Eigen::Vector3d closedFormWheel(const Frame& f, Leg leg, double a, double b, double pitch) {
  const model::LegGeometry& g = robot().legGeometry(leg);
  const auto down = [](double angle, double length) {  // (0, 0, -L) rotated about +y
    return Eigen::Vector3d(-length * std::sin(angle), 0.0, -length * std::cos(angle));
  };
  const Eigen::Vector3d p_B = g.p_BH + g.p_HT + Eigen::Vector3d(0, g.wheel_lateral_offset, 0) +
                              down(a, g.thigh_length) + down(a + b, g.shank_length);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return f.p_WB + R * p_B;
}

TEST(VizGeometry, UrdfShapesAreRead) {
  const auto& links = robot().links();
  ASSERT_EQ(links[0].shapes.size(), 1u);
  EXPECT_EQ(links[0].shapes[0].kind, model::LinkShape::Kind::Box);
  EXPECT_TRUE(links[0].shapes[0].size.isApprox(robot().baseBoxSize()));
  for (const Leg leg : model::kLegs) {
    const auto& wheel = links[robot().joint(leg, JointKind::Wheel).child_link].shapes;
    ASSERT_EQ(wheel.size(), 1u);
    EXPECT_EQ(wheel[0].kind, model::LinkShape::Kind::Cylinder);
    EXPECT_DOUBLE_EQ(wheel[0].size.x(), robot().wheelRadius());
    EXPECT_DOUBLE_EQ(wheel[0].size.z(), robot().wheelWidth());
    EXPECT_EQ(links[robot().joint(leg, JointKind::KFE).child_link].shapes.size(), 1u);  // shank
  }
}

TEST(VizGeometry, WheelCentresMatchTheLegsClosedForm) {
  for (const double pitch : {0.0, 0.3, -0.2})
    for (const auto& [a, b] : {std::pair{0.0, -0.5}, {0.8, -1.6}, {-0.4, -2.2}}) {
      Eigen::VectorXd q = Eigen::VectorXd::Zero(model::kNumJoints);
      for (const Leg leg : model::kLegs) {
        q[model::jointIndex(leg, JointKind::HFE)] = a;
        q[model::jointIndex(leg, JointKind::KFE)] = b;
        q[model::jointIndex(leg, JointKind::Wheel)] = 1.234;  // turning must not move the axle
      }
      const Frame f = makePlanarFrame(robot(), 0.0, 1.0, 0.45, pitch, q);
      const auto centres = calcWheelCentersW(robot(), f);
      for (const Leg leg : model::kLegs)
        EXPECT_LT((centres[static_cast<int>(leg)] - closedFormWheel(f, leg, a, b, pitch)).norm(),
                  1e-12)
            << model::toString(leg) << " pitch " << pitch << " a " << a << " b " << b;
    }
}

TEST(VizGeometry, PlanarFramePutsTheCompositeComWhereAsked) {
  const Eigen::VectorXd q = testing::syntheticPosture();
  const Frame f = makePlanarFrame(robot(), 0.5, 2.0, 0.4, 0.25, q);
  const Eigen::Vector3d p_BC = robot().calcCompositeInertia(q).com;
  EXPECT_LT((basePose(f) * p_BC - Eigen::Vector3d(2.0, 0.0, 0.4)).norm(), 1e-12);
  EXPECT_LT((f.p_WC - Eigen::Vector3d(2.0, 0.0, 0.4)).norm(), 1e-12);
}

TEST(VizGeometry, SideOutlinesAreTheShapesSilhouettes) {
  const double pitch = 0.3;
  const Frame f =
      makePlanarFrame(robot(), 0.0, 0.0, 0.5, pitch, Eigen::VectorXd::Zero(model::kNumJoints));
  const auto shapes = calcPosedShapes(robot(), f);
  const auto base =
      std::find_if(shapes.begin(), shapes.end(), [](const PosedShape& s) { return s.link == 0; });
  ASSERT_NE(base, shapes.end());
  // The base box seen from the side: the rectangle length x height, turned by the pitch.
  const auto outline = sideOutline(*base);
  ASSERT_EQ(outline.size(), 4u);
  const Eigen::Vector3d& d = robot().baseBoxSize();
  const Eigen::Vector2d c(f.p_WB.x(), f.p_WB.z());
  for (const double sx : {-0.5, 0.5})
    for (const double sz : {-0.5, 0.5}) {
      // nose-up: +x corners go up
      const Eigen::Vector2d corner =
          c + Eigen::Vector2d(sx * d.x() * std::cos(pitch) - sz * d.z() * std::sin(pitch),
                              sx * d.x() * std::sin(pitch) + sz * d.z() * std::cos(pitch));
      double nearest = 1e9;
      for (const auto& p : outline) nearest = std::min(nearest, (p - corner).norm());
      EXPECT_LT(nearest, 1e-12);
    }
  // A wheel (axle along y) is a circle of the wheel's radius about its centre.
  const auto centres = calcWheelCentersW(robot(), f);
  for (const PosedShape& s : shapes) {
    if (s.shape.kind != model::LinkShape::Kind::Cylinder) continue;
    const auto circle = sideOutline(s, 48);
    EXPECT_GE(circle.size(), 48u);  // both rims project onto the circle: a few near-duplicates
    const Eigen::Vector3d& w = s.X_WS.translation();
    bool is_centre = false;
    for (const auto& cw : centres) is_centre = is_centre || (cw - w).norm() < 1e-12;
    EXPECT_TRUE(is_centre);
    for (const auto& p : circle)
      EXPECT_NEAR((p - Eigen::Vector2d(w.x(), w.z())).norm(), robot().wheelRadius(), 1e-9);
  }
}

TEST(VizGeometry, ConvexHullDropsInnerAndRepeatedPoints) {
  const std::vector<Eigen::Vector2d> pts = {{0, 0},     {1, 0}, {1, 1},  {0, 1},
                                            {0.5, 0.5}, {1, 1}, {0.5, 0}};
  const auto h = convexHull(pts);
  ASSERT_EQ(h.size(), 4u);
  double area = 0.0;  // counter-clockwise: positive shoelace area
  for (std::size_t i = 0; i < h.size(); ++i)
    area += h[i].x() * h[(i + 1) % h.size()].y() - h[(i + 1) % h.size()].x() * h[i].y();
  EXPECT_NEAR(0.5 * area, 1.0, 1e-12);
}

TEST(VizRecording, ValidateNamesTheBadField) {
  Recording rec = testing::makeSyntheticJump(robot(), {});
  EXPECT_NO_THROW(rec.validate());
  rec.frames[3].t = rec.frames[2].t;
  EXPECT_THAT(test::errorOf<std::invalid_argument>([&] { return rec.validate(); }),
              test::HasSubstr("frames[3].t"));
  EXPECT_THROW(Recording{}.validate(), std::invalid_argument);
}

TEST(VizStrip, SnapshotsAreEvenlySpacedFromTakeoffToLanding) {
  const Recording rec = testing::makeSyntheticJump(robot(), {});
  StripSettings s;
  s.snapshots = 6;
  const StripLayout layout = planStrip(robot(), rec, s);
  ASSERT_EQ(layout.frames.size(), 6u);
  const double t0 = rec.jump_start_t, t1 = rec.touchdown_t + s.landing_tail_s;
  for (int k = 0; k < 6; ++k)
    EXPECT_NEAR(rec.frames[layout.frames[k]].t, t0 + (t1 - t0) * k / 5.0, 0.0021);
  // The apex: highest CoM, at vz / g after lift-off.
  EXPECT_NEAR(rec.frames[layout.apex].t, 0.4 + 2.2 / 9.81, 0.0021);
  EXPECT_EQ(layout.spread_m, 0.0);  // the forward jump travels: true positions
  testing::SyntheticJump vertical;
  vertical.vx = 0.0;
  const StripLayout in_place = planStrip(robot(), testing::makeSyntheticJump(robot(), vertical), s);
  EXPECT_GT(in_place.spread_m, robot().baseBoxSize().x());  // spread like a film strip
}

TEST(VizGif, FrameCountIsBoundedAndTheJumpIsKept) {
  testing::SyntheticJump long_run;
  long_run.t_end = 30.0;
  long_run.t_lift = 20.0;
  long_run.dt = 0.01;
  const Recording rec = testing::makeSyntheticJump(robot(), long_run);
  GifSettings s;
  s.max_frames = 100;
  const GifLayout g = planGif(rec, s);
  EXPECT_EQ(static_cast<int>(g.frames.size()), 100);
  EXPECT_DOUBLE_EQ(g.slowdown, 1.0);  // too long for slow motion: real time
  EXPECT_LE(g.t_begin, rec.jump_start_t);
  EXPECT_GE(g.t_end, rec.touchdown_t);
  EXPECT_GE(g.fps, 7.5);  // 30 s do not fit: the fewest frames a second, then a window
  EXPECT_DOUBLE_EQ(g.fps, 100.0 / g.delay_cs);
  for (std::size_t k = 1; k < g.frames.size(); ++k)  // real time at the rate used
    EXPECT_NEAR(rec.frames[g.frames[k]].t - rec.frames[g.frames[k - 1]].t, 1.0 / g.fps, 0.011);
  // 12 s fit at a lower frame rate: the whole run, in real time.
  long_run.t_end = 12.0;
  long_run.t_lift = 6.0;
  const GifLayout whole = planGif(testing::makeSyntheticJump(robot(), long_run), s);
  EXPECT_DOUBLE_EQ(whole.t_begin, 0.0);
  EXPECT_NEAR(whole.t_end, 12.0, 1e-9);
  EXPECT_LE(static_cast<int>(whole.frames.size()), s.max_frames);
  EXPECT_NEAR((static_cast<double>(whole.frames.size()) - 1.0) / whole.fps, 12.0, 1.0 / whole.fps);
  // A short run: slowed as asked.
  const GifLayout short_run = planGif(testing::makeSyntheticJump(robot(), {}), s);
  EXPECT_DOUBLE_EQ(short_run.slowdown, s.slowdown);
  EXPECT_EQ(static_cast<int>(short_run.frames.size()),
            static_cast<int>(1.5 * s.fps * s.slowdown) + 1);
}

TEST(VizSettings, OutOfRangeIsRefusedByName) {
  StripSettings s;
  s.snapshots = 1;
  EXPECT_THAT(test::errorOf<std::invalid_argument>([&] { return s.validate(); }),
              test::HasSubstr("snapshots"));
  GifSettings g;
  g.fps = 0.5;
  EXPECT_THROW(g.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace wj::viz
