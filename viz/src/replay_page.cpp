#include "viz/replay_page.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "viz/geometry.h"

namespace wj::viz {

namespace {

using nlohmann::json;

// Rounded for the page: 0.1 mm, 1e-4 rad, which keeps the file small.
double r4(double v) {
  return std::round(v * 1e4) / 1e4;
}

json vec(const Eigen::Vector3d& v) {
  return {r4(v.x()), r4(v.y()), r4(v.z())};
}
json quat(const Eigen::Quaterniond& q) {
  const Eigen::Quaterniond n = q.normalized();
  return {r4(n.w()), r4(n.x()), r4(n.y()), r4(n.z())};
}

std::string readText(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("replay page: cannot read " + path.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Replaces the one occurrence of `marker` in `page` by `text`.
void fill(std::string& page, const std::string& marker, const std::string& text) {
  const auto at = page.find(marker);
  if (at == std::string::npos) throw std::runtime_error("replay page: template lacks " + marker);
  page.replace(at, marker.size(), text);
}

json robotJson(const model::RobotModel& robot) {
  json links = json::array();
  for (const model::LinkSpec& l : robot.links()) {
    json shapes = json::array();
    for (const model::LinkShape& s : l.shapes) {
      const char* kind = s.kind == model::LinkShape::Kind::Box        ? "box"
                         : s.kind == model::LinkShape::Kind::Cylinder ? "cylinder"
                                                                      : "sphere";
      shapes.push_back({{"kind", kind},
                        {"size", vec(s.size)},
                        {"xyz", vec(s.X_LS.translation())},
                        {"quat", quat(Eigen::Quaterniond(s.X_LS.linear()))}});
    }
    links.push_back({{"name", l.name}, {"parent_joint", l.parent_joint}, {"shapes", shapes}});
  }
  json joints = json::array();
  for (const model::JointSpec& j : robot.joints())
    joints.push_back({{"name", j.name},
                      {"kind", std::string(model::toString(j.kind))},
                      {"parent", j.parent_link},
                      {"child", j.child_link},
                      {"xyz", vec(j.X_PJ.translation())},
                      {"quat", quat(Eigen::Quaterniond(j.X_PJ.linear()))},
                      {"axis", vec(j.axis)},
                      {"peak_torque_nm", j.actuator.peak_torque_nm}});
  return {{"name", robot.name()}, {"links", links}, {"joints", joints}};
}

}  // namespace

void PageSettings::validate() const {
  if (!(rate_hz >= 5.0 && rate_hz <= 1000.0))
    throw std::invalid_argument("PageSettings.rate_hz must be in [5, 1000] Hz");
}

std::filesystem::path findWebDir() {
  std::filesystem::path dir = WJ_SOURCE_VIZ_WEB_DIR;
  if (const char* env = std::getenv("WJ_VIZ_WEB_DIR"); env && *env) dir = env;
  if (!std::filesystem::exists(dir / "replay.html"))
    throw std::runtime_error("replay page: no replay.html in " + dir.string() +
                             " (set WJ_VIZ_WEB_DIR to the source tree's viz/web)");
  if (!std::filesystem::exists(dir / "node_modules" / "three" / "build" / "three.module.js"))
    throw std::runtime_error("replay page: three.js is not installed in " +
                             (dir / "node_modules").string() +
                             " (run deploy/install-deps.sh, or `npm ci` in " + dir.string() + ")");
  return dir;
}

json pageData(const model::RobotModel& robot, const Recording& rec, const PageSettings& settings) {
  settings.validate();
  rec.validate();
  const int n = static_cast<int>(rec.frames.size());
  const int apex = rec.apexFrame();
  const int takeoff = std::isfinite(rec.jump_start_t) ? rec.frameAt(rec.jump_start_t) : 0;
  const int touchdown = std::isfinite(rec.touchdown_t) ? rec.frameAt(rec.touchdown_t) : n - 1;
  // Frames kept: one per 1/rate_hz, plus the instants the page jumps to.
  std::vector<int> keep;
  double next = rec.frames.front().t;
  for (int i = 0; i < n; ++i)
    if (rec.frames[i].t >= next - 1e-9) {
      keep.push_back(i);
      next = rec.frames[i].t + 1.0 / settings.rate_hz;
    }
  for (const int i : {apex, takeoff, touchdown, n - 1}) keep.push_back(i);
  std::sort(keep.begin(), keep.end());
  keep.erase(std::unique(keep.begin(), keep.end()), keep.end());
  const auto indexOf = [&](int i) {
    return static_cast<int>(std::lower_bound(keep.begin(), keep.end(), i) - keep.begin());
  };

  json t = json::array(), base = json::array(), q = json::array(), tau = json::array(),
       load = json::array(), com = json::array(), phase = json::array(), phases = json::array();
  std::map<std::string, int> phase_index;
  for (const int i : keep) {
    const Frame& f = rec.frames[i];
    t.push_back(r4(f.t));
    base.push_back({r4(f.p_WB.x()), r4(f.p_WB.y()), r4(f.p_WB.z()), r4(f.q_WB.w()), r4(f.q_WB.x()),
                    r4(f.q_WB.y()), r4(f.q_WB.z())});
    json qi = json::array(), ti = json::array(), li = json::array();
    for (int j = 0; j < model::kNumJoints; ++j) {
      qi.push_back(r4(f.q[j]));
      ti.push_back(std::round(f.tau[j] * 100.0) / 100.0);
      const double limit = robot.joints()[j].actuator.torqueLimit(f.tau[j], f.qd[j]);
      li.push_back(limit > 0.0 ? std::round(std::min(9.99, std::abs(f.tau[j]) / limit) * 1e3) / 1e3
                               : 9.99);
    }
    q.push_back(qi);
    tau.push_back(ti);
    load.push_back(li);
    com.push_back(vec(f.p_WC));
    const auto [it, added] = phase_index.try_emplace(f.phase, static_cast<int>(phases.size()));
    if (added) phases.push_back(f.phase);
    phase.push_back(it->second);
  }
  // Boxes as far as the page shows them: the simulation's walls span y by kilometres and sit
  // deep in the ground; 5 m beyond the run along x, 1 m either side, from just below ground.
  double x_lo = rec.frames.front().p_WB.x(), x_hi = x_lo;
  for (const Frame& f : rec.frames) {
    x_lo = std::min(x_lo, f.p_WB.x());
    x_hi = std::max(x_hi, f.p_WB.x());
  }
  const Eigen::Vector3d lo(x_lo - 5.0, -1.0, -0.02), hi(x_hi + 5.0, 1.0, 1e3);
  json boxes = json::array();
  for (const SceneBox& b : rec.boxes) {
    const Eigen::Vector3d a = b.min.cwiseMax(lo), c = b.max.cwiseMin(hi);
    if ((a.array() < c.array()).all()) boxes.push_back({{"min", vec(a)}, {"max", vec(c)}});
  }
  json planned = json::array();
  for (const PathPoint& p : rec.planned_com)
    planned.push_back({r4(p.t), r4(p.p.x()), r4(p.p.y()), r4(p.p.z())});
  json wheels = json::array();
  for (const Eigen::Vector3d& c : calcWheelCentersW(robot, rec.frames[apex]))
    wheels.push_back(vec(c));
  const auto instant = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  return {{"version", 1},
          {"title", rec.title},
          {"source", rec.source},
          {"robot", robotJson(robot)},
          {"boxes", boxes},
          {"planned_com", planned},
          {"frames",
           {{"t", t},
            {"base", base},
            {"q", q},
            {"tau", tau},
            {"load", load},
            {"com", com},
            {"phase", phase},
            {"phases", phases}}},
          {"events",
           {{"jump_start_t", instant(rec.jump_start_t)},
            {"touchdown_t", instant(rec.touchdown_t)},
            {"takeoff_index", indexOf(takeoff)},
            {"apex_index", indexOf(apex)},
            {"touchdown_index", indexOf(touchdown)}}},
          {"check", {{"frame", indexOf(apex)}, {"wheel_centers", wheels}}}};
}

void writeReplayPage(const model::RobotModel& robot, const Recording& rec,
                     const std::filesystem::path& html, const PageSettings& settings) {
  const std::filesystem::path dir = settings.web_dir.empty() ? findWebDir() : settings.web_dir;
  std::string page = readText(dir / "replay.html");
  const std::filesystem::path three = dir / "node_modules" / "three" / "build";
  std::string core = readText(three / "three.core.js");
  std::string module = readText(three / "three.module.js");
  for (const std::string* js : {&core, &module})
    if (js->find("</script") != std::string::npos)
      throw std::runtime_error("replay page: three.js contains </script and cannot be inlined");
  // JSON inside <script>: "</" is written "<\/" (the same string to a JSON parser).
  std::string data = pageData(robot, rec, settings).dump();
  for (std::size_t at = data.find("</"); at != std::string::npos; at = data.find("</", at + 3))
    data.replace(at, 2, "<\\/");
  // Data first: the three.js sources could contain the other markers' text.
  fill(page, "/*WJ_DATA*/", data);
  const auto at_core = page.find("/*WJ_THREE_CORE*/");
  if (at_core == std::string::npos) throw std::runtime_error("replay page: template lacks three");
  page.replace(at_core, std::string("/*WJ_THREE_CORE*/").size(), core);
  const auto at_module = page.find("/*WJ_THREE_MODULE*/", at_core + core.size());
  if (at_module == std::string::npos) throw std::runtime_error("replay page: template lacks three");
  page.replace(at_module, std::string("/*WJ_THREE_MODULE*/").size(), module);
  std::ofstream out(html, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + html.string());
  out << page;
  if (!out) throw std::runtime_error("cannot write " + html.string());
}

}  // namespace wj::viz
