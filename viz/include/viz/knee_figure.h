#pragma once
/// @file The paper's backflip figure (Zeng et al., Sec. IV-B): the knees' joint velocity and
/// torque over the take-off, simulated against planned, with the actuator's limits: the
/// no-load speed, the peak torque and the torque-speed envelope (in time at the measured
/// speed, and as the envelope itself in the speed-torque plane). Drawn with gnuplot.

#include <array>
#include <filesystem>

#include "robot_model/robot_model.h"
#include "viz/recording.h"

namespace wj::viz {

/// How the knee figure is drawn.
struct KneeFigureSettings {
  double before_s = 0.05;  ///< shown before the start of the take-off (jump_start_t) [s]
  double after_s = 0.10;   ///< shown after the lift-off (liftoff_t, else touchdown_t) [s]
  int width_px = 1100;     ///< image size
  int height_px = 1250;
  /// Throws std::invalid_argument naming the field when out of range.
  void validate() const;
};

/// What the figure shows: the time window, the two knees drawn (the left front and the left
/// hind one; the plans are left-right symmetric) and, per knee, the largest speed and the
/// largest |tau| over the envelope at the measured speed inside the window.
struct KneeFigureLayout {
  double t_begin = 0.0, t_end = 0.0;  ///< [s]
  std::array<int, 2> joints{};        ///< jointIndex of LF_KFE, LH_KFE
  std::array<double, 2> max_abs_speed{};
  std::array<double, 2> max_envelope_ratio{};  ///< |tau| / torqueLimit(qd); > 1: outside
  int frames = 0;                              ///< frames inside the window
};
KneeFigureLayout planKneeFigure(const model::RobotModel& robot, const Recording& rec,
                                const KneeFigureSettings& settings);

/// Writes the figure as a PNG (gnuplot pngcairo); its data and script are kept beside it
/// (`png + ".dat"`, `png + ".plan.dat"`, `png + ".envelope.dat"`, `png + ".gp"`). Throws
/// std::invalid_argument for a recording that cannot be drawn, std::runtime_error when gnuplot
/// fails or a file cannot be written.
void writeKneeFigure(const model::RobotModel& robot, const Recording& rec,
                     const std::filesystem::path& png, const KneeFigureSettings& settings = {});

}  // namespace wj::viz
