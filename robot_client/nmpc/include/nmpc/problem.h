#pragma once
/// @file The optimal control problem of the NMPC (paper Eq. 5): cost that tracks a reference
/// of base orientation, height and velocity; the wheel constraints of paper Eq. 7-8 as
/// state-input equalities (eliminated by the solver) and the friction cone and joint limits as
/// relaxed barriers. The problem is immutable; what changes every MPC cycle (gait, terrain,
/// reference) is passed in as Targets.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "nmpc/centroidal_model.h"
#include "nmpc/gait.h"
#include "nmpc/relaxed_barrier.h"
#include "nmpc/types.h"

namespace wj::nmpc {

/// The ground under the robot as a plane (the NMPC's only terrain knowledge).
struct TerrainPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit normal out of the ground, in W
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    ///< a point of the plane, in W [m]

  /// Horizontal ground at height `height_m`.
  static TerrainPlane flat(double height_m = 0.0);
  /// Plane through the origin rising at `slope_rad` along +x (as sim::Terrain::slope).
  static TerrainPlane slope(double slope_rad);
  /// Height of the plane above (x, y) [m].
  double heightAt(double x, double y) const;
};

/// A state reference sampled in time; linear interpolation, held constant beyond the ends.
struct ReferenceTrajectory {
  std::vector<double> times;  ///< strictly increasing [s]
  std::vector<State> states;  ///< one per time

  /// Reference at time t (no allocation).
  State interpolate(double t) const;
};

/// A raised block on the terrain plane (a step, a platform): perception's stand-in.
struct TerrainBox {
  double x_min = 0.0;   ///< [m]
  double x_max = 0.0;   ///< [m]
  double y_min = 0.0;   ///< [m]
  double y_max = 0.0;   ///< [m]
  double height = 0.0;  ///< top above the terrain plane [m]
};

/// Heights of one swing above the terrain plane: where the wheel lifts off and where it is
/// expected to touch down. The swing spline blends them and adds the bump on top.
struct SwingHeights {
  double t_liftoff = 0.0;    ///< [s]
  double t_touchdown = 0.0;  ///< [s]
  double h_liftoff = 0.0;    ///< [m]
  double h_touchdown = 0.0;  ///< [m]
  /// Foothold: the leg's joint reference moves (smoothstep over the swing) to q_foothold, which
  /// lands the wheel off the hip, and holds it until t_release (the next lift-off).
  bool has_foothold = false;
  Eigen::Vector3d q_foothold = Eigen::Vector3d::Zero();  ///< HAA, HFE, KFE [rad]
  double t_release = 0.0;                                ///< [s]
};

/// Swings per leg that Targets can describe.
inline constexpr int kMaxSwingsPerLeg = 4;

/// What the NMPC tracks in one cycle: gait, terrain and state reference, and the heights of
/// the swings (all zero over a plane).
struct Targets {
  GaitSchedule gait;
  TerrainPlane terrain;
  ReferenceTrajectory reference;
  std::array<std::array<SwingHeights, kMaxSwingsPerLeg>, kNumLegs> swings{};  ///< per leg
  std::array<int, kNumLegs> num_swings{};  ///< entries of `swings` in use, per leg
};

/// Height of the terrain above its plane at (x, y): the highest box there, else 0 [m].
double calcTerrainHeight(const std::vector<TerrainBox>& boxes, double x, double y);

/// Cost weights and constraint parameters. The stage cost is
///   l = 1/2 |x - x_ref|^2_Q + 1/2 |u - u_ref|^2_R + sum of relaxed barriers,
/// integrated over the interval; the terminal cost is terminal_weight_scale / 2 |x - x_ref|^2_Q.
struct ProblemSettings {
  std::array<double, 3> weight_orientation = {200.0, 300.0, 100.0};  ///< roll, pitch, yaw
  std::array<double, 3> weight_position = {0.0, 0.0, 400.0};         ///< CoM point x, y, z
  std::array<double, 3> weight_angular_velocity = {5.0, 5.0, 5.0};   ///< about x, y, z of W
  std::array<double, 3> weight_velocity = {40.0, 40.0, 20.0};        ///< CoM point, in W
  std::array<double, 3> weight_joint_position = {20.0, 10.0, 10.0};  ///< HAA, HFE, KFE
  double weight_force = 1e-3;                                        ///< per N^2, every axis
  std::array<double, 3> weight_joint_velocity = {0.5, 0.5, 0.5};     ///< HAA, HFE, KFE
  double terminal_weight_scale = 10.0;  ///< terminal Q as a multiple of the stage Q [s]
  double friction_coefficient = 0.6;    ///< mu of the friction cone (paper Eq. 8) [-]
  /// eps in mu f_n - sqrt(|f_t|^2 + eps): smooths the cone's apex [N^2].
  double friction_regularization_n2 = 25.0;
  BarrierSettings friction_barrier = {0.1, 5.0};      ///< on the cone margin [N]
  BarrierSettings joint_limit_barrier = {0.1, 0.05};  ///< on the joint position margins [rad]
  BarrierSettings joint_speed_barrier = {0.1, 1.0};   ///< on the joint speed margins [rad/s]
  double joint_speed_fraction = 0.8;  ///< leg joints may use this fraction of no-load speed
  /// Swing feedback: the normal velocity of a swinging wheel is the spline's plus this gain
  /// times the error of its height above the terrain plane (0: velocity only, Eq. 7) [1/s].
  double swing_position_gain = 10.0;

