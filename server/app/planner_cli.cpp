// planner_cli: the planning service from the command line, for people.
//   planner_cli plan --v0 3 --dx 2.1 --height 0.36 --event touchdown --obstacle 1.2,1.3,0.25
//   planner_cli stats
//   planner_cli warm --v0-min 0 --v0-max 3 --v0-step 0.05 --dx 0 --height 0.6
//   planner_cli plan --v0 3 ... --html plan.html --snapshots plan.png   (the plan alone, drawn)
// Exit status: 0 answered (and feasible for plan), 3 answered but infeasible, 1 RPC error,
// 2 bad command line.
#include <google/protobuf/util/json_util.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include "planner_client/planner_client.h"
#include "robot_model/robot_model.h"
#include "viz/replay_page.h"
#include "viz/side_view.h"

namespace v1 = wheeljump::planner::v1;

namespace {

std::string toJson(const google::protobuf::Message& m) {
  std::string out;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  (void)google::protobuf::util::MessageToJsonString(m, &out, options);
  return out;
}

// Line `line` (1-based) of a request log: one PlanJumpRequest in JSON per line.
v1::PlanJumpRequest readRequest(const std::string& path, int line) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("--request: cannot open " + path);
  std::string text;
  for (int i = 0; i < line; ++i)
    if (!std::getline(in, text))
      throw std::invalid_argument("--request-line: " + path + " has fewer than " +
                                  std::to_string(line) + " lines");
  v1::PlanJumpRequest r;
  const auto status = google::protobuf::util::JsonStringToMessage(text, &r);
  if (!status.ok())
    throw std::invalid_argument("--request: line " + std::to_string(line) + " of " + path +
                                " is not a PlanJumpRequest: " + std::string(status.message()));
  return r;
}

std::vector<double> parseList(const std::string& text, std::size_t n, const std::string& flag) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    std::size_t used = 0;
    double x = 0.0;
    try {
      x = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size())
      throw std::invalid_argument(flag + ": '" + item + "' is not a number");
    v.push_back(x);
  }
  if (v.size() != n)
    throw std::invalid_argument(flag + " takes " + std::to_string(n) + " comma-separated numbers");
  return v;
}

struct TaskArgs {
  double dx = 0.0, height = 0.6, pitch = 0.0;
  std::string event = "apex", mode = "simultaneous", obstacle;

  void add(CLI::App& app) {
    app.add_option("--dx", dx, "target CoM displacement along x [m]")->capture_default_str();
    app.add_option("--height", height, "target CoM height at the event [m]")->capture_default_str();
    app.add_option("--pitch", pitch, "target pitch change, nose-up positive [rad]")
        ->capture_default_str();
    app.add_option("--event", event, "apex | touchdown")->capture_default_str();
    app.add_option("--mode", mode, "simultaneous | two-step")->capture_default_str();
    app.add_option("--obstacle", obstacle, "box x_min,x_max,height [m]");
  }
  v1::JumpTask build() const {
    v1::JumpTask t;
    t.set_target_dx_m(dx);
    t.set_target_height_m(height);
    t.set_target_pitch_change_rad(pitch);
    if (event != "apex" && event != "touchdown")
      throw std::invalid_argument("--event must be apex or touchdown");
    t.set_event(event == "apex" ? v1::TARGET_EVENT_APEX : v1::TARGET_EVENT_TOUCHDOWN);
    if (mode != "simultaneous" && mode != "two-step")
      throw std::invalid_argument("--mode must be simultaneous or two-step");
    t.set_takeoff_mode(mode == "simultaneous" ? v1::TAKEOFF_MODE_SIMULTANEOUS
                                              : v1::TAKEOFF_MODE_TWO_STEP);
    if (!obstacle.empty()) {
      const auto o = parseList(obstacle, 3, "--obstacle");
      t.mutable_obstacle()->set_x_min_m(o[0]);
      t.mutable_obstacle()->set_x_max_m(o[1]);
      t.mutable_obstacle()->set_height_m(o[2]);
    }
    return t;
  }
};

