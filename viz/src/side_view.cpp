#include "viz/side_view.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "gnuplot.h"
#include "viz/geometry.h"

namespace wj::viz {

namespace {

using detail::quoted;
using detail::runGnuplot;
using detail::writeScript;

// Axis-aligned bounds of what a picture shows, in (x, z).
struct Bounds {
  double x_min = 1e300, x_max = -1e300, z_min = 1e300, z_max = -1e300;
  void add(double x, double z) {
    x_min = std::min(x_min, x);
    x_max = std::max(x_max, x);
    z_min = std::min(z_min, z);
    z_max = std::max(z_max, z);
  }
};

// An RGB colour as gnuplot's "#rrggbb".
std::string rgb(double r, double g, double b) {
  char s[8];
  const auto c = [](double v) {
    return static_cast<int>(std::lround(std::clamp(v, 0.0, 1.0) * 255));
  };
  std::snprintf(s, sizeof s, "#%02x%02x%02x", c(r), c(g), c(b));
  return s;
}

// Colour of snapshot k of n: blue (take-off) through violet to red (landing).
std::string timeColour(int k, int n) {
  const double u = n > 1 ? static_cast<double>(k) / (n - 1) : 0.0;
  return rgb(0.12 + 0.70 * u, 0.37 - 0.12 * u, 0.75 - 0.55 * u);
}

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

// How one robot is drawn.
struct RobotStyle {
  std::string body;         ///< base and near-side legs (fill and border)
  double fill_alpha = 0.3;  ///< transparency of the fills (pngcairo), 1 = opaque
  double line_width = 1.0;
  bool transparent = true;  ///< false for terminals without alpha (gif)
};

// Appends `set object` / `set arrow` lines that draw the robot at `frame`, shifted by dx along
// x, far side (y > 0, away from the viewer at -y) first; grows `bounds`.
void drawRobot(std::ostream& gp, int& tag, const model::RobotModel& robot, const Frame& frame,
               double dx, const RobotStyle& style, Bounds& bounds) {
  std::vector<PosedShape> shapes = calcPosedShapes(robot, frame);
  std::stable_sort(shapes.begin(), shapes.end(), [](const PosedShape& a, const PosedShape& b) {
    return a.X_WS.translation().y() > b.X_WS.translation().y();
  });
  const auto X_WL = calcLinkPosesW(robot, frame);
  for (const PosedShape& s : shapes) {
    const bool far = s.X_WS.translation().y() > 0.0 && s.link != 0;
    const bool wheel = s.shape.kind == model::LinkShape::Kind::Cylinder;
    const std::string border = far ? "#9a9a9a" : style.body;
    const std::string fill =
        s.link == 0 ? style.body : (far ? "#c8c8c8" : (wheel ? "#3a3a3a" : "#6a6a6a"));
    // Legs and wheels twice as opaque as the body, so that they read through it.
    const double alpha = s.link == 0 ? style.fill_alpha : std::min(1.0, 2.0 * style.fill_alpha);
    const auto outline = sideOutline(s);
    gp << "set object " << tag++ << " polygon from ";
    for (std::size_t i = 0; i <= outline.size(); ++i) {
      const Eigen::Vector2d& p = outline[i % outline.size()];
      gp << (i ? " to " : "") << fixed(p.x() + dx, 4) << "," << fixed(p.y(), 4);
      bounds.add(p.x() + dx, p.y());
    }
    gp << " back fc rgb '" << fill << "' fs "
       << (style.transparent ? "transparent solid " + fixed(alpha, 2) : std::string("solid 1"))
       << " border lc rgb '" << border << "' lw " << style.line_width << "\n";
    if (wheel) {  // a spoke along the wheel link's x axis shows the wheel turning
      const Eigen::Vector3d c = X_WL[s.link].translation();
      const Eigen::Vector3d r = c + s.shape.size.x() * X_WL[s.link].linear().col(0);
      gp << "set arrow from " << fixed(c.x() + dx, 4) << "," << fixed(c.z(), 4) << " to "
         << fixed(r.x() + dx, 4) << "," << fixed(r.z(), 4) << " nohead back lc rgb '"
         << (far ? "#9a9a9a" : "#e8e8e8") << "' lw " << style.line_width << "\n";
    }
  }
}

// Ground and boxes as objects behind everything.
void drawTerrain(std::ostream& gp, int& tag, const Recording& rec, const Bounds& view) {
  gp << "set object " << tag++ << " rect from " << fixed(view.x_min - 1.0, 3) << ","
     << fixed(view.z_min - 1.0, 3) << " to " << fixed(view.x_max + 1.0, 3)
     << ",0 back fc rgb '#e4d9c4' fs solid 1 border lc rgb '#7a6a50'\n";
  for (const SceneBox& b : rec.boxes)  // what is below the ground is not seen
    gp << "set object " << tag++ << " rect from " << fixed(b.min.x(), 4) << ","
       << fixed(std::max(b.min.z(), 0.0), 4) << " to " << fixed(b.max.x(), 4) << ","
       << fixed(b.max.z(), 4) << " back fc rgb '#a07850' fs solid 1 border lc rgb '#5a4028'\n";
}

double robotLength(const model::RobotModel& robot) {
  double front = 0.0, hind = 0.0;
  for (const model::Leg leg : model::kLegs) {
    front = std::max(front, robot.legGeometry(leg).p_BH.x());
    hind = std::min(hind, robot.legGeometry(leg).p_BH.x());
  }
  return std::max(robot.baseBoxSize().x(), front - hind + 2.0 * robot.wheelRadius());
}

// Window of a jump of the recording: [start, touchdown + tail] within the frames; an unknown
// (NaN) end is the run's.
std::pair<double, double> jumpWindow(const Recording& rec, double start, double touchdown,
                                     double tail) {
  const double t0 = rec.frames.front().t, tn = rec.frames.back().t;
  const double a = std::isfinite(start) ? std::clamp(start, t0, tn) : t0;
  const double b = std::isfinite(touchdown) ? std::clamp(touchdown + tail, a, tn) : tn;
  return {a, b};
}

// The frames of one jump's row: evenly spaced from its take-off to its touchdown + tail, its
// apex, and the spread of a jump in place.
StripLayout planRow(const model::RobotModel& robot, const Recording& rec, const JumpSpan& jump,
                    const StripSettings& settings) {
  const auto [a, b] = jumpWindow(rec, jump.start_t, jump.touchdown_t, settings.landing_tail_s);
  StripLayout layout;
  for (int k = 0; k < settings.snapshots; ++k) {
    const int i = rec.frameAt(a + (b - a) * k / (settings.snapshots - 1));
    if (layout.frames.empty() || layout.frames.back() != i) layout.frames.push_back(i);
  }
  // The highest CoM between take-off and touchdown (the whole row without a touchdown).
  layout.apex = rec.apexFrame(jump.start_t, jump.touchdown_t);
  // A jump in place: every snapshot on top of the others. Spread them like a film strip.
  const double travel =
      rec.frames[layout.frames.back()].p_WB.x() - rec.frames[layout.frames.front()].p_WB.x();
  const double length = robotLength(robot);
  const int n = static_cast<int>(layout.frames.size());
  if (n > 1 && std::abs(travel) < settings.spread_below * length)
    layout.spread_m = 1.15 * length - travel / (n - 1);
  return layout;
}

// The gnuplot commands of one row of the strip (its objects, ranges, title and plot) and the
// row's height in pixels. `tag` names the row's datablocks, unique within a script.
struct RowScript {
  std::string text;
  int height_px = 0;
};
RowScript stripRow(const model::RobotModel& robot, const Recording& rec, const JumpSpan& jump,
                   const StripSettings& settings, const std::string& heading,
                   const std::string& tag_suffix) {
  const StripLayout layout = planRow(robot, rec, jump, settings);
  const int n = static_cast<int>(layout.frames.size());
  const double t0 = rec.frames[layout.frames.front()].t;
  const double t1 = rec.frames[layout.frames.back()].t;
  const double dt_snap = n > 1 ? (t1 - t0) / (n - 1) : 1.0;
  // x shift of anything at time t (0 unless the snapshots are spread).
  const auto shift = [&](double t) { return layout.spread_m * (t - t0) / dt_snap; };

  std::ostringstream objects;
  int tag = 100;  // terrain gets 1..99, drawn first
  Bounds bounds;
  for (int k = 0; k < n; ++k) {
    const Frame& f = rec.frames[layout.frames[k]];
    drawRobot(objects, tag, robot, f, shift(f.t), {timeColour(k, n), 0.18, 1.2, true}, bounds);
  }
  const Frame& apex = rec.frames[layout.apex];
  drawRobot(objects, tag, robot, apex, shift(apex.t), {"#101010", 0.45, 2.5, true}, bounds);

  std::ostringstream sim, plan;
  for (std::size_t i = 0; i < rec.frames.size(); ++i) {
    const Frame& f = rec.frames[i];
    if (f.t < t0 || f.t > t1) continue;
    sim << fixed(f.p_WC.x() + shift(f.t), 4) << " " << fixed(f.p_WC.z(), 4) << "\n";
    bounds.add(f.p_WC.x() + shift(f.t), f.p_WC.z());
  }
  for (const PathPoint& p : jump.planned_com) {
    if (p.t < t0 || p.t > t1) continue;
    plan << fixed(p.p.x() + shift(p.t), 4) << " " << fixed(p.p.z(), 4) << "\n";
    bounds.add(p.p.x() + shift(p.t), p.p.z());
  }
  for (const SceneBox& b : rec.boxes)
    if (b.max.x() > bounds.x_min - 0.5 && b.min.x() < bounds.x_max + 0.5)
      bounds.add(std::clamp(b.max.x(), bounds.x_min - 0.3, bounds.x_max + 0.3), b.max.z());
  bounds.add(bounds.x_min, -0.06);
  const double margin = 0.08;
  const double xspan = bounds.x_max - bounds.x_min + 2 * margin;
  const double zspan = bounds.z_max - bounds.z_min + 2 * margin;
  RowScript out;
  out.height_px = std::clamp(static_cast<int>(settings.width_px * zspan / xspan) + 170, 320, 1400);

  const std::string sim_block = "$sim" + tag_suffix, plan_block = "$plan" + tag_suffix;
  std::ostringstream gp;
  std::ostringstream title;
  title << heading << "\n"
        << n << " snapshots every " << fixed(dt_snap, 3)
        << " s (blue to red) from the take-off, t = " << fixed(t0, 2)
        << " s, to after the landing, t = " << fixed(t1, 2)
        << " s; black: the apex, t = " << fixed(apex.t, 2) << " s";
  if (layout.spread_m > 0.0)
    title << "\na jump in place: snapshots spread apart by " << fixed(layout.spread_m, 2)
          << " m each along x (x not to scale between snapshots)";
  gp << "set title " << quoted(title.str()) << "\n"
     << "set size ratio -1\nset grid\nset key top left opaque box\n"
     << "set xlabel 'x [m]'\nset ylabel 'z [m]'\n"
     << "set xrange [" << fixed(bounds.x_min - margin, 3) << ":" << fixed(bounds.x_max + margin, 3)
     << "]\nset yrange [" << fixed(bounds.z_min - margin, 3) << ":"
     << fixed(bounds.z_max + margin, 3) << "]\n";
  int terrain_tag = 1;
  drawTerrain(gp, terrain_tag, rec, bounds);
  gp << objects.str();
  // Datablocks before the plot command.
  gp << sim_block << " << EOD\n" << sim.str() << "EOD\n";
  const bool planned = !plan.str().empty();
  if (planned) gp << plan_block << " << EOD\n" << plan.str() << "EOD\n";
  gp << "plot " << sim_block << " using 1:2 with lines lw 2.5 lc rgb '#000000' title "
     << quoted(rec.source + " CoM");
  if (planned)
    gp << ", " << plan_block
       << " using 1:2 with lines dt 2 lw 2.5 lc rgb '#e0301e' title 'planned CoM'";
  gp << "\n";
  out.text = gp.str();
  return out;
}

}  // namespace

void StripSettings::validate() const {
  if (snapshots < 2 || snapshots > 30)
    throw std::invalid_argument("StripSettings.snapshots must be in [2, 30]");
  if (!(landing_tail_s >= 0.0 && landing_tail_s <= 5.0))
    throw std::invalid_argument("StripSettings.landing_tail_s must be in [0, 5] s");
  if (width_px < 300 || width_px > 4000)
    throw std::invalid_argument("StripSettings.width_px must be in [300, 4000]");
  if (!(spread_below >= 0.0 && spread_below <= 10.0))
    throw std::invalid_argument("StripSettings.spread_below must be in [0, 10]");
}

void GifSettings::validate() const {
  if (!(fps >= 2.0 && fps <= 50.0))
    throw std::invalid_argument("GifSettings.fps must be in [2, 50]");
  if (!(slowdown >= 0.1 && slowdown <= 20.0))
    throw std::invalid_argument("GifSettings.slowdown must be in [0.1, 20]");
  if (max_frames < 2 || max_frames > 2000)
    throw std::invalid_argument("GifSettings.max_frames must be in [2, 2000]");
  if (!(window_m >= 0.5 && window_m <= 50.0))
    throw std::invalid_argument("GifSettings.window_m must be in [0.5, 50] m");
  if (width_px < 100 || width_px > 2000 || height_px < 100 || height_px > 2000)
    throw std::invalid_argument("GifSettings.width_px and height_px must be in [100, 2000]");
}

StripLayout planStrip(const model::RobotModel& robot, const Recording& rec,
                      const StripSettings& settings) {
  settings.validate();
  rec.validate();
  return planRow(robot, rec, {rec.jump_start_t, rec.touchdown_t, {}}, settings);
}

void writeSnapshotStrip(const model::RobotModel& robot, const Recording& rec,
                        const std::filesystem::path& png, const StripSettings& settings) {
  settings.validate();
  rec.validate();
  // One row per jump: a run with several (the course) would otherwise show only its last.
  std::vector<RowScript> rows;
  if (rec.jumps.size() < 2) {
    JumpSpan only{rec.jump_start_t, rec.touchdown_t, rec.planned_com};
    rows.push_back(stripRow(robot, rec, only, settings, rec.title, ""));
  } else {
    const int n = static_cast<int>(rec.jumps.size());
    for (int i = 0; i < n; ++i)
      rows.push_back(
          stripRow(robot, rec, rec.jumps[static_cast<std::size_t>(i)], settings,
                   rec.title + ", jump " + std::to_string(i + 1) + " of " + std::to_string(n),
                   std::to_string(i)));
  }
  int height = 0;
  for (const RowScript& r : rows) height += r.height_px;
  std::ostringstream gp;
  gp << "set terminal pngcairo size " << settings.width_px << "," << height
     << " font ',11' noenhanced\n"
     << "set output " << quoted(png.string()) << "\n";
  if (rows.size() > 1) gp << "set multiplot layout " << rows.size() << ",1\n";
  for (const RowScript& r : rows) gp << "unset object\nunset arrow\n" << r.text;
  if (rows.size() > 1) gp << "unset multiplot\n";
  const std::filesystem::path script = png.string() + ".gp";
  writeScript(script, gp.str());
  runGnuplot(script, png);
}

GifLayout planGif(const Recording& rec, const GifSettings& settings) {
  settings.validate();
  rec.validate();
  GifLayout g;
  const double t0 = rec.frames.front().t, tn = rec.frames.back().t;
  g.t_begin = t0;
  g.t_end = tn;
  const auto count = [&] {  // frames 1 / (fps * slowdown) of run time apart, both ends in
    return static_cast<int>(std::floor((g.t_end - g.t_begin) * g.fps * g.slowdown + 1e-9)) + 1;
  };
  // GIF delays are whole centiseconds: the frame rate is 100 / delay.
  const auto useFps = [&](double fps) {
    g.delay_cs = std::max(2, static_cast<int>(std::ceil(100.0 / fps - 1e-9)));
    g.fps = 100.0 / g.delay_cs;
  };
  useFps(settings.fps);
  g.slowdown = settings.slowdown;
  // Too many frames: real time, then fewer frames a second (not below kMinFps), then only the
  // part around the jump.
  constexpr double kMinFps = 8.0;
  if (count() > settings.max_frames) g.slowdown = std::min(1.0, settings.slowdown);
  if (count() > settings.max_frames)
    useFps(std::max(kMinFps, (settings.max_frames - 1) / (g.slowdown * (tn - t0))));
  if (count() > settings.max_frames) {
    const double span = (settings.max_frames - 1) / (g.fps * g.slowdown);
    const auto [a, b] = jumpWindow(rec, rec.jump_start_t, rec.touchdown_t, 0.0);
    const double centre = std::isfinite(rec.jump_start_t) ? 0.5 * (a + b) : 0.5 * (t0 + tn);
    g.t_begin = std::clamp(centre - 0.5 * span, t0, tn - span);
    g.t_end = g.t_begin + span;
  }
  const int n = std::min(count(), settings.max_frames);
  for (int k = 0; k < n; ++k) g.frames.push_back(rec.frameAt(g.t_begin + k / (g.fps * g.slowdown)));
  return g;
}

void writeAnimationGif(const model::RobotModel& robot, const Recording& rec,
                       const std::filesystem::path& gif, const GifSettings& settings) {
  const GifLayout layout = planGif(rec, settings);
  // Heights: the same for every frame.
  Bounds all;
  for (const int i : layout.frames)
    for (const PosedShape& s : calcPosedShapes(robot, rec.frames[i]))
      for (const Eigen::Vector2d& p : sideOutline(s, 12)) all.add(p.x(), p.y());
  for (const SceneBox& b : rec.boxes) all.add(b.min.x(), b.max.z());
  // Equal scales: the window's height follows from its width and the image's aspect; the
  // window widens if the jump is higher than that.
  const double aspect = (settings.height_px - 70.0) / (settings.width_px - 90.0);
  const double z_bottom = -0.08;
  const double window = std::max(settings.window_m, (all.z_max + 0.1 - z_bottom) / aspect);
  const double z_top = z_bottom + window * aspect;

  std::ostringstream gp, sim;
  gp << "set terminal gif animate delay " << layout.delay_cs << " loop 0 size " << settings.width_px
     << "," << settings.height_px << " font 'DejaVuSans,9' noenhanced\n"
     << "set output " << quoted(gif.string()) << "\n"
     << "set size ratio -1\nset grid\nset key top right opaque\nset xlabel 'x [m]'\n"
     << "set yrange [" << fixed(z_bottom, 3) << ":" << fixed(z_top, 3) << "]\n";
  const std::string speed = std::abs(layout.slowdown - 1.0) < 1e-9
                                ? std::string("real time")
                                : "slowed " + fixed(layout.slowdown, 1) + "x";
  gp << "set title " << quoted(rec.title + " (" + speed + ")") << "\n";
  for (const int i : layout.frames)
    sim << fixed(rec.frames[i].p_WC.x(), 4) << " " << fixed(rec.frames[i].p_WC.z(), 4) << "\n";
  gp << "$sim << EOD\n" << sim.str() << "EOD\n";
  if (!rec.planned_com.empty()) {
    gp << "$plan << EOD\n";
    for (const PathPoint& p : rec.planned_com)
      gp << fixed(p.p.x(), 4) << " " << fixed(p.p.z(), 4) << "\n";
    gp << "EOD\n";
  }
  for (std::size_t k = 0; k < layout.frames.size(); ++k) {
    const Frame& f = rec.frames[layout.frames[k]];
    const double xc = f.p_WB.x();
    Bounds view;
    view.add(xc - 0.5 * window, z_bottom);
    view.add(xc + 0.5 * window, z_top);
    gp << "unset object\nunset arrow\nunset label\n";
    int tag = 1;
    drawTerrain(gp, tag, rec, view);
    Bounds unused;
    drawRobot(gp, tag, robot, f, 0.0, {"#2b5c9e", 1.0, 1.0, false}, unused);
    gp << "set label 1 " << quoted("t = " + fixed(f.t, 2) + " s  " + f.phase)
       << " at graph 0.02, graph 0.93 front\n"
       << "set xrange [" << fixed(view.x_min, 3) << ":" << fixed(view.x_max, 3) << "]\n"
       << "plot ";
    if (!rec.planned_com.empty())
      gp << "$plan using 1:2 with lines lw 1.5 lc rgb '#e0301e' title 'planned CoM', ";
    gp << "$sim every ::0::" << k << " using 1:2 with lines lw 2 lc rgb '#000000' title "
       << quoted(rec.source + " CoM") << "\n";
  }
  gp << "unset output\n";
  const std::filesystem::path script = gif.string() + ".gp";
  writeScript(script, gp.str());
  runGnuplot(script, gif);
}

}  // namespace wj::viz
