// The files the viewers write: the strip is a whole PNG of the promised width, the GIF a whole
// animation with one image per planned frame, the page carries three.js and the run's data.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "error_of.h"
#include "image_files.h"
#include "synthetic_run.h"
#include "test_robot.h"
#include "viz/geometry.h"
#include "viz/knee_figure.h"
#include "viz/replay_page.h"
#include "viz/side_view.h"

namespace wj::viz {
namespace {

using wj::test::robot;

std::filesystem::path outDir() {
  const auto dir = std::filesystem::temp_directory_path() / "wj_test_viz_files";
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(VizFiles, StripIsAWholePng) {
  const auto png = outDir() / "strip.png";
  StripSettings s;
  s.width_px = 900;
  writeSnapshotStrip(robot(), testing::makeSyntheticJump(robot(), {}), png, s);
  const testing::ImageInfo info = testing::readPngInfo(testing::readBytes(png));
  EXPECT_EQ(info.width, 900);
  EXPECT_GE(info.height, 320);
  EXPECT_LT(std::filesystem::file_size(png), 600u * 1024u);
}

// Two synthetic jumps one after the other, each over its own wall, as the course scenario runs
// them: the second is the first shifted by 1.5 s and by the distance rolled meanwhile.
Recording twoJumps() {
  const testing::SyntheticJump spec;
  Recording rec = testing::makeSyntheticJump(robot(), spec);
  const Recording first = rec;
  const double dt = spec.t_end + spec.dt, dx = spec.vx * dt;
  const auto shifted = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d {
    return p + Eigen::Vector3d(dx, 0.0, 0.0);
  };
  JumpSpan one{first.jump_start_t, first.touchdown_t, first.planned_com};
  JumpSpan two{first.jump_start_t + dt, first.touchdown_t + dt, {}};
  for (Frame f : first.frames) {
    f.t += dt;
    f.p_WB = shifted(f.p_WB);
    f.p_WC = shifted(f.p_WC);
    rec.frames.push_back(std::move(f));
  }
  for (const PathPoint& p : first.planned_com) two.planned_com.push_back({p.t + dt, shifted(p.p)});
  for (const SceneBox& b : first.boxes) rec.boxes.push_back({shifted(b.min), shifted(b.max)});
  rec.jump_start_t = two.start_t;
  rec.touchdown_t = two.touchdown_t;
  rec.planned_com = two.planned_com;
  rec.jumps = {one, two};
  return rec;
}

// The x range of every row in a strip's gnuplot script, in order.
std::vector<std::pair<double, double>> xRanges(const std::filesystem::path& script) {
  std::ifstream in(script);
  std::vector<std::pair<double, double>> ranges;
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("set xrange [", 0) == 0) {
      const auto colon = line.find(':');
      ranges.emplace_back(std::stod(line.substr(12, colon - 12)),
                          std::stod(line.substr(colon + 1)));
    }
  return ranges;
}

TEST(VizFiles, StripOfSeveralJumpsHasARowPerJump) {
  const Recording rec = twoJumps();
  const auto one = outDir() / "strip_one.png", both = outDir() / "strip_two.png";
  Recording last = rec;
  last.jumps.clear();  // the single-jump fields alone: the last jump
  writeSnapshotStrip(robot(), last, one);
  writeSnapshotStrip(robot(), rec, both);
  const int h1 = testing::readPngInfo(testing::readBytes(one)).height;
  const int h2 = testing::readPngInfo(testing::readBytes(both)).height;
  EXPECT_NEAR(h2, 2 * h1, 2);
  // Row k shows jump k's wall and not the other's.
  const auto rows = xRanges(both.string() + ".gp");
  ASSERT_EQ(rows.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const SceneBox& wall = rec.boxes[k];
    const SceneBox& other = rec.boxes[1 - k];
    EXPECT_LT(rows[k].first, wall.min.x());
    EXPECT_GT(rows[k].second, wall.max.x());
    EXPECT_FALSE(rows[k].first < other.min.x() && rows[k].second > other.max.x());
  }
  EXPECT_EQ(xRanges(one.string() + ".gp").size(), 1u);
}

// The synthetic jump with the hind knees turning at 30 rad/s over the last 0.1 s of the push
// (the front ones at rest), a plan of its own and a lift-off at 0.4 s: at -30 rad/s, along their
// -30 Nm (driving), then over the last 10 ms at +30 rad/s, against it (braking).
Recording kneeJump() {
  Recording rec = testing::makeSyntheticJump(robot(), {});
  rec.liftoff_t = 0.4;
  rec.front_liftoff_t = 0.3;
  for (Frame& f : rec.frames)
    if (f.t >= 0.3 && f.t < 0.4)
      for (const model::Leg leg : {model::Leg::LH, model::Leg::RH})
        f.qd[model::jointIndex(leg, model::JointKind::KFE)] = f.t < 0.39 ? -30.0 : 30.0;
  for (int k = 0; k <= 50; ++k) {
    PlannedJoints p;
    p.t = 0.01 * k;
    p.qd[model::jointIndex(model::Leg::LH, model::JointKind::KFE)] = 25.0;
    p.tau[model::jointIndex(model::Leg::LH, model::JointKind::KFE)] = -20.0;
    rec.planned_joints.push_back(p);
  }
  return rec;
}

TEST(VizFiles, KneeFigureWindowAndEnvelope) {
  const Recording rec = kneeJump();
  KneeFigureSettings s;
  s.before_s = 0.05;
  s.after_s = 0.1;
  const KneeFigureLayout l = planKneeFigure(robot(), rec, s);
  // From 0.05 s before the take-off (jump_start_t 0.2 s) to 0.1 s after the lift-off.
  EXPECT_NEAR(l.t_begin, 0.15, 1e-12);
  EXPECT_NEAR(l.t_end, 0.5, 1e-12);
  EXPECT_EQ(l.joints[0], model::jointIndex(model::Leg::LF, model::JointKind::KFE));
  EXPECT_EQ(l.joints[1], model::jointIndex(model::Leg::LH, model::JointKind::KFE));
  EXPECT_EQ(l.frames, 176);  // 0.15 ... 0.5 s every 2 ms
  // Front knees at rest under 30 Nm: inside the envelope's flat part.
  const model::ActuatorEnvelope& a = robot().joints()[l.joints[1]].actuator;
  EXPECT_NEAR(l.max_envelope_ratio[0], 30.0 / a.peak_torque_nm, 1e-12);
  EXPECT_DOUBLE_EQ(l.max_abs_speed[0], 0.0);
  // Hind knees: 30 Nm along 30 rad/s, where the linear fall of the envelope leaves
  // peak (no_load - 30) / (no_load - corner); braking, they have the peak torque.
  const double limit_30 = a.peak_torque_nm * (a.no_load_speed_rad_s - 30.0) /
                          (a.no_load_speed_rad_s - a.corner_speed_rad_s);
  EXPECT_NEAR(l.max_envelope_ratio[1], 30.0 / limit_30, 1e-9);
  EXPECT_DOUBLE_EQ(l.max_abs_speed[1], 30.0);
}

TEST(VizFiles, KneeFigureIsAWholePngWithItsData) {
  const auto png = outDir() / "knees.png";
  KneeFigureSettings s;
  s.width_px = 800;
  s.height_px = 900;
  writeKneeFigure(robot(), kneeJump(), png, s);
  const testing::ImageInfo info = testing::readPngInfo(testing::readBytes(png));
  EXPECT_EQ(info.width, 800);
  EXPECT_EQ(info.height, 900);
  // The planned knee and the envelope polygon are written beside it for gnuplot.
  std::ifstream plan(png.string() + ".plan.dat");
  int rows = 0;
  for (std::string line; std::getline(plan, line);) ++rows;
  EXPECT_EQ(rows, 36);  // 0.15 ... 0.5 s every 10 ms
  std::ifstream env(png.string() + ".envelope.dat");
  int corners = 0;
  for (std::string line; std::getline(env, line);) ++corners;
  EXPECT_EQ(corners, 7);  // six corners, closed
}

TEST(VizFiles, KneeFigureRefusesBadSettingsByName) {
  KneeFigureSettings s;
  s.after_s = -1.0;
  EXPECT_THAT(
      test::errorOf<std::invalid_argument>([&] { return planKneeFigure(robot(), kneeJump(), s); }),
      test::HasSubstr("after_s"));
  Recording empty = kneeJump();
  empty.frames.resize(1);
  EXPECT_THROW(planKneeFigure(robot(), empty, {}), std::invalid_argument);
}

TEST(VizFiles, GifHasOneImagePerPlannedFrame) {
  const auto gif = outDir() / "run.gif";
  const Recording rec = testing::makeSyntheticJump(robot(), {});
  GifSettings s;
  s.fps = 10.0;
  s.width_px = 320;
  s.height_px = 160;
  writeAnimationGif(robot(), rec, gif, s);
  const testing::ImageInfo info = testing::readGifInfo(testing::readBytes(gif));
  EXPECT_EQ(info.width, 320);
  EXPECT_EQ(info.height, 160);
  EXPECT_EQ(info.frames, static_cast<int>(planGif(rec, s).frames.size()));
}

TEST(VizFiles, PageCarriesThreeAndTheData) {
  const auto html = outDir() / "replay.html";
  const Recording rec = testing::makeSyntheticJump(robot(), {});
  writeReplayPage(robot(), rec, html);
  const auto bytes = testing::readBytes(html);
  const std::string page(bytes.begin(), bytes.end());
  EXPECT_EQ(page.find("/*WJ_"), std::string::npos);       // every placeholder filled
  EXPECT_THAT(page, test::HasSubstr("Copyright 2010-"));  // three.js inlined, licence kept
  const std::string open = "<script type=\"application/json\" id=\"wj-data\">";
  const auto a = page.find(open) + open.size();
  const auto data = nlohmann::json::parse(page.substr(a, page.find("</script>", a) - a));
  // 100 frames a second of a 1.5 s run at 500 Hz, plus the instants the page jumps to.
  const auto n = data["frames"]["t"].size();
  EXPECT_GE(n, 151u);
  EXPECT_LE(n, 155u);
  EXPECT_EQ(data["frames"]["q"].size(), n);
  EXPECT_EQ(data["robot"]["links"].size(), robot().links().size());
  const int apex = data["events"]["apex_index"];
  EXPECT_NEAR(data["frames"]["t"][apex].get<double>(), rec.frames[rec.apexFrame()].t, 1e-4);
  const auto centres = calcWheelCentersW(robot(), rec.frames[rec.apexFrame()]);
  for (int leg = 0; leg < model::kNumLegs; ++leg)
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(data["check"]["wheel_centers"][leg][k].get<double>(), centres[leg][k], 1e-4);
}

}  // namespace
}  // namespace wj::viz
