#pragma once
/// @file Closed loop of the locomotion controller and the Simbody robot, shared by the
/// closed-loop tests and bench_mpc (target wj::nmpc_sim_loop, header-only): 1 kHz joint
/// control, the MPC synchronously every `mpc_period_s` of simulated time; the state comes from
/// the simulator's ground truth (no state estimator yet).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>
#include <vector>

#include "nmpc/locomotion_controller.h"
#include "sim/sim_robot.h"
#include "sim/verifier.h"

namespace wj::nmpc::sim_loop {

/// One sample per control period.
struct LoopSample {
  double t = 0.0;
  double speed = 0.0;   ///< base velocity along the travel direction [m/s]
  double height = 0.0;  ///< base origin above the terrain along its normal [m]
  double roll = 0.0;    ///< [rad]
  double pitch = 0.0;   ///< relative to the terrain along the heading [rad]
  double x = 0.0;       ///< base x [m]
};

/// Outcome of a run.
struct LoopResult {
  bool fell = false;
  double fell_at = -1.0;
  std::vector<LoopSample> samples;
  std::vector<double> mpc_wall_ms;  ///< wall time of every updateMpc()
  std::vector<SqpStats> mpc_stats;  ///< solver statistics of every updateMpc()
  double wall_s = 0.0;              ///< whole run
  int mpc_calls = 0;
};

/// The robot standing still at the origin on `terrain` in the controller's nominal posture.
inline sim::RobotPlacement standingPlacement(const model::RobotModel& robot,
                                             const LocomotionController& c,
                                             const sim::Terrain& terrain) {
  sim::InitialState init;
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int j = 0; j < kLegDofs; ++j)
      init.q[robotJointIndex(leg, j)] = c.model().nominalJoints()[kLegDofs * leg + j];
  init.com.z = c.model().settings().nominal_base_height_m + c.model().comOffset().z() - 1e-3;
  return sim::calcPlacement(robot, init, terrain);
}

/// Runs the loop for `duration_s` from `placement`; `on_tick(t, controller)` may change
/// commands and gaits.
template <class OnTick>
LoopResult runClosedLoopFrom(const model::RobotModel& robot, LocomotionController& controller,
                             const sim::SimSettings& sim_settings,
                             const sim::RobotPlacement& placement, double duration_s,
                             double mpc_period_s, double travel_slope_rad, OnTick&& on_tick) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  LoopResult result;
  sim::SimRobot robot_sim(robot, sim_settings);
  robot_sim.reset(placement);
  const int steps = static_cast<int>(std::lround(duration_s / robot_sim.controlPeriod()));
  const int mpc_every =
      std::max(1, static_cast<int>(std::lround(mpc_period_s / robot_sim.controlPeriod())));
  result.samples.reserve(static_cast<std::size_t>(steps));
  result.mpc_wall_ms.reserve(static_cast<std::size_t>(steps / mpc_every + 1));
  result.mpc_stats.reserve(static_cast<std::size_t>(steps / mpc_every + 1));
  sim::GroundTruth gt;
  model::SensorData sensors;
  model::JointCommands commands{};
  const Eigen::Vector3d direction(std::cos(travel_slope_rad), 0.0, -std::sin(travel_slope_rad));
  const Eigen::Vector3d normal(std::sin(travel_slope_rad), 0.0, std::cos(travel_slope_rad));
  double yaw = 0.0;
  for (int k = 0; k < steps; ++k) {
    robot_sim.calcGroundTruth(gt, false);
    robot_sim.read(sensors);
    const double t = gt.t;
    on_tick(t, controller);
    const State x = controller.model().calcStateFromBase(gt.X_WB, gt.v_WB, gt.w_WB, gt.q, yaw);
    yaw = x[state_index::kTheta + 2];
    if (k % mpc_every == 0) {
      const auto t0 = Clock::now();
      controller.updateMpc(t, x);
      result.mpc_wall_ms.push_back(
          std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      result.mpc_stats.push_back(controller.solver().stats());
      // First cycle: a few more iterations at the same instant (cold start).
      if (k == 0)
        for (int i = 0; i < 4; ++i) controller.updateMpc(t, x);
      ++result.mpc_calls;
    }
    controller.calcCommands(t, x, sensors, commands);
    robot_sim.write(commands);
    robot_sim.advance();

    LoopSample s;
    s.t = t;
    const Eigen::Vector3d p = gt.X_WB.translation();
    s.x = p.x();
    s.speed = gt.v_WB.dot(direction);
    const double ground = sim_settings.terrain.heightAt(p.x(), p.y());
    s.height = (p.z() - ground) * normal.z();
    s.roll = x[state_index::kTheta];
    s.pitch = x[state_index::kTheta + 1] - travel_slope_rad;
    result.samples.push_back(s);
    if (!result.fell && (gt.base_in_contact || gt.legs_in_contact || std::abs(s.roll) > 0.6 ||
                         std::abs(s.pitch) > 0.6 || s.height < 0.15)) {
      result.fell = true;
      result.fell_at = t;
      break;
    }
  }
  result.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

/// Runs the loop for `duration_s` from standing still in the controller's nominal posture.
template <class OnTick>
LoopResult runClosedLoop(const model::RobotModel& robot, LocomotionController& controller,
                         const sim::SimSettings& sim_settings, double duration_s,
                         double mpc_period_s, double travel_slope_rad, OnTick&& on_tick) {
  return runClosedLoopFrom(robot, controller, sim_settings,
                           standingPlacement(robot, controller, sim_settings.terrain), duration_s,
                           mpc_period_s, travel_slope_rad, std::forward<OnTick>(on_tick));
}

/// Mean of f over the samples with t in [t0, t1].
template <class F>
double meanOver(const LoopResult& r, double t0, double t1, F&& f) {
  double sum = 0.0;
  int n = 0;
  for (const LoopSample& s : r.samples)
    if (s.t >= t0 && s.t <= t1) {
      sum += f(s);
      ++n;
    }
  return n > 0 ? sum / n : 0.0;
}

/// Largest f over the samples with t in [t0, t1].
template <class F>
double maxOver(const LoopResult& r, double t0, double t1, F&& f) {
  double m = -1e300;
  for (const LoopSample& s : r.samples)
    if (s.t >= t0 && s.t <= t1) m = std::max(m, f(s));
  return m;
}

}  // namespace wj::nmpc::sim_loop
