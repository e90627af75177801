#include "robot_client/backends.h"

#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "can/can_bus.h"
#include "can/can_robot.h"
#include "can/can_settings.h"
#include "can/sim_via_can.h"
#include "nmpc_sim/closed_loop.h"
#include "robot_client/control_loop.h"
#include "robot_client/run_report.h"
#include "sim/sim_robot.h"
#include "sim/verifier.h"

namespace wj::robot_client {

namespace {

sim::SimSettings simSettings(const ScenarioSettings& scenario, std::uint64_t seed, bool noise) {
  sim::SimSettings s;
  s.noise.enabled = noise;
  s.noise.seed = seed;
  // Walls to clear (one, or a course of several), or a platform to land and drive on
  // (terrain, not an obstacle).
  const auto box = scenario.landsOnWall() ? sim::Terrain::platform : sim::Terrain::wall;
  s.terrain = sim::Terrain::flat();
  if (scenario.has_wall)
    for (const double x : scenario.wall_x_m) {
      const sim::Terrain one = box(x, x + scenario.wall_thickness_m, scenario.wall_height_m);
      s.terrain.boxes.insert(s.terrain.boxes.end(), one.boxes.begin(), one.boxes.end());
    }
  return s;
}

// A forward range sensor on the simulated robot: the true distance from the base origin to the
// near face of the first obstacle ahead (the simulated terrain's, where the plant put it), plus
// the plant's range bias and seeded Gaussian noise; in range between 0.05 m and 6 m.
class SimRangeSensor final : public RangeSensor {
 public:
  static constexpr double kNoiseStd = 0.01;  // [m], a depth camera at a few metres
  static constexpr double kMaxRange = 6.0;   // [m]

  // `near_faces_m`: the real near faces, increasing.
  SimRangeSensor(const sim::SimRobot& sim, const std::vector<double>& near_faces_m, double bias_m,
                 std::uint64_t seed)
      : sim_(sim),
        near_faces_(near_faces_m),
        bias_(bias_m),
        rng_(seed ^ 0x5EEDu),
        noise_(0.0, kNoiseStd) {}
  bool read(double& distance_m) override {
    sim_.calcGroundTruth(gt_, false);
    const double x = gt_.X_WB.translation().x();
    for (const double face : near_faces_) {
      const double d = face - x;
      if (d < 0.05) continue;
      if (d > kMaxRange) return false;
      distance_m = d + bias_ + noise_(rng_);
      return true;
    }
    return false;
  }
  double noiseStd() const override { return kNoiseStd; }

 private:
  const sim::SimRobot& sim_;
  std::vector<double> near_faces_;
  double bias_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> noise_;
  sim::GroundTruth gt_;
};

// The Simbody robot, driven directly or through the in-process CAN bus (SimViaCan), standing
// in the NMPC's nominal posture at the origin.
class SimBackend final : public Backend, public FaultSource {
 public:
  SimBackend(const model::RobotModel& robot, const nmpc::LocomotionController& controller,
             const ScenarioSettings& scenario, std::uint64_t seed, bool noise, bool via_can,
             const sim::PlantSettings& plant) {
    const sim::SimSettings nominal = simSettings(scenario, seed, noise);
    const sim::SimSettings settings = sim::applyPlant(nominal, plant);
    if (via_can)
      via_can_.emplace(robot, settings, can::loadCanRobotSettings(can::defaultCanConfigFile()));
    else
      direct_.emplace(robot, settings);
    placement_ = nmpc::sim_loop::standingPlacement(robot, controller, settings.terrain);
    // Where the robot believes it starts: on the nominal ground.
    start_ =
        nmpc::sim_loop::standingPlacement(robot, controller, nominal.terrain).X_WB.translation();
    if (via_can_)
      via_can_->reset(placement_);
    else
      direct_->reset(placement_);
    if (scenario.has_wall) {
      // Where the walls really are: applyPlant() moves obstacles by the wall error (a
      // platform is terrain and stays).
      std::vector<double> faces = scenario.wall_x_m;
      if (!scenario.landsOnWall())
        for (double& x : faces) x += plant.wall_position_error_m;
      range_.emplace(sim(), faces, plant.range_bias_m, seed);
    }
  }
  RangeSensor* rangeSensor() override { return range_ ? &*range_ : nullptr; }
  model::RobotInterface& robot() override {
    return via_can_ ? static_cast<model::RobotInterface&>(*via_can_) : *direct_;
  }
  const FaultSource* faults() const override { return via_can_ ? this : nullptr; }
  bool hasFault() const override { return via_can_ && via_can_->canRobot().hasFault(); }
  Eigen::Vector3d startPosition() const override { return start_; }
  void observe(const ControlLoop& loop, RunRecorder& recorder) override {
    sim().calcGroundTruth(gt_, false);
    recorder.onTruth(gt_, loop);
  }
  std::string name() const override { return via_can_ ? "sim-via-can" : "sim"; }
  std::string canReport() const override {
    if (!via_can_) return {};
    std::ostringstream s;
    std::uint64_t sent = 0, received = 0, dropped = 0;
    for (int leg = 0; leg < model::kNumLegs; ++leg) {
      const can::CanBusStats st = via_can_->bus(leg).robotSide().stats();
      sent += st.sent;
      received += st.received;
      dropped += st.dropped;
    }
    s << "frames sent " << sent << ", received " << received << ", dropped " << dropped
      << ", motor fault " << (via_can_->canRobot().hasFault() ? "yes" : "no");
    return s.str();
  }

 private:
  sim::SimRobot& sim() const { return via_can_ ? via_can_->sim() : *direct_; }

  // Exactly one is set. Mutable: the CAN side reports faults and counters through non-const
  // calls, and the range sensor reads the simulator's ground truth.
  mutable std::optional<sim::SimRobot> direct_;
  mutable std::optional<can::SimViaCan> via_can_;
  sim::RobotPlacement placement_;
  Eigen::Vector3d start_ = Eigen::Vector3d::Zero();
  sim::GroundTruth gt_;
  std::optional<SimRangeSensor> range_;
};

}  // namespace

std::unique_ptr<Backend> makeSimBackend(const model::RobotModel& robot,
                                        const nmpc::LocomotionController& controller,
                                        const ScenarioSettings& scenario, std::uint64_t seed,
                                        bool noise, bool via_can, const sim::PlantSettings& plant) {
  return std::make_unique<SimBackend>(robot, controller, scenario, seed, noise, via_can, plant);
}

std::unique_ptr<Backend> makeCanBackend(const model::RobotModel& robot,
                                        const std::vector<std::string>& interfaces) {
  (void)robot;
  if (interfaces.size() != static_cast<std::size_t>(model::kNumLegs))
    throw std::invalid_argument("--can-interfaces needs 4 interfaces (LF RF LH RH)");
  // Opening the buses first reports a missing SocketCAN (no PF_CAN) or interface clearly.
  std::vector<std::unique_ptr<can::SocketCanBus>> buses;
  for (const std::string& name : interfaces)
    buses.push_back(std::make_unique<can::SocketCanBus>(name));
  throw std::runtime_error(
      "the CAN backend has no hardware IMU driver yet (can::ImuSource): the buses open, but the "
      "loop cannot run without an IMU");
}

}  // namespace wj::robot_client
