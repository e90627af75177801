#include "viz/knee_figure.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "gnuplot.h"

namespace wj::viz {

namespace {

constexpr std::array<model::Leg, 2> kKneeLegs = {model::Leg::LF, model::Leg::LH};
constexpr std::array<const char*, 2> kKneeNames = {"LF_KFE (front)", "LH_KFE (hind)"};

std::ofstream openData(const std::filesystem::path& path) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path.string());
  out << std::setprecision(6);
  return out;
}

// Inside the window, ends included (1 ns of slack: the frames' times are sums of periods).
bool inWindow(const KneeFigureLayout& l, double t) {
  return t >= l.t_begin - 1e-9 && t <= l.t_end + 1e-9;
}

// A vertical dotted line at t, if known.
void markInstant(std::ostream& gp, double t) {
  if (std::isfinite(t))
    gp << "set arrow from " << t << ", graph 0 to " << t << ", graph 1 nohead dt 3 lc 'gray'\n";
}

}  // namespace

void KneeFigureSettings::validate() const {
  const auto check = [](bool ok, const char* field, const char* range) {
    if (!ok)
      throw std::invalid_argument(std::string("KneeFigureSettings.") + field + " must be " + range);
  };
  check(before_s >= 0.0 && before_s <= 5.0, "before_s", "in [0, 5] s");
  check(after_s >= 0.0 && after_s <= 5.0, "after_s", "in [0, 5] s");
  check(width_px >= 300 && width_px <= 4000, "width_px", "in [300, 4000]");
  check(height_px >= 300 && height_px <= 4000, "height_px", "in [300, 4000]");
}

KneeFigureLayout planKneeFigure(const model::RobotModel& robot, const Recording& rec,
                                const KneeFigureSettings& settings) {
  settings.validate();
  rec.validate();
  KneeFigureLayout l;
  const double t0 = rec.frames.front().t, tn = rec.frames.back().t;
  l.t_begin =
      std::isfinite(rec.jump_start_t) ? std::max(t0, rec.jump_start_t - settings.before_s) : t0;
  const double end = std::isfinite(rec.liftoff_t) ? rec.liftoff_t : rec.touchdown_t;
  l.t_end = std::isfinite(end) ? std::clamp(end + settings.after_s, l.t_begin, tn) : tn;
  for (int i = 0; i < 2; ++i) l.joints[i] = model::jointIndex(kKneeLegs[i], model::JointKind::KFE);
  for (const Frame& f : rec.frames) {
    if (!inWindow(l, f.t)) continue;
    ++l.frames;
    for (int i = 0; i < 2; ++i) {
      const int j = l.joints[i];
      const double limit = robot.joints()[j].actuator.torqueLimit(f.tau[j], f.qd[j]);
      l.max_abs_speed[i] = std::max(l.max_abs_speed[i], std::abs(f.qd[j]));
      const double ratio = limit > 0.0
                               ? std::abs(f.tau[j]) / limit
                               : (f.tau[j] == 0.0 ? 0.0 : std::numeric_limits<double>::infinity());
      l.max_envelope_ratio[i] = std::max(l.max_envelope_ratio[i], ratio);
    }
  }
  if (l.frames < 2)
    throw std::invalid_argument("recording '" + rec.title +
                                "': fewer than two frames in the take-off window of the knee "
                                "figure");
  return l;
}

