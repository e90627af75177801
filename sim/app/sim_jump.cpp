// sim_jump: plans a jump with the planner library, verifies it in the Simbody simulation, and
// prints the plan's prediction and the simulated outcome side by side. Writes CSV telemetry and,
// with --plot, figures like the paper's Fig. 7 and Fig. 11 (gnuplot); with --snapshots, --gif and
// --html, pictures of the jump (viz/: snapshot strip, side-view animation, 3D replay page).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "planner/jump_planner.h"
#include "planner/plan_report.h"
#include "planner/presets.h"
#include "robot_model/momentum.h"
#include "sim/executor_settings_file.h"
#include "sim/liftoff_correction.h"
#include "sim/statics.h"
#include "sim/telemetry.h"
#include "sim/verifier.h"
#include "viz/knee_figure.h"
#include "viz/replay_page.h"
#include "viz/side_view.h"

namespace {

using nlohmann::json;
namespace pl = wj::planner;
namespace sm = wj::sim;
using wj::model::JointKind;
using wj::model::Leg;

json eventJson(const pl::JumpEvent& e) {
  return {{"t", e.t},
          {"com_x", e.state.x},
          {"com_z", e.state.z},
          {"pitch", e.state.pitch},
          {"com_vx", e.state.vx},
          {"com_vz", e.state.vz},
          {"base_z", e.base_z},
          {"momentum", e.momentum}};
}

json outcomeJson(const pl::JumpOutcome& o) {
  json j = {{"takeoff", eventJson(o.takeoff)},
            {"apex", eventJson(o.apex)},
            {"touchdown", eventJson(o.touchdown)}};
  j["min_obstacle_clearance"] =
      std::isfinite(o.min_obstacle_clearance) ? json(o.min_obstacle_clearance) : json(nullptr);
  return j;
}

// The plan's dense samples, for comparison with the telemetry CSV (same joint order).
void writePlanCsv(const std::filesystem::path& path, const pl::JumpPlan& plan) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path.string());
  out << "t,x,z,pitch,vx,vz,pitch_rate";
  for (const char* what : {"q", "qd", "tau"})
    for (int j = 0; j < wj::model::kNumJoints; ++j) out << ',' << what << j;
  out << '\n';
  out.precision(10);
  for (int k = 0; k < plan.numSamples(); ++k) {
    const pl::PlanarState& c = plan.centroidal[k];
    out << k * plan.dt << ',' << c.x << ',' << c.z << ',' << c.pitch << ',' << c.vx << ',' << c.vz
        << ',' << c.pitch_rate;
    for (const auto* m : {&plan.q, &plan.qd, &plan.tau})
      for (int j = 0; j < wj::model::kNumJoints; ++j) out << ',' << (*m)(k, j);
    out << '\n';
  }
}

// Nose-up (about -y) angular momentum of the whole robot about its CoM, Simbody's against the
// plan's (model::calcCentralAngularMomentum of the plan's pitch, pitch rate, q and qd) at
// every telemetry sample inside the plan: where the flight's momentum is won or lost.
void writeMomentumCsv(const std::filesystem::path& path, const wj::model::RobotModel& robot,
                      const sm::TelemetryRecorder& recorder, const pl::JumpPlan& plan) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path.string());
  out << "t,h_sim,h_plan,pitch_rate_sim,pitch_rate_plan\n";
  out.precision(8);
  const auto noseUp = [&](const Eigen::Matrix3d& R, const Eigen::Vector3d& w,
                          const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
    return -wj::model::calcCentralAngularMomentum(robot, R, w, q, qd).y();
  };
  Eigen::VectorXd q(wj::model::kNumJoints), qd(wj::model::kNumJoints);
  for (const sm::TelemetrySample& s : recorder.samples()) {
    const int k = static_cast<int>(std::lround(s.t / plan.dt));
    if (k < 0 || k >= plan.numSamples()) continue;
    for (int j = 0; j < wj::model::kNumJoints; ++j) {
      q[j] = s.q[j];
      qd[j] = s.qd[j];
    }
    const double h_sim = noseUp(s.q_WB.toRotationMatrix(), s.w_WB, q, qd);
    const pl::PlanarState& c = plan.centroidal[k];
    const Eigen::Matrix3d R_plan =
        Eigen::AngleAxisd(-c.pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
    const double h_plan = noseUp(R_plan, Eigen::Vector3d(0.0, -c.pitch_rate, 0.0),
                                 plan.q.row(k).transpose(), plan.qd.row(k).transpose());
    out << s.t << ',' << h_sim << ',' << h_plan << ',' << -s.w_WB.y() << ',' << c.pitch_rate
        << '\n';
  }
}

