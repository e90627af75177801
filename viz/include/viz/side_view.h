#pragma once
/// @file Side views of a run drawn with gnuplot: the snapshot strip (robot at evenly spaced
/// instants from take-off to landing over the obstacle, like the paper's simulation figures)
/// and the GIF animation of the whole run.

#include <filesystem>
#include <string>

#include "robot_model/robot_model.h"
#include "viz/recording.h"

namespace wj::viz {

/// How the snapshot strip is drawn.
struct StripSettings {
  int snapshots = 7;             ///< evenly spaced instants from take-off to landing, ends included
  double landing_tail_s = 0.25;  ///< the strip goes on this long after touchdown [s]
  int width_px = 1400;           ///< image width; the height follows the scene's aspect
  /// When the robot travels less than this many robot lengths over the whole strip (a jump in
  /// place), the snapshots are spread apart along x like a film strip; the title says so.
  double spread_below = 1.0;
  /// Throws std::invalid_argument naming the field when out of range.
  void validate() const;
};

/// How the GIF animation is drawn.
struct GifSettings {
  double fps = 20.0;      ///< frames per second of the GIF (2 to 50)
  double slowdown = 2.0;  ///< wall time per simulated time (1 = real time, 2 = half speed)
  int max_frames = 120;   ///< bound on the frame count, so that files stay small (planGif)
  double window_m = 3.2;  ///< width of the camera window that follows the robot [m]
  int width_px = 640;     ///< image size
  int height_px = 300;
  /// Throws std::invalid_argument naming the field when out of range.
  void validate() const;
};

/// The instants the strip draws (evenly spaced from take-off to touchdown + tail) and whether
/// the snapshots are spread apart (see StripSettings::spread_below).
struct StripLayout {
  std::vector<int> frames;  ///< frame indices, time order
  int apex = 0;             ///< frame of the highest CoM, drawn bold
  double spread_m = 0.0;    ///< x shift per snapshot index (0: true positions) [m]
};
StripLayout planStrip(const model::RobotModel& robot, const Recording& rec,
                      const StripSettings& settings);

/// The frames the GIF shows and the playback it ends up with.
struct GifLayout {
  std::vector<int> frames;            ///< frame indices, time order
  double slowdown = 1.0;              ///< wall time per run time actually used
  double fps = 20.0;                  ///< frames per second actually used (100 / delay_cs)
  int delay_cs = 5;                   ///< GIF frame delay [1/100 s]
  double t_begin = 0.0, t_end = 0.0;  ///< run time span shown [s]
};
/// Slowed as asked if the frames fit in max_frames; else real time; else fewer frames a second
/// (down to 8); else only the part around the jump.
GifLayout planGif(const Recording& rec, const GifSettings& settings);

/// Writes the snapshot strip as a PNG (gnuplot pngcairo). The gnuplot script is kept beside it
/// (`png + ".gp"`). Throws std::runtime_error when gnuplot fails or the file cannot be written.
void writeSnapshotStrip(const model::RobotModel& robot, const Recording& rec,
                        const std::filesystem::path& png, const StripSettings& settings = {});
/// Writes the animation as a GIF (gnuplot's gif animate terminal). Throws as above.
void writeAnimationGif(const model::RobotModel& robot, const Recording& rec,
                       const std::filesystem::path& gif, const GifSettings& settings = {});

}  // namespace wj::viz