// The plan alone as the viewers see it: the robot placed by the planned CoM, pitch and joint
// references (the planner's rigid-body placement), the obstacle of the task. Frames end at the
// planned touchdown; their CoM path is the plan's (no second, "planned" path).
wj::viz::Recording planRecording(const wj::model::RobotModel& robot, const v1::Plan& plan,
                                 const v1::JumpTask& task) {
  constexpr int kJ = wj::model::kNumJoints;
  const v1::JointTrajectory& joints = plan.joints();
  const int n = std::min(plan.centroidal_trajectory_size(), static_cast<int>(joints.num_samples()));
  if (n < 2 || joints.positions_rad_size() < n * kJ)
    throw std::runtime_error("the answer has no dense trajectory to draw");
  wj::viz::Recording rec;
  rec.title = "planner_cli plan";
  rec.source = "planned";
  const v1::PhaseTimes& pt = plan.phase_times();
  for (int k = 0; k < n; ++k) {
    const v1::CentroidalSample& c = plan.centroidal_trajectory(k);
    Eigen::VectorXd q(kJ);
    for (int j = 0; j < kJ; ++j) q[j] = joints.positions_rad(k * kJ + j);
    wj::viz::Frame f =
        wj::viz::makePlanarFrame(robot, c.t_s(), c.com_x_m(), c.com_z_m(), c.pitch_rad(), q);
    for (int j = 0; j < kJ; ++j) {
      if (joints.torques_nm_size() >= n * kJ) f.tau[j] = joints.torques_nm(k * kJ + j);
      if (joints.velocities_rad_s_size() >= n * kJ) f.qd[j] = joints.velocities_rad_s(k * kJ + j);
    }
    f.phase = c.t_s() < pt.t1_s() ? "four wheels" : c.t_s() < pt.t2_s() ? "hind wheels" : "flight";
    if (!rec.frames.empty() && !(f.t > rec.frames.back().t)) continue;
    rec.frames.push_back(std::move(f));
  }
  if (task.has_obstacle())
    rec.boxes.push_back(
        {Eigen::Vector3d(task.obstacle().x_min_m(), -1.0, 0.0),
         Eigen::Vector3d(task.obstacle().x_max_m(), 1.0, task.obstacle().height_m())});
  rec.jump_start_t = 0.0;
  rec.touchdown_t = pt.t3_s();
  return rec;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Command-line client of planner_server (wheeljump.planner.v1.JumpPlanner)."};
  app.require_subcommand(1);
  wj::client::ClientOptions options;
  int deadline_ms = 10000;
  std::string ca, cert, key;
  app.add_option("--target", options.target, "server host:port")->capture_default_str();
  app.add_option("--deadline-ms", deadline_ms, "deadline of the call [ms]")
      ->capture_default_str()
      ->check(CLI::Range(1, 3600000));
  app.add_option("--ca", ca, "TLS: CA certificate that signed the server's (PEM)");
  app.add_option("--cert", cert, "mutual TLS: client certificate (PEM)");
  app.add_option("--key", key, "mutual TLS: client key (PEM)");

  auto* plan = app.add_subcommand("plan", "plan one jump and print the answer");
  TaskArgs plan_task;
  plan_task.add(*plan);
  double v0 = 0.0, hfe = 1.0, kfe = -2.0;
  std::uint64_t seed = 0;
  unsigned candidates = 0;
  bool skip_verification = false, full = false;
  std::string request_id = "planner_cli", html, snapshots;
  plan->add_option("--v0", v0, "run-up speed along the heading [m/s]")->capture_default_str();
  plan->add_option("--hfe", hfe, "HFE angle of every leg at take-off [rad]")->capture_default_str();
  plan->add_option("--kfe", kfe, "KFE angle of every leg at take-off [rad]")->capture_default_str();
  plan->add_option("--seed", seed, "DE seed (0: the server's)")->capture_default_str();
  plan->add_option("--candidates", candidates, "candidates to verify (0: the server's)")
      ->capture_default_str();
  plan->add_flag("--skip-verification", skip_verification, "no multibody verification");
  plan->add_flag("--full", full, "print the whole response, dense trajectories included");
  plan->add_option("--request-id", request_id, "request id echoed by the server")
      ->capture_default_str();
  plan->add_option("--html", html, "write a 3D page that plays the plan (HTML)");
  plan->add_option("--snapshots", snapshots, "write a snapshot strip of the plan (PNG)");
  std::string request_file;
  int request_line = 1;
  plan->add_option("--request", request_file,
                   "replay a logged request (robot_client --request-log: one JSON request per "
                   "line) instead of building one from the options above; --seed and "
                   "--candidates still override its budget when given");
  plan->add_option("--request-line", request_line, "which line of --request (1 = the first)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);

  auto* stats = app.add_subcommand("stats", "print the server's counters and latencies");

  auto* warm = app.add_subcommand("warm", "precompute a grid of run-up speeds");
  TaskArgs warm_task;
  warm_task.add(*warm);
  double v0_min = 0.0, v0_max = 1.0, v0_step = 0.05;
  warm->add_option("--v0-min", v0_min, "first run-up speed [m/s]")->capture_default_str();
  warm->add_option("--v0-max", v0_max, "last run-up speed [m/s]")->capture_default_str();
  warm->add_option("--v0-step", v0_step, "grid step [m/s]")->capture_default_str();

  CLI11_PARSE(app, argc, argv);
  try {
    if (!ca.empty()) {
      options.use_tls = true;
      options.tls.root_ca_file = ca;
      options.tls.cert_chain_file = cert;
      options.tls.private_key_file = key;
    }
    const auto deadline = std::chrono::milliseconds(deadline_ms);
    wj::client::PlannerClient client(options);

    if (plan->parsed()) {
      v1::PlanJumpRequest r;
      if (!request_file.empty()) {
        r = readRequest(request_file, request_line);
        if (seed != 0) r.mutable_budget()->set_seed(seed);
        if (candidates != 0) r.mutable_budget()->set_max_verified_candidates(candidates);
        if (skip_verification) r.mutable_budget()->set_skip_verification(true);
      } else {
        auto* s = r.mutable_state();
        s->mutable_base_orientation_w()->set_w(1.0);
        s->mutable_base_linear_velocity_w_m_s()->set_x(v0);
        for (int leg = 0; leg < 4; ++leg) {
          for (const double q : {0.0, hfe, kfe, 0.0}) s->add_joint_positions_rad(q);
          for (int j = 0; j < 4; ++j) s->add_joint_velocities_rad_s(0.0);
        }
        *r.mutable_task() = plan_task.build();
        r.mutable_budget()->set_seed(seed);
        r.mutable_budget()->set_max_verified_candidates(candidates);
        r.mutable_budget()->set_skip_verification(skip_verification);
        r.set_request_id(request_id);
      }
      const bool draw = !html.empty() || !snapshots.empty();
      if (draw) r.set_trajectory_format(v1::TRAJECTORY_FORMAT_DENSE);
      const auto result = client.planJump(r, deadline).get();
      if (!result.ok()) {
        std::cerr << "planner_cli: PlanJump failed: " << result.status.error_code() << " "
                  << result.status.error_message() << "\n";
        return 1;
      }
      if (draw) {
        const auto robot = wj::model::RobotModel::loadDefault();
        const wj::viz::Recording rec = planRecording(robot, result.response.plan(), r.task());
        if (!html.empty()) wj::viz::writeReplayPage(robot, rec, html);
        if (!snapshots.empty()) wj::viz::writeSnapshotStrip(robot, rec, snapshots);
      }
      v1::PlanJumpResponse shown = result.response;
      if (!full) {
        // The dense trajectories are thousands of numbers; keep the summary readable.
        shown.mutable_plan()->clear_centroidal_trajectory();
        auto* j = shown.mutable_plan()->mutable_joints();
        j->clear_positions_rad();
        j->clear_velocities_rad_s();
        j->clear_torques_nm();
      }
      std::cout << toJson(shown) << "\n";
      return result.response.feasibility().feasible() ? 0 : 3;
    }
    if (stats->parsed()) {
      const auto result = client.getStats(deadline).get();
      if (!result.ok()) {
        std::cerr << "planner_cli: GetStats failed: " << result.status.error_message() << "\n";
        return 1;
      }
      std::cout << toJson(result.response) << "\n";
      return 0;
    }
    v1::WarmCacheRequest w;
    *w.mutable_task() = warm_task.build();
    w.set_v0_min_m_s(v0_min);
    w.set_v0_max_m_s(v0_max);
    w.set_v0_step_m_s(v0_step);
    std::promise<wj::client::WarmResult> done;
    client.warmCache(
        w,
        [](const v1::WarmCacheProgress& p) {
          std::cout << p.done() << "/" << p.total() << " v0 " << p.v0_m_s()
                    << " m/s: " << (p.feasible() ? "feasible" : "infeasible") << " ("
                    << v1::PlanSource_Name(p.source()) << ")" << std::endl;
        },
        [&done](wj::client::WarmResult r) { done.set_value(std::move(r)); }, deadline);
    const auto result = done.get_future().get();
    if (!result.ok()) {
      std::cerr << "planner_cli: WarmCache failed: " << result.status.error_message() << "\n";
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "planner_cli: " << e.what() << "\n";
    return 2;
  }
}
