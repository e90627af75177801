#pragma once
/// @file Settings of the multibody simulation: contact model, integrator, sensor noise and
/// terrain. Plain data with documented defaults; loadSimSettings() reads them from YAML and
/// fails on unknown or missing keys. Simbody-free; also compiles as C++17 because the
/// Simbody translation units include it.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "sim/plant.h"

namespace wj::sim {

/// Shape that stands in for the wheel (a cylinder with rounded tread) in ground contact.
/// Simbody 3.7 has no cylinder or torus tracker against a half-space.
enum class WheelShape : std::uint8_t {
  Sphere,     ///< sphere of the wheel radius: circular Hertz contact, cheapest
  Ellipsoid,  ///< ellipsoid flattened to the wheel width: elliptical Hertz contact
};

/// Explicit integrators of Simbody that the simulator offers.
enum class IntegratorKind : std::uint8_t {
  SemiExplicitEuler,   ///< fixed step (max_step_s), first order, no error control
  SemiExplicitEuler2,  ///< step doubling on semi-explicit Euler, error controlled, 1st order
  RungeKutta3,         ///< 3rd order Runge-Kutta with embedded error estimate
  RungeKuttaMerson,    ///< 4th order Runge-Kutta-Merson with embedded error estimate
  /// SemiExplicitEuler through Simbody's own SemiExplicitEulerIntegrator even where the
  /// project's stepper applies (the sagittal model): the same trajectory bit for bit at about
  /// a third more work per step; the stepper's reference (docs/sim.md, "Integrator").
  SemiExplicitEulerSimbody,
};

/// When the drives evaluate their PD law.
enum class ActuatorUpdate : std::uint8_t {
  /// At every dynamics evaluation inside the period, like a drive that closes its PD loop at
  /// tens of kHz on the commands it received at 1 kHz.
  Continuous,
  /// Once at the start of each control period, torque held constant over it (zero-order hold).
  ZeroOrderHold,
};

/// Compliant contact: Hertz elasticity, Hunt-Crossley dissipation, Stribeck friction (the
/// model of Simbody's CompliantContactSubsystem; box terrain uses the same law, see docs/sim.md).
/// The robot and the terrain share one material, so the effective Hertz modulus of a contact
/// is stiffness_pa / 2^(3/2).
struct ContactSettings {
  double stiffness_pa = 8.0e6;                  ///< plane-strain modulus of each surface [Pa]
  double dissipation_s_m = 0.8;                 ///< Hunt-Crossley c: restitution e = 1 - c v [s/m]
  double static_friction = 0.9;                 ///< mu_s [-]
  double dynamic_friction = 0.7;                ///< mu_d [-], <= mu_s
  double viscous_friction_s_m = 0.0;            ///< mu_v [s/m]
  double transition_velocity_m_s = 0.2;         ///< slip speed below which friction ramps up [m/s]
  WheelShape wheel_shape = WheelShape::Sphere;  ///< stand-in for the wheel in ground contact
  double base_sphere_radius_m = 0.03;   ///< radius of the spheres that cover the base box [m]
  double body_sphere_radius_m = 0.015;  ///< radius of the spheres along thighs and shanks [m]
};

/// Time integration of the multibody dynamics between control instants.
struct IntegratorSettings {
  IntegratorKind kind = IntegratorKind::SemiExplicitEuler;  ///< method
  double accuracy = 2e-2;    ///< relative accuracy of error-controlled methods [-]
  double max_step_s = 1e-3;  ///< largest internal step (the fixed step of SemiExplicitEuler) [s]
};

/// Seeded Gaussian noise on what read() returns; the ground truth stays exact.
struct NoiseSettings {
  bool enabled = false;                ///< add noise at all
  std::uint64_t seed = 1;              ///< generator seed (same seed, same noise)
  double joint_position_rad = 1e-4;    ///< standard deviation of q [rad]
  double joint_velocity_rad_s = 2e-2;  ///< of qd [rad/s]
  double joint_torque_nm = 0.2;        ///< of the measured torque [Nm]
  double gyro_rad_s = 5e-3;            ///< of the IMU angular velocity [rad/s]
  double accel_m_s2 = 5e-2;            ///< of the IMU specific force [m/s^2]
  double orientation_rad = 2e-3;       ///< of the IMU orientation (small rotation) [rad]
};

/// Axis-aligned box standing in the world (W = J, the jump frame), e.g. a wall or a step.
struct Box {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();  ///< lower corner [m]
  Eigen::Vector3d max = Eigen::Vector3d::Zero();  ///< upper corner [m]
  /// True for an obstacle the jump must clear (counted in the clearance metric); false for
  /// terrain the robot may drive or land on (a step).
  bool obstacle = true;
};

/// The world the robot moves in: an optional ground plane through the origin, tilted by
/// `slope_rad` about -y (rising along +x), plus boxes.
struct Terrain {
  bool has_ground = true;  ///< false: no ground at all (free fall)
  double slope_rad = 0.0;  ///< ground inclination, positive uphill along +x [rad]
  std::vector<Box> boxes;  ///< walls, steps

