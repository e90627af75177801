#pragma once
/// @file The legs' own dynamics in the take-off (issue 22, sessions 13 and 15; docs/planner.md,
/// "Stance torques"): the exact accelerations of a contact sample (CoM, pitch, joints, base)
/// and the joint torques of the legs in contact as a Newton-Euler balance of their links; the
/// whole robot's momentum rate and the pairs' normal forces balanced to make it (session 18,
/// "The balanced stance"). Used by the plan export (jump_model_plan.cpp); the DE's evaluate
/// keeps the statics and takes the momentum rate at t2 only (the unloading tail's moment).

#include <Eigen/Core>
#include <array>

#include "jump_model_internal.h"

namespace wj::planner::detail {

/// The acceleration polynomials of one solved take-off: what stanceAccelerations() needs
/// beyond the sample. Cheap (derivatives of S's polynomials): the DE's evaluate builds one for
/// the unloading tail's moment (addUnloadingTailMoment).
struct TakeoffAccelerations {
  Poly ax1, az1, aw1;  ///< CoM x, z and pitch accelerations, phase 1 (in t)
  Poly ax2, az2, aw2;  ///< ... phase 2 (in tau = t - t1)
  Poly ddd_h2;         ///< the hind axle offset's acceleration, phase 2

  explicit TakeoffAccelerations(const Solved& S);
};

/// What the stance torques need that is fixed for one solved take-off: the acceleration
/// polynomials and, per leg, its links in the frame H of its HFE joint (which moves with the
/// base: the HAA holds its initial angle in the take-off). Below H a leg is planar: the KFE and
/// wheel axes are H's y axis (checked; the planner's leg model assumes it throughout). Built
/// once per plan export.
struct StanceDynamics : TakeoffAccelerations {
  struct Chain {
    Eigen::Matrix3d R_hfe = Eigen::Matrix3d::Identity();  ///< H in the base
    Eigen::Vector3d t_hfe = Eigen::Vector3d::Zero();
    Eigen::Vector3d e_y = Eigen::Vector3d::UnitY();       ///< the base's (and world's) y axis in H
    Eigen::Vector3d o_haa = Eigen::Vector3d::Zero();      ///< HAA joint origin in H
    Eigen::Vector3d axis_haa = Eigen::Vector3d::UnitX();  ///< HAA axis in H
    std::array<Eigen::Vector3d, 4> axis{};                ///< HAA, HFE, KFE, wheel axes in H
    std::array<double, 3> sign{};                     ///< HFE, KFE, wheel: their axis' y in H (+-1)
    Eigen::Vector3d t_kfe = Eigen::Vector3d::Zero();  ///< KFE origin in the thigh frame
    Eigen::Vector3d t_wheel = Eigen::Vector3d::Zero();  ///< wheel axle in the shank frame
    /// Hip (in H), thigh, shank and wheel (in their own frames): CoM, mass, pitch inertia.
    std::array<Eigen::Vector3d, 4> com{};
    std::array<double, 4> mass{}, i_yy{};
  };
  std::array<Chain, model::kNumLegs> leg{};

  /// Throws std::invalid_argument if a leg is not planar below its HFE joint.
  StanceDynamics(const JumpModelConstants& M, const Solved& S);
};

/// The accelerations of one contact sample, in the x-z plane of the world (CoM, base origin)
/// or of the joints.
struct StanceAccelerations {
  Eigen::Vector2d com = Eigen::Vector2d::Zero();  ///< the CoM's [m/s^2]
  double pitch = 0.0;                             ///< the pitch's (nose-up) [rad/s^2]
  double hind_axle_x = 0.0;  ///< the hind axles' x (the front axles' is com.x()) [m/s^2]
  /// (HFE, KFE) per pair, hind then front [rad/s^2]
  std::array<Eigen::Vector2d, 2> qdd{Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  Eigen::Vector2d base = Eigen::Vector2d::Zero();      ///< the base origin's [m/s^2]
  Eigen::Vector2d base_pos = Eigen::Vector2d::Zero();  ///< the base origin, com - R c [m]
};

/// The accelerations of a sample from contactSample() (the contact geometry differentiated
/// twice; a lifted front pair's joints brake).
StanceAccelerations stanceAccelerations(const JumpModelConstants& M, const Solved& S,
                                        const TakeoffAccelerations& D, const Sample& smp);

/// The rate of change of the whole robot's nose-up angular momentum about its CoM at a contact
/// sample with its accelerations (the legs' and wheels' motion included): the moment about the
/// CoM that the ground forces must make for the sample's motion [Nm].
double momentumRate(const JumpModelConstants& M, const Sample& smp, const StanceAccelerations& acc);

/// The nose-up moment about the CoM of the sample's ground forces (per wheel in p.f) [Nm].
double groundMoment(const Sample& smp);

/// Balances a simultaneous take-off's four-wheel sample (docs/planner.md, "The balanced
/// stance"): the rigid-body pitch of Eq. S-0 leaves out what the legs' motion adds to the
/// angular momentum (E' of "Stance momentum"), so the pairs' normal forces of the model do not
/// make the moment the sample's motion needs. Moves part of the normal force from one pair to
/// the other (the total, and so the CoM's motion, unchanged) until their moment is
/// momentumRate(). Nothing for a sample with one pair in contact.
void balancePairForces(const JumpModelConstants& M, const StanceAccelerations& acc, Sample& smp);

/// The joint torques of each leg in contact at the sample (HAA, HFE, KFE, wheel): the
/// Newton-Euler balance of the links below each joint with the wheel's share of its pair's
/// ground force. The other legs' entries of `tau` are left as they are.
void addStanceTorques(const JumpModelConstants& M, const StanceDynamics& D, const Sample& smp,
                      const StanceAccelerations& acc,
                      Eigen::Matrix<double, model::kNumJoints, 1>& tau);

/// The flight's feed-forward at time t (after t2): each leg's HAA, HFE and KFE torques that
/// make its links follow the flight references while the base moves as the plan's flight
/// (ballistic CoM, the attitude table's pitch, the momentum balance's pitch rate); the wheels'
/// are zero (they turn freely). The same Newton-Euler balance as addStanceTorques, without a
/// ground force. Writes every leg's entries.
void flightTorques(const JumpModelConstants& M, const StanceDynamics& D, const Solved& S, double t,
                   Eigen::Matrix<double, model::kNumJoints, 1>& tau);

}  // namespace wj::planner::detail
