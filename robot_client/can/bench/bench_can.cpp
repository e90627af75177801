// bench_can: cost of the CAN path, as JSON on stdout:
//   codec            encode + decode of one command and one reply [ns], mean over a batch;
//   can_robot        CanRobot::write (16 commands) and CanRobot::read (16 replies) on the
//                    in-process buses with the emulators answering: median / p99 / max [us];
//   sim_via_can      one period (read, write, advance) of SimViaCan against SimRobot directly,
//                    standing: median [us] and the overhead of going through CAN.
// Times are wall clock of the calling thread (steady_clock) on a shared machine: read the
// medians; the tails include preemption.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <iostream>
#include <optional>
#include <vector>

#include "can/can_bus.h"
#include "can/can_robot.h"
#include "can/mit_codec.h"
#include "can/motor_emulator.h"
#include "can/sim_via_can.h"
#include "sim/reference_plans.h"
#include "sim/statics.h"

namespace {

using namespace wj;
using namespace wj::can;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

double us(Clock::duration d) {
  return std::chrono::duration<double, std::micro>(d).count();
}

json summary(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const auto at = [&](double q) {
    return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5)];
  };
  return {{"median", at(0.5)}, {"p99", at(0.99)}, {"max", v.back()}, {"samples", v.size()}};
}

json benchCodec(long n) {
  const MitLimits l;
  CanFrame f;
  MitCommand c;
  MitReply r;
  double sink = 0.0;
  const auto t0 = Clock::now();
  for (long k = 0; k < n; ++k) {
    const double x = 1e-4 * static_cast<double>(k % 10000);
    encodeCommand(l, 1, {x, -x, 100.0 + x, 1.0, x}, f);
    decodeCommand(l, f, c);
    encodeReply(l, 0, 1, {x, x, -x}, f);
    decodeReply(l, f, r);
    sink += c.p_des + r.state.t;
  }
  const double ns = 1e3 * us(Clock::now() - t0) / static_cast<double>(n);
  return {{"ns_per_command_and_reply_round_trip", ns}, {"checksum", sink}};
}

class ZeroImu final : public ImuSource {
 public:
  bool read(model::ImuReading&) override { return true; }
};

json benchCanRobot(const model::RobotModel& m, int periods) {
  const CanRobotSettings s;
  std::array<std::optional<InProcessCanBus>, model::kNumLegs> buses;
  std::array<std::optional<MitMotorEmulator>, model::kNumJoints> motors;
  std::array<CanBus*, model::kNumLegs> sides{};
  for (int leg = 0; leg < model::kNumLegs; ++leg) {
    buses[leg].emplace(64);
    sides[leg] = &buses[leg]->robotSide();
  }
  for (int j = 0; j < model::kNumJoints; ++j)
    motors[j].emplace(buses[j / 4]->motorSide(),
                      MitMotorConfig{s.motors[j].can_id, s.host_can_id, s.limitsOf(j), j % 4 == 3});
  ZeroImu imu;
  CanRobot robot(m, s, sides, imu);
  const auto service = [&](double phase) {
    for (int leg = 0; leg < model::kNumLegs; ++leg) {
      CanFrame f;
      while (buses[leg]->motorSide().receive(f))
        for (int k = 0; k < 4; ++k)
          if (motors[leg * 4 + k]->handle(f)) break;
    }
    for (auto& motor : motors) motor->respond({phase, 1.0, 2.0});
  };
  robot.enable();
  service(0.0);
  model::SensorData out;
  model::JointCommands c{};
  std::vector<double> write_us, read_us;
  for (int k = 0; k < periods; ++k) {
    for (auto& jc : c) jc = {0.001 * k, 0.5, 100.0, 1.0, 3.0};
    const auto t0 = Clock::now();
    robot.write(c);
    const auto t1 = Clock::now();
    service(0.001 * k);
    robot.advance();
    const auto t2 = Clock::now();
    robot.read(out);
    const auto t3 = Clock::now();
    write_us.push_back(us(t1 - t0));
    read_us.push_back(us(t3 - t2));
  }
  return {
      {"write_us", summary(write_us)}, {"read_us", summary(read_us)}, {"faults", robot.hasFault()}};
}

json benchSimViaCan(const model::RobotModel& m, int periods) {
  const sim::SimSettings settings;
  const sim::JointVector q0 = sim::standingPosture(m, 0.36);
  const sim::StandingStatics st = sim::calcStandingStatics(m, q0, settings.gravity_m_s2);
  model::JointCommands hold{};
  for (int j = 0; j < model::kNumJoints; ++j)
    hold[j] = (j % 4 == 3) ? model::JointCommand{0.0, 0.0, 0.0, 1.0, 0.0}
                           : model::JointCommand{q0[j], 0.0, 400.0, 4.0, st.tau[j]};
  sim::RobotPlacement p;
  p.q = q0;
  p.X_WB.translation().z() = st.base_height_m;
  const auto run = [&](model::RobotInterface& robot) {
    std::vector<double> period_us;
    model::SensorData out;
    for (int k = 0; k < periods; ++k) {
      const auto t0 = Clock::now();
      robot.read(out);
      robot.write(hold);
      robot.advance();
      period_us.push_back(us(Clock::now() - t0));
    }
    return period_us;
  };
  sim::SimRobot direct(m, settings);
  direct.reset(p);
  SimViaCan via(m, settings, CanRobotSettings{});
  via.reset(p);
  const std::vector<double> d = run(direct);
  const std::vector<double> v = run(via);
  json out = {{"sim_robot_period_us", summary(d)}, {"sim_via_can_period_us", summary(v)}};
  out["overhead_median_us"] = out["sim_via_can_period_us"]["median"].get<double>() -
                              out["sim_robot_period_us"]["median"].get<double>();
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("bench_can: cost of the CAN path (JSON on stdout)");
  int periods = 20000;
  int sim_periods = 2000;
  app.add_option("--periods", periods, "CanRobot periods")->check(CLI::PositiveNumber);
  app.add_option("--sim-periods", sim_periods, "SimViaCan periods")->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  const model::RobotModel m = model::RobotModel::loadDefault();
  json result;
  result["codec"] = benchCodec(1000000);
  result["can_robot"] = benchCanRobot(m, periods);
  result["sim_via_can"] = benchSimViaCan(m, sim_periods);
  std::cout << result.dump(2) << std::endl;
  return 0;
}