void writeKneeFigure(const model::RobotModel& robot, const Recording& rec,
                     const std::filesystem::path& png, const KneeFigureSettings& settings) {
  const KneeFigureLayout l = planKneeFigure(robot, rec, settings);
  const std::string base = png.string();
  const std::filesystem::path sim_dat = base + ".dat", plan_dat = base + ".plan.dat",
                              env_dat = base + ".envelope.dat", script = base + ".gp";
  {
    // t, then per knee: qd, tau, envelope at qd.
    std::ofstream out = openData(sim_dat);
    for (const Frame& f : rec.frames) {
      if (!inWindow(l, f.t)) continue;
      out << f.t;
      for (const int j : l.joints)
        out << ' ' << f.qd[j] << ' ' << f.tau[j] << ' '
            << robot.joints()[j].actuator.torqueLimit(f.qd[j]);
      out << '\n';
    }
  }
  bool have_plan = false;
  {
    // t, then per knee: qd, tau.
    std::ofstream out = openData(plan_dat);
    for (const PlannedJoints& p : rec.planned_joints) {
      if (!inWindow(l, p.t)) continue;
      have_plan = true;
      out << p.t;
      for (const int j : l.joints) out << ' ' << p.qd[j] << ' ' << p.tau[j];
      out << '\n';
    }
  }
  // The hind knee's envelope in the speed-torque plane, closed (both knees are the same kind).
  const model::ActuatorEnvelope& a = robot.joints()[l.joints[1]].actuator;
  {
    std::ofstream out = openData(env_dat);
    const double w0 = a.corner_speed_rad_s, w1 = a.no_load_speed_rad_s, T = a.peak_torque_nm;
    for (const auto& [w, t] :
         {std::pair{-w1, 0.0}, {-w0, T}, {w0, T}, {w1, 0.0}, {w0, -T}, {-w0, -T}, {-w1, 0.0}})
      out << w << ' ' << t << '\n';
  }
  std::ostringstream gp;
  gp << "set terminal pngcairo size " << settings.width_px << "," << settings.height_px
     << " font ',10' noenhanced\nset output '" << base << "'\nset key outside right\nset grid\n"
     << "set multiplot layout 3,1 title "
     << detail::quoted(rec.title + ": knees over the take-off (" + rec.source + "); peak " +
                       std::to_string(static_cast<int>(std::lround(a.peak_torque_nm))) + " Nm to " +
                       std::to_string(static_cast<int>(a.corner_speed_rad_s)) + " rad/s, 0 at " +
                       std::to_string(static_cast<int>(a.no_load_speed_rad_s)) + " rad/s")
     << "\n"
     << "set xrange [" << l.t_begin << ":" << l.t_end << "]\n";
  markInstant(gp, rec.jump_start_t);
  markInstant(gp, rec.front_liftoff_t);
  markInstant(gp, rec.liftoff_t);
  const std::string plan_qd = have_plan ? ", '" + plan_dat.string() +
                                              "' using 1:2 w l dt 4 lc 1 t 'LF planned', '' " +
                                              "using 1:4 w l dt 4 lc 2 t 'LH planned'"
                                        : std::string();
  const std::string plan_tau = have_plan ? ", '" + plan_dat.string() +
                                               "' using 1:3 w l dt 4 lc 1 t 'LF planned', '' " +
                                               "using 1:5 w l dt 4 lc 2 t 'LH planned'"
                                         : std::string();
  gp << "set ylabel 'knee velocity [rad/s]'\n"
     << "plot '" << sim_dat.string() << "' using 1:2 w l lw 2 lc 1 t '" << kKneeNames[0]
     << "', '' using 1:5 w l lw 2 lc 2 t '" << kKneeNames[1] << "'" << plan_qd << ", "
     << a.no_load_speed_rad_s << " dt 2 lc 'red' t 'no-load speed', " << -a.no_load_speed_rad_s
     << " dt 2 lc 'red' notitle\n"
     << "set ylabel 'knee torque [Nm]'\n"
     << "set xlabel 'time [s] (dotted: start of the take-off, front lift-off t1, lift-off t2)'\n"
     << "plot '" << sim_dat.string() << "' using 1:3 w l lw 2 lc 1 t '" << kKneeNames[0]
     << "', '' using 1:6 w l lw 2 lc 2 t '" << kKneeNames[1] << "'" << plan_tau << ", '"
     << sim_dat.string()
     << "' using 1:4 w l dt 2 lc 'orange' t 'LF envelope at its speed', '' using 1:(-$4) w l "
        "dt 2 lc 'orange' notitle, '' using 1:7 w l dt 2 lc 'red' t 'LH envelope at its speed', "
        "'' using 1:(-$7) w l dt 2 lc 'red' notitle\n"
     << "unset arrow\nset autoscale x\nset xrange [" << -1.05 * a.no_load_speed_rad_s << ":"
     << 1.05 * a.no_load_speed_rad_s << "]\n"
     << "set xlabel 'knee velocity [rad/s]'\nset ylabel 'knee torque [Nm]'\n"
     << "plot '" << env_dat.string() << "' using 1:2 w l lw 2 lc 'red' t 'torque-speed envelope', '"
     << sim_dat.string() << "' using 2:3 w l lc 1 t 'LF', '' using 5:6 w l lc 2 t 'LH'"
     << (have_plan ? ", '" + plan_dat.string() +
                         "' using 2:3 w l dt 4 lc 1 t 'LF planned', '' using 4:5 w l dt 4 lc 2 "
                         "t 'LH planned'"
                   : std::string())
     << "\nunset multiplot\n";
  detail::writeScript(script, gp.str());
  detail::runGnuplot(script, png);
}

}  // namespace wj::viz