// Writes the planned CoM height and the figure script, then runs gnuplot.
void plot(const std::filesystem::path& png, const std::filesystem::path& csv,
          const pl::JumpPlan& plan, const wj::model::RobotModel& robot) {
  const std::filesystem::path planned = png.string() + ".plan.dat";
  {
    std::ofstream out(planned);
    for (int k = 0; k < plan.numSamples(); ++k)
      out << k * plan.dt << " " << plan.centroidal[k].z << "\n";
  }
  const auto& hfe = robot.joint(Leg::LF, JointKind::HFE).actuator;
  const auto& wheel = robot.joint(Leg::LF, JointKind::Wheel).actuator;
  // Telemetry columns (1-based): com_z 18; q_* 22..37; qd_* 38..53; tau_* 54..69; LF first.
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1200,1100 font ',10'\n"
     << "set output '" << png.string() << "'\n"
     << "set datafile separator ','\nset key outside right\nset grid\n"
     << "set multiplot layout 3,1 title 'sim\\_jump: left-front leg and CoM (limits dashed)'\n"
     << "set arrow from " << plan.t1 << ", graph 0 to " << plan.t1
     << ", graph 1 nohead dt 3 lc 'gray'\n"
     << "set arrow from " << plan.t2 << ", graph 0 to " << plan.t2
     << ", graph 1 nohead dt 3 lc 'gray'\n"
     << "set arrow from " << plan.t3 << ", graph 0 to " << plan.t3
     << ", graph 1 nohead dt 3 lc 'gray'\n"
     << "set ylabel 'joint velocity [rad/s]'\n"
     << "plot '" << csv.string()
     << "' every ::1 using 1:38 w l t 'LF HAA', '' every ::1 using 1:39 w l "
     << "t 'LF HFE', '' every ::1 using 1:40 w l t 'LF KFE', '' every ::1 using 1:41 w l t 'LF "
        "WHEEL', "
     << wheel.no_load_speed_rad_s << " dt 2 lc 'red' t 'no-load speed', "
     << -wheel.no_load_speed_rad_s << " dt 2 lc 'red' notitle\n"
     << "set ylabel 'joint torque [Nm]'\n"
     << "plot '" << csv.string()
     << "' every ::1 using 1:54 w l t 'LF HAA', '' every ::1 using 1:55 w l "
     << "t 'LF HFE', '' every ::1 using 1:56 w l t 'LF KFE', '' every ::1 using 1:57 w l t 'LF "
        "WHEEL', "
     << hfe.peak_torque_nm << " dt 2 lc 'red' t 'peak torque', " << -hfe.peak_torque_nm
     << " dt 2 lc 'red' notitle\n"
     << "set ylabel 'CoM height [m]'\nset xlabel 'time [s] (dotted: t1, t2, t3 of the plan)'\n"
     << "plot '" << csv.string() << "' every ::1 using 1:18 w l lw 2 t 'simulated', '"
     << planned.string() << "' using 1:2 w l dt 4 t 'planned' \n"
     << "unset multiplot\n";
  const std::filesystem::path script = png.string() + ".gp";
  std::ofstream(script) << gp.str();
  std::ofstream(planned, std::ios::app).close();
  // The plan file has a space separator; gnuplot's separator is per file via a temporary set.
  std::string text = gp.str();
  const std::string needle = "'" + planned.string() + "' using 1:2";
  text.replace(text.find(needle), needle.size(),
               "'< tr \" \" \",\" < " + planned.string() + "' using 1:2");
  std::ofstream(script) << text;
  const std::string cmd = "gnuplot '" + script.string() + "'";
  if (std::system(cmd.c_str()) != 0)
    throw std::runtime_error("gnuplot failed on " + script.string());
}