  /// Flat ground at z = 0.
  static Terrain flat();
  /// No ground and no boxes: free space.
  static Terrain none();
  /// Ground plane through the origin rising at `slope_rad` along +x.
  static Terrain slope(double slope_rad);
  /// Flat ground with a step up of `height_m` starting at x = `x_m` and going on along +x.
  static Terrain step(double x_m, double height_m);
  /// Flat ground with a wall spanning y, from x_min_m to x_max_m, `height_m` high (as the
  /// proto's BoxObstacle).
  static Terrain wall(double x_min_m, double x_max_m, double height_m);
  /// Flat ground with a platform from x_min_m to x_max_m, `height_m` high, spanning y: terrain
  /// to land and drive on (Box::obstacle = false), as the planner's obstacle a jump lands on.
  static Terrain platform(double x_min_m, double x_max_m, double height_m);

  /// Height of the terrain surface under (x, y) [m]: the ground plane or the top of a box,
  /// whichever is higher; -infinity where there is nothing.
  double heightAt(double x, double y) const;
};

/// Everything that defines one simulation, except the robot description.
struct SimSettings {
  double control_period_s = 1e-3;  ///< period of advance() [s]
  double gravity_m_s2 = 9.81;      ///< magnitude of gravity, along -z of W [m/s^2]
  ActuatorUpdate actuator_update = ActuatorUpdate::Continuous;  ///< see ActuatorUpdate
  ContactSettings contact;
  IntegratorSettings integrator;
  NoiseSettings noise;
  Terrain terrain = Terrain::flat();
  /// How the simulated robot differs from the model: SimRobot applies the masses, drive
  /// envelopes, motor latency and IMU biases; applyPlant() also moves the terrain and sets the
  /// contact friction. Not part of the YAML of loadSimSettings() (a plant file is separate).
  PlantSettings plant;

  /// Throws std::invalid_argument naming the field when a value is out of range.
  void validate() const;
};

/// `nominal` with `plant` applied: contact friction (mu_d = plant.friction, mu_s keeping the
/// ratio mu_s / mu_d), obstacles moved by the wall position error, the take-off ground raised
/// by ground_height_m, and the plant stored for SimRobot. Throws std::invalid_argument on a
/// bad plant.
SimSettings applyPlant(const SimSettings& nominal, const PlantSettings& plant);

/// "sphere", "ellipsoid".
std::string_view toString(WheelShape shape);
/// "semi_explicit_euler", "semi_explicit_euler2", "runge_kutta3", "runge_kutta_merson".
std::string_view toString(IntegratorKind kind);
/// "continuous", "zero_order_hold".
std::string_view toString(ActuatorUpdate update);

/// Reads SimSettings from a YAML file (layout: sim/config/sim_settings.yaml). Every key is
/// required and unknown keys are errors; throws std::runtime_error naming file and key.
SimSettings loadSimSettings(const std::filesystem::path& yaml_file);
/// Same as loadSimSettings() from YAML text; `origin` names the source in error messages.
SimSettings parseSimSettings(std::string_view yaml_text, const std::string& origin = "<text>");

}  // namespace wj::sim
