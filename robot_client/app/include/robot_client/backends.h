#pragma once
/// @file What the robot client runs on: the Simbody robot (optionally through emulated CAN
/// frames) or MIT-mode motors on SocketCAN. The control loop sees a model::RobotInterface
/// either way; only the simulated backend can observe the ground truth for the report.

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "nmpc/locomotion_controller.h"
#include "robot_client/client_settings.h"
#include "robot_model/robot_interface.h"
#include "sim/plant.h"

namespace wj::sim {
struct GroundTruth;
}

namespace wj::robot_client {

class ControlLoop;
class RunRecorder;
struct FaultSource;
struct RangeSensor;

class Backend {
 public:
  virtual ~Backend() = default;
  /// The hardware-shaped interface the loop drives.
  virtual model::RobotInterface& robot() = 0;
  /// Motor faults (CAN backends), or null.
  virtual const FaultSource* faults() const = 0;
  /// Where the base starts (the robot's known start position in W) [m].
  virtual Eigen::Vector3d startPosition() const = 0;
  /// After each period: hand the ground truth to the recorder (simulation only).
  virtual void observe(const ControlLoop& loop, RunRecorder& recorder) = 0;
  /// "sim", "sim-via-can" or "can".
  virtual std::string name() const = 0;
  /// The forward range sensor, or null.
  virtual RangeSensor* rangeSensor() { return nullptr; }
  /// CAN traffic and quantisation notes for the summary ("" when not on CAN).
  virtual std::string canReport() const { return {}; }
};

/// The Simbody robot standing in the NMPC's nominal posture at the origin, on flat ground with
/// the scenario's wall; sensor noise seeded with `seed`. `via_can`: every command and
/// measurement crosses the in-process CAN bus as MIT-mode frames to motor emulators. `plant`
/// perturbs the simulated robot only (sim/plant.h): the controllers and the estimator's start
/// keep the nominal world; the range sensor measures the real walls (where the plant's
/// wall_position_error_m moved them) plus the plant's range_bias_m.
std::unique_ptr<Backend> makeSimBackend(const model::RobotModel& robot,
                                        const nmpc::LocomotionController& controller,
                                        const ScenarioSettings& scenario, std::uint64_t seed,
                                        bool noise, bool via_can,
                                        const sim::PlantSettings& plant = {});

/// MIT-mode motors on four SocketCAN interfaces (one per leg, LF RF LH RH). Throws
/// can::CanError with the reason when SocketCAN is unavailable (no PF_CAN in the kernel, no
/// such interface) and std::runtime_error because no hardware IMU driver exists yet.
std::unique_ptr<Backend> makeCanBackend(const model::RobotModel& robot,
                                        const std::vector<std::string>& interfaces);

}  // namespace wj::robot_client
