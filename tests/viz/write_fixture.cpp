// Writes the pictures of the synthetic vertical jump (strip, GIF, page) into the folder given
// as the only argument: the browser test's second page, beside sim_jump's forward jump.
#include <iostream>

#include "synthetic_run.h"
#include "viz/replay_page.h"
#include "viz/side_view.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: viz_write_fixture OUT_DIR\n";
    return 2;
  }
  try {
    const std::filesystem::path dir = argv[1];
    std::filesystem::create_directories(dir);
    const auto robot = wj::model::RobotModel::loadDefault();
    wj::viz::testing::SyntheticJump s;
    s.vx = 0.0;
    s.wall = false;
    const wj::viz::Recording rec = wj::viz::testing::makeSyntheticJump(robot, s);
    wj::viz::writeSnapshotStrip(robot, rec, dir / "vertical.png");
    wj::viz::writeAnimationGif(robot, rec, dir / "vertical.gif");
    wj::viz::writeReplayPage(robot, rec, dir / "vertical.html");
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "viz_write_fixture: " << e.what() << "\n";
    return 1;
  }
}
