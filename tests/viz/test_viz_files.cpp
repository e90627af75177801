// The files the viewers write: the strip is a whole PNG of the promised width, the GIF a whole
// animation with one image per planned frame, the page carries three.js and the run's data.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "image_files.h"
#include "synthetic_run.h"
#include "viz/geometry.h"
#include "viz/replay_page.h"
#include "viz/side_view.h"

namespace wj::viz {
namespace {

const model::RobotModel& robot() {
  static const model::RobotModel m = model::RobotModel::loadDefault();
  return m;
}

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
  EXPECT_EQ(page.find("/*WJ_"), std::string::npos);            // every placeholder filled
  EXPECT_NE(page.find("Copyright 2010-"), std::string::npos);  // three.js inlined, licence kept
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