// Signed distance of the lowest wheel to the terrain in the plan's predicted touchdown state
// (CoM and pitch of plan.predicted.touchdown, posture q_landing): 0 if the predicted
// touchdown is a first wheel contact, negative if the wheels would already be in the ground.
double predictedTouchdownWheelGap(const wj::model::RobotModel& robot, const pl::JumpPlan& plan,
                                  const sm::Terrain& terrain) {
  sm::InitialState state;
  state.com = plan.predicted.touchdown.state;
  state.q = plan.q_landing;
  const sm::RobotPlacement placement = sm::calcPlacement(robot, state, terrain);
  double gap = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& c : sm::calcWheelCenters(robot, plan.q_landing))
    gap = std::min(gap, sm::calcTerrainDistance(terrain, placement.X_WB * c) - robot.wheelRadius());
  return gap;
}

// Where the pictures of the run go ("" = not wanted).
struct PictureFiles {
  std::string strip, gif, html;
  bool any() const { return !strip.empty() || !gif.empty() || !html.empty(); }
};

// The run as the viewers see it: Simbody's ground truth per control period, the plan's CoM path
// (the world frame is the plan's jump frame: CoM at x = 0 at the start of take-off) and the
// terrain's boxes.
wj::viz::Recording makeRecording(const std::string& title, const sm::TelemetryRecorder& recorder,
                                 const pl::JumpPlan& plan, const sm::Scenario& scenario,
                                 const pl::JumpOutcome& simulated) {
  wj::viz::Recording rec;
  rec.title = title;
  for (const sm::TelemetrySample& s : recorder.samples()) {
    wj::viz::Frame f;
    f.t = s.t;
    f.p_WB = s.p_WB;
    f.q_WB = s.q_WB;
    f.q = s.q;
    f.qd = s.qd;
    f.tau = s.tau;
    f.p_WC = s.p_WC;
    f.phase = std::string(sm::toString(s.phase));
    if (rec.frames.empty() || f.t > rec.frames.back().t) rec.frames.push_back(std::move(f));
  }
  for (const sm::Box& b : scenario.terrain.boxes) rec.boxes.push_back({b.min, b.max});
  for (int k = 0; k < plan.numSamples(); ++k)
    rec.planned_com.push_back(
        {k * plan.dt, Eigen::Vector3d(plan.centroidal[k].x, 0.0, plan.centroidal[k].z)});
  rec.jump_start_t = 0.0;
  rec.touchdown_t = simulated.touchdown.t > 0.0 ? simulated.touchdown.t : plan.t3;
  rec.liftoff_t = plan.t2;
  if (plan.t2 - plan.t1 > plan.dt) rec.front_liftoff_t = plan.t1;
  for (int k = 0; k < plan.numSamples(); ++k) {
    wj::viz::PlannedJoints p;
    p.t = k * plan.dt;
    for (int j = 0; j < wj::model::kNumJoints; ++j) {
      p.qd[j] = plan.qd(k, j);
      p.tau[j] = plan.tau(k, j);
    }
    rec.planned_joints.push_back(p);
  }
  return rec;
}

void writePictures(const PictureFiles& files, const wj::model::RobotModel& robot,
                   const wj::viz::Recording& rec) {
  if (!files.strip.empty()) wj::viz::writeSnapshotStrip(robot, rec, files.strip);
  if (!files.gif.empty()) wj::viz::writeAnimationGif(robot, rec, files.gif);
  if (!files.html.empty()) wj::viz::writeReplayPage(robot, rec, files.html);
}

// A start state other than the preset's nominal one (--start-state): what the planner plans
// from and where Simbody starts.
struct StartState {
  pl::InitialState planner;  ///< v0, pitch, pitch rate, joint positions
  sm::JointVector qd;        ///< joint velocities at t = 0 in Simbody [rad/s]
};