  /// Throws std::invalid_argument naming the field when a value is out of range.
  void validate() const;
};

/// Equality constraints of one node: at most 4 per leg (swing: force = 0 and the normal
/// velocity), 2 per leg in contact.
inline constexpr int kMaxEqualities = 4 * kNumLegs;
using EqVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxEqualities, 1>;
using EqStateMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, kStateDim, 0, kMaxEqualities, kStateDim>;
using EqInputMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, kInputDim, 0, kMaxEqualities, kInputDim>;

/// The targets of one time node, evaluated once per MPC cycle.
struct NodeTargets {
  double t = 0.0;                                        ///< [s]
  ContactFlags contact{};                                ///< wheels on the ground
  std::array<double, kNumLegs> swing_normal_velocity{};  ///< [m/s]; 0 in contact
  std::array<double, kNumLegs> swing_height{};  ///< spline height above the plane [m]; 0 in contact
  State x_ref = State::Zero();
  Input u_ref = Input::Zero();  ///< weight shared by the stance wheels, zero joint speeds
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();        ///< ground normal in W
  Eigen::Vector3d terrain_point = Eigen::Vector3d::Zero();  ///< a point of the ground plane
};

/// Quadratic model of a cost: value, gradient and Gauss-Newton Hessian (exact for the
/// quadratic tracking terms; barrier Hessians B'' dh dh^T + B' d2h, positive semidefinite
/// because every constraint here is concave).
struct CostQuadratic {
  double value = 0.0;
  State dx = State::Zero();
  Input du = Input::Zero();
  StateMatrix dxx = StateMatrix::Zero();
  InputMatrix duu = InputMatrix::Zero();
  /// duu is block diagonal in 3 x 3 blocks (true for the stage cost here: per-wheel friction
  /// cones, diagonal elsewhere); lets the projection skip the zero blocks.
  bool duu_block_diagonal = false;
};

/// Linearised equality constraints g + C dx + D du = 0.
struct EqualityLinearization {
  EqVector g;
  EqStateMatrix C;
  EqInputMatrix D;
};

/// The centroidal optimal control problem (see the file comment). Immutable; may be evaluated
/// from several threads at once, each with its own ModelData.
class CentroidalOcp {
 public:
  /// Throws std::invalid_argument when the settings are out of range.
  CentroidalOcp(CentroidalModel model, const ProblemSettings& settings);

  /// The centroidal model.
  const CentroidalModel& model() const { return model_; }
  /// Cost weights and constraint parameters.
  const ProblemSettings& settings() const { return settings_; }

  /// Gait, reference and terrain of `targets` at time t.
  NodeTargets calcNodeTargets(const Targets& targets, double t) const;
  /// Number of equality constraints of a node with these contacts.
  static int numEqualities(const ContactFlags& contact);

  /// Stage cost rate l(x, u) (tracking + barriers).
  double calcStageCost(const NodeTargets& node, const State& x, const Input& u) const;
  /// Stage cost rate with its quadratic model.
  void calcStageCostQuadratic(const NodeTargets& node, const State& x, const Input& u,
                              CostQuadratic& out) const;
  /// Terminal cost.
  double calcTerminalCost(const NodeTargets& node, const State& x) const;
  /// Terminal cost with its quadratic model (du, duu left zero).
  void calcTerminalCostQuadratic(const NodeTargets& node, const State& x, CostQuadratic& out) const;

  /// Equality constraints g(x, u) (paper Eq. 7-8), leg by leg: contact: n.v, b.v; swing:
  /// f (3 rows), n.v - v_swing - k (r + h_swing - n.(p_wheel - p_terrain)), with k the
  /// swing_position_gain. `data` must be updated at x.
  void calcEqualities(const NodeTargets& node, const State& x, const Input& u,
                      const ModelData& data, EqVector& g) const;
  /// Same, linearised.
  void calcEqualitiesLinear(const NodeTargets& node, const State& x, const Input& u,
                            const ModelData& data, EqualityLinearization& out) const;

  /// Height error of the swinging wheel of `leg`: r + h_swing - n.(p_wheel - p_terrain) [m].
  double calcSwingHeightError(const NodeTargets& node, int leg, const State& x,
                              const ModelData& data) const;

  /// Friction cone margin mu f_n - sqrt(|f_t|^2 + eps) of force f under normal n (>= 0 inside).
  double calcFrictionMargin(const Eigen::Vector3d& f, const Eigen::Vector3d& n) const;

 private:
  CentroidalModel model_;
  ProblemSettings settings_;
  State q_diag_ = State::Zero();  // tracking weights as diagonals
  Input r_diag_ = Input::Zero();
};

}  // namespace wj::nmpc