// Reads a strict JSON start state: exactly the keys v0 [m/s], pitch [rad, nose-up], pitch_rate
// [rad/s], q and qd (16 numbers each, jointIndex order: LF, RF, LH, RH, each HAA, HFE, KFE,
// wheel). The ranges are the planner's (InitialState::validate) and, for qd, each joint's
// no-load speed. Throws naming the field.
StartState readStartState(const std::string& path, const wj::model::RobotModel& robot) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("--start-state: cannot read " + path);
  const json j = json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) throw std::runtime_error("--start-state " + path + ": not a JSON object");
  const std::array<const char*, 5> keys = {"v0", "pitch", "pitch_rate", "q", "qd"};
  for (const auto& [key, value] : j.items())
    if (std::find_if(keys.begin(), keys.end(), [&](const char* k) { return key == k; }) ==
        keys.end())
      throw std::runtime_error("--start-state " + path + ": unknown key '" + key +
                               "' (allowed: v0, pitch, pitch_rate, q, qd)");
  const auto number = [&](const char* key) {
    if (!j.contains(key) || !j[key].is_number())
      throw std::runtime_error("--start-state " + path + ": '" + key + "' must be a number");
    return j[key].get<double>();
  };
  const auto joints = [&](const char* key) {
    if (!j.contains(key) || !j[key].is_array() || j[key].size() != wj::model::kNumJoints)
      throw std::runtime_error("--start-state " + path + ": '" + key + "' must be an array of " +
                               std::to_string(wj::model::kNumJoints) +
                               " numbers (jointIndex order)");
    sm::JointVector v;
    for (int i = 0; i < wj::model::kNumJoints; ++i) {
      if (!j[key][i].is_number())
        throw std::runtime_error("--start-state " + path + ": '" + key + "[" +
                                 robot.joints()[i].name + "]' must be a number");
      v[i] = j[key][i].get<double>();
    }
    return v;
  };
  StartState s;
  s.planner.v0 = number("v0");
  s.planner.pitch = number("pitch");
  s.planner.pitch_rate = number("pitch_rate");
  s.planner.q = joints("q");
  s.qd = joints("qd");
  s.planner.validate(robot);
  for (int i = 0; i < wj::model::kNumJoints; ++i) {
    const double limit = robot.joints()[i].actuator.no_load_speed_rad_s;
    if (!(std::abs(s.qd[i]) <= limit))
      throw std::runtime_error("--start-state " + path + ": qd[" + robot.joints()[i].name +
                               "] = " + std::to_string(s.qd[i]) + " is outside [-" +
                               std::to_string(limit) + ", " + std::to_string(limit) + "] rad/s");
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Plans a jump and verifies it in the Simbody simulation."};
  std::string task = "forward", csv_path, plan_csv_path, plot_path, planner_config, sim_config;
  std::string actuators = wj::model::kDefaultActuatorsFile;
  std::optional<double> v0;
  std::uint64_t seed = 1;
  int threads = 2;
  bool json_out = false;
  PictureFiles pictures;
  app.add_option("--task", task, "forward | forward_hw | vertical | backflip | platform");
  auto* v0_option = app.add_option("--v0", v0, "run-up speed [m/s]");
  std::string start_state_path;
  app.add_option("--start-state", start_state_path,
                 "plan from and start Simbody in this state instead of the preset's nominal one "
                 "(JSON: v0, pitch, pitch_rate, q[16], qd[16], jointIndex order; "
                 "docs/backflip.md)")
      ->excludes(v0_option);
  app.add_option("--seed", seed, "planner seed");
  app.add_option("--threads", threads, "planner threads")->check(CLI::Range(1, 64));
  app.add_option("--config", planner_config, "planner settings YAML");
  app.add_option("--actuators", actuators,
                 "actuator file of the robot (planner and simulation), in the models folder or a "
                 "path, e.g. actuators-57nm.yaml");
  app.add_option("--sim-config", sim_config, "simulation settings YAML (sim/config layout)");
  std::string executor_path;
  app.add_option("--executor", executor_path,
                 "jump executor gains YAML (config/jump_executor.yaml layout: the robot client's, "
                 "which the planning service verifies with); default: the executor's built-in "
                 "gains");
  std::string plant_path;
  app.add_option("--plant", plant_path,
                 "plant file (YAML, every key optional): the simulated robot differs from the "
                 "planner's model (docs/sim.md, 'Plant')");
  app.add_option("--csv", csv_path, "write telemetry CSV here");
  app.add_option("--plan-csv", plan_csv_path,
                 "write the plan's dense samples here (t, CoM x z pitch vx vz pitch_rate, q, qd, "
                 "tau in the telemetry's joint order)");
  std::string momentum_csv_path;
  app.add_option("--momentum-csv", momentum_csv_path,
                 "write the angular momentum about the CoM here, Simbody's against the plan's "
                 "(t, h_sim, h_plan, pitch rates; nose-up positive)");
  app.add_option("--plot", plot_path,
                 "write a PNG figure here (gnuplot; a backflip: the knees over the take-off)");
  app.add_option("--snapshots", pictures.strip,
                 "write a snapshot strip here (PNG: the robot from take-off to landing)");
  app.add_option("--gif", pictures.gif, "write a side-view animation of the run here (GIF)");
  app.add_option("--html", pictures.html, "write a 3D replay page of the run here (HTML)");
  app.add_flag("--json", json_out, "print JSON");
  int correction_rounds = 0;
  app.add_option("--liftoff-correction", correction_rounds,
                 "plan again up to this many times with the flight started from Simbody's "
                 "lift-off (docs/planner.md, 'The lift-off correction'); 0: the model alone")
      ->check(CLI::Range(0, 10));
  CLI11_PARSE(app, argc, argv);
  try {
    const auto robot = wj::model::RobotModel::loadDefault(actuators);
    const pl::JumpPlanner planner(robot, planner_config.empty()
                                             ? pl::PlannerSettings{}
                                             : pl::PlannerSettings::fromYaml(planner_config));
    std::optional<StartState> start;
    if (!start_state_path.empty()) start = readStartState(start_state_path, robot);
    pl::Scenario sc = pl::makePreset(planner, task, start ? start->planner.v0 : v0);
    if (start) sc.initial = start->planner;
    pl::PlanOptions opts;
    opts.seed = seed;
    opts.threads = threads;

    sm::VerifierSettings vs;
    if (!sim_config.empty()) vs.sim = sm::loadSimSettings(sim_config);
    if (!executor_path.empty()) vs.executor = sm::loadExecutorSettings(executor_path);
    const sm::PlantSettings plant =
        plant_path.empty() ? sm::PlantSettings{} : sm::loadPlantSettings(plant_path);
    vs.sim = sm::applyPlant(vs.sim, plant);
    const sm::Verifier verifier(robot, vs);
    sm::Scenario scenario = sm::scenarioForTask(sc.task);
    scenario.name = task;
    {
      // The plant's terrain (wall position error, take-off ground) on the scenario's.
      sm::SimSettings with_terrain = vs.sim;
      with_terrain.terrain = scenario.terrain;
      scenario.terrain = sm::applyPlant(with_terrain, plant).terrain;
    }
    // Simbody starts where the plan does, with the start state's joint velocities if given.
    const auto initialFor = [&](const pl::JumpPlan& plan) {
      sm::InitialState initial = sm::initialStateFromPlan(robot, plan);
      if (start) initial.qd = start->qd;
      return initial;
    };
    sm::LiftOffCorrectionSettings correction;
    correction.max_rounds = correction_rounds;
    // Each verification recorded: round k's is recordings[k] (the rounds verify in order, and
    // the first round without a plan ends the iteration).
    std::deque<sm::TelemetryRecorder> recordings;
    const sm::CorrectedPlan corrected = sm::planWithLiftOffCorrection(
        planner,
        [&](const pl::JumpPlan& plan) {
          return verifier.verify(plan, initialFor(plan), scenario,
                                 recordings.emplace_back().callback());
        },
        sc.task, sc.initial, opts, correction);
    const pl::PlannerResult& r = corrected.result;
    if (!r.evaluation.valid) throw std::runtime_error("the planner found no valid trajectory");
    const sm::TelemetryRecorder& recorder =
        recordings.at(static_cast<std::size_t>(corrected.chosen));
    const sm::VerificationReport& v = corrected.report;
    if (!plan_csv_path.empty()) writePlanCsv(plan_csv_path, r.plan);
    if (!momentum_csv_path.empty()) writeMomentumCsv(momentum_csv_path, robot, recorder, r.plan);
    if (csv_path.empty() && !plot_path.empty()) csv_path = plot_path + ".csv";
    if (!csv_path.empty()) {
      std::ofstream out(csv_path);
      if (!out) throw std::runtime_error("cannot write " + csv_path);
      recorder.writeCsv(out);
    }
    if (!plot_path.empty() || pictures.any()) {
      const wj::viz::Recording rec =
          makeRecording("sim_jump --task " + task, recorder, r.plan, scenario, v.measured);
      // A backflip's figure is the paper's: the knees over the take-off with their limits.
      if (sc.task.isBackflip() && !plot_path.empty())
        wj::viz::writeKneeFigure(robot, rec, plot_path);
      else if (!plot_path.empty())
        plot(plot_path, csv_path, r.plan, robot);
      writePictures(pictures, robot, rec);
    }

    const pl::JumpOutcome& p = r.evaluation.predicted;
    const pl::JumpOutcome& s = v.measured;
    std::array<double, 4> sim_torque{}, sim_speed{}, limit_torque{}, limit_speed{};
    for (int j = 0; j < wj::model::kNumJoints; ++j) {
      const int kind = j % wj::model::kJointsPerLeg;
      sim_torque[kind] = std::max(sim_torque[kind], v.joints[j].max_abs_torque_nm);
      sim_speed[kind] = std::max(sim_speed[kind], v.joints[j].max_abs_speed_rad_s);
      limit_torque[kind] = robot.joints()[j].actuator.peak_torque_nm;
      limit_speed[kind] = robot.joints()[j].actuator.no_load_speed_rad_s;
    }
    if (json_out) {
      json j;
      j["plan"] = pl::reportJson(sc, r);
      j["predicted"] = outcomeJson(p);
      j["predicted"]["touchdown"]["lowest_wheel_gap_m"] =
          predictedTouchdownWheelGap(robot, r.plan, scenario.terrain);
      j["simulated"] = outcomeJson(s);
      json failures = json::array();
      for (const sm::FailureReason f : v.failures.toVector()) failures.push_back(sm::toString(f));
      j["verification"] = {
          {"passed", v.passed},
          {"failures", failures},
          {"reasons", v.reasons},
          {"landed_upright", v.landed_upright},
          {"max_envelope_ratio", v.max_envelope_ratio},
          {"worst_envelope_joint", v.worst_envelope_joint >= 0
                                       ? json(robot.joints()[v.worst_envelope_joint].name)
                                       : json(nullptr)},
          {"max_speed_ratio", v.max_speed_ratio},
          {"apex_height_error_m", v.apex_height_error_m},
          {"touchdown_dx_error_m", v.touchdown_dx_error_m},
          {"touchdown_pitch_error_rad", v.touchdown_pitch_error_rad},
          {"max_base_z_m", v.max_base_z_m},
          {"final_pitch_rad", v.final_pitch_rad},
          {"final_rotation_rad", v.final_rotation_rad},
          {"actuators_file", actuators},
          {"final_roll_rad", v.final_roll_rad},
          {"final_base_height_m", v.final_base_height_m},
          {"nominal_base_height_m", v.nominal_base_height_m}};
      json rounds = json::array();
      const auto triple = [](const pl::LiftOffCorrection& c) {
        return json{{"vx", c.vx}, {"vz", c.vz}, {"momentum", c.momentum}};
      };
      for (const sm::CorrectionRound& round : corrected.rounds)
        rounds.push_back({{"correction", triple(round.correction)},
                          {"residual", triple(round.residual)},
                          {"residual_ratio", round.residual_ratio},
                          {"feasible", round.feasible},
                          {"passed", round.passed},
                          {"reasons", round.reasons},
                          {"solve_ms", round.solve_ms},
                          {"verify_ms", round.verify_ms}});
      j["liftoff_correction"] = {{"rounds", rounds}, {"chosen", corrected.chosen}};
      const char* kinds[4] = {"haa", "hfe", "kfe", "wheel"};
      for (int k = 0; k < 4; ++k)
        j["simulated_max"][kinds[k]] = {{"torque_nm", sim_torque[k]},
                                        {"speed_rad_s", sim_speed[k]},
                                        {"torque_limit_nm", limit_torque[k]},
                                        {"speed_limit_rad_s", limit_speed[k]}};
      std::cout << j.dump(2) << "\n";
    } else {
      std::cout << pl::reportText(sc, r) << std::fixed << std::setprecision(3)
                << "\n                         planned   simulated\n"
                << "  take-off t [s]        " << std::setw(8) << p.takeoff.t << "   "
                << std::setw(8) << s.takeoff.t << "\n  lift-off vx [m/s]     " << std::setw(8)
                << p.takeoff.state.vx << "   " << std::setw(8) << s.takeoff.state.vx
                << "\n  lift-off vz [m/s]     " << std::setw(8)
                << p.takeoff.state.vz - planner.settings().gravity * (s.takeoff.t - p.takeoff.t)
                << "   " << std::setw(8) << s.takeoff.state.vz << "  (the plan's at Simbody's t)"
                << "\n  lift-off H [kg m^2/s] " << std::setw(8) << p.takeoff.momentum << "   "
                << std::setw(8) << s.takeoff.momentum << "\n  apex CoM z [m]        "
                << std::setw(8) << p.apex.state.z << "   " << std::setw(8) << s.apex.state.z
                << "\n  apex base z [m]       " << std::setw(8) << p.apex.base_z << "   "
                << std::setw(8) << v.max_base_z_m << "\n  apex dx [m]           " << std::setw(8)
                << p.apex.state.x << "   " << std::setw(8) << s.apex.state.x
                << "\n  touchdown t [s]       " << std::setw(8) << p.touchdown.t << "   "
                << std::setw(8) << s.touchdown.t << "\n  touchdown dx [m]      " << std::setw(8)
                << p.touchdown.state.x << "   " << std::setw(8) << s.touchdown.state.x
                << "\n  touchdown pitch [rad] " << std::setw(8) << p.touchdown.state.pitch << "   "
                << std::setw(8) << s.touchdown.state.pitch << "\n  obstacle clearance [m] "
                << std::setw(7) << p.min_obstacle_clearance << "   " << std::setw(8)
                << s.min_obstacle_clearance << "\n\n  simulated max |tau| / limit [Nm]:  haa "
                << sim_torque[0] << "/" << limit_torque[0] << "  hfe " << sim_torque[1] << "/"
                << limit_torque[1] << "  kfe " << sim_torque[2] << "/" << limit_torque[2]
                << "  wheel " << sim_torque[3] << "/" << limit_torque[3]
                << "\n  simulated max |qd| / limit [rad/s]: haa " << sim_speed[0] << "/"
                << limit_speed[0] << "  hfe " << sim_speed[1] << "/" << limit_speed[1] << "  kfe "
                << sim_speed[2] << "/" << limit_speed[2] << "  wheel " << sim_speed[3] << "/"
                << limit_speed[3] << "\n  robot: " << actuators << " (knee peak " << limit_torque[2]
                << " Nm); rotation at touchdown " << s.touchdown.state.pitch << " rad, at the end "
                << v.final_rotation_rad << " rad"
                << "\n  verification: " << (v.passed ? "PASSED" : "FAILED") << "\n";
      for (const auto& reason : v.reasons) std::cout << "    - " << reason << "\n";
      if (corrected.rounds.size() > 1 || correction_rounds > 0) {
        std::cout << "  lift-off correction (vx, vz [m/s], H [kg m^2/s]; chosen: round "
                  << corrected.chosen << "):\n";
        for (std::size_t k = 0; k < corrected.rounds.size(); ++k) {
          const sm::CorrectionRound& c = corrected.rounds[k];
          std::cout << std::setprecision(4) << "    round " << k << ": correction ("
                    << c.correction.vx << ", " << c.correction.vz << ", " << c.correction.momentum
                    << "), Simbody - plan (" << c.residual.vx << ", " << c.residual.vz << ", "
                    << c.residual.momentum << "), " << std::setprecision(2) << c.residual_ratio
                    << " x tolerance, " << (c.feasible ? "feasible" : "infeasible") << ", "
                    << (c.passed ? "verified" : "not verified") << "\n";
          for (const std::string& why : c.reasons) std::cout << "      - " << why << "\n";
        }
      }
      if (!csv_path.empty()) std::cout << "  telemetry: " << csv_path << "\n";
      if (!plot_path.empty()) std::cout << "  figure: " << plot_path << "\n";
      for (const auto& [what, path] : {std::pair{"snapshot strip", pictures.strip},
                                       {"animation", pictures.gif},
                                       {"3D replay", pictures.html}})
        if (!path.empty()) std::cout << "  " << what << ": " << path << "\n";
    }
    return v.passed ? 0 : 3;
  } catch (const std::exception& e) {
    std::cerr << "sim_jump: " << e.what() << "\n";
    return 2;
  }
}
