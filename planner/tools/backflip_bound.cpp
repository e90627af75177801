#include "backflip_bound.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "planner/jump_model.h"
#include "planner/planner_settings.h"
#include "robot_model/momentum.h"

namespace wj::bound {
namespace {

using model::JointKind;
using model::Leg;
using model::RobotModel;

constexpr double kGravity = 9.81;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Sagittal second and first moments of a group of links about the base origin: I(c) of the
/// group about a point c is a - 2 c.s + mass |c|^2 (x and z only: the pitch axis is y).
struct Moments {
  double a = 0.0;     ///< sum of I_yy + m (x^2 + z^2) [kg m^2]
  double sx = 0.0;    ///< sum of m x [kg m]
  double sz = 0.0;    ///< sum of m z [kg m]
  double mass = 0.0;  ///< [kg]
  double at(double cx, double cz) const {
    return a - 2.0 * (cx * sx + cz * sz) + mass * (cx * cx + cz * cz);
  }
  /// Upper bound of |grad_c at(c)| . (c' - c) over |c' - c|_inf <= h.
  double slack(double cx, double cz, double h) const {
    return 2.0 * h * (std::abs(mass * cx - sx) + std::abs(mass * cz - sz));
  }
};

Moments& operator+=(Moments& l, const Moments& r) {
  l.a += r.a;
  l.sx += r.sx;
  l.sz += r.sz;
  l.mass += r.mass;
  return l;
}

/// One leg posture of the grid and its moments.
struct LegSample {
  Eigen::Vector3d q;  ///< HAA, HFE, KFE [rad]
  Moments m;
};

/// Values from lo to hi (both included) at most `step` apart.
std::vector<double> gridOf(double lo, double hi, double step) {
  const int n = std::max(1, static_cast<int>(std::ceil((hi - lo) / step - 1e-9)));
  std::vector<double> v(n + 1);
  for (int i = 0; i <= n; ++i) v[i] = lo + (hi - lo) * i / n;
  return v;
}

int legOfLink(const RobotModel& robot, std::size_t link) {
  const int j = robot.links()[link].parent_joint;
  return j < 0 ? -1 : static_cast<int>(robot.joints()[j].leg);
}

/// Moments of the base (leg = -1) or of one leg's links at the link poses X_BL.
Moments momentsOf(const RobotModel& robot, const std::vector<Eigen::Isometry3d>& X_BL, int leg) {
  Moments m;
  for (std::size_t i = 0; i < robot.links().size(); ++i) {
    if (legOfLink(robot, i) != leg) continue;
    const model::Inertia& li = robot.links()[i].inertia;
    const Eigen::Matrix3d R = X_BL[i].linear();
    const Eigen::Vector3d p = X_BL[i] * li.com;
    m.a += (R * li.inertia_com * R.transpose())(1, 1) + li.mass * (p.x() * p.x() + p.z() * p.z());
    m.sx += li.mass * p.x();
    m.sz += li.mass * p.z();
    m.mass += li.mass;
  }
  return m;
}

Eigen::VectorXd standingPosture() {
  const planner::PlannerSettings defaults;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(model::kNumJoints);
  for (const Leg leg : model::kLegs) {
    q[model::jointIndex(leg, JointKind::HFE)] = defaults.stand_hfe_rad;
    q[model::jointIndex(leg, JointKind::KFE)] = defaults.stand_kfe_rad;
  }
  return q;
}

void setLeg(Eigen::VectorXd& q, Leg leg, const Eigen::Vector3d& q_leg) {
  for (int k = 0; k < 3; ++k) q[model::jointIndex(leg, model::kJointKinds[k])] = q_leg[k];
}

/// Every grid posture of every leg with its moments (the other legs do not move a leg's links).
std::array<std::vector<LegSample>, model::kNumLegs> legSamples(const RobotModel& robot,
                                                               double step) {
  std::array<std::vector<LegSample>, model::kNumLegs> out;
  for (const Leg leg : model::kLegs) {
    const auto& haa = robot.joint(leg, JointKind::HAA);
    const auto& hfe = robot.joint(leg, JointKind::HFE);
    const auto& kfe = robot.joint(leg, JointKind::KFE);
    Eigen::VectorXd q = Eigen::VectorXd::Zero(model::kNumJoints);
    for (const double a : gridOf(haa.lower_rad, haa.upper_rad, step))
      for (const double h : gridOf(hfe.lower_rad, hfe.upper_rad, step))
        for (const double k : gridOf(kfe.lower_rad, kfe.upper_rad, step)) {
          const Eigen::Vector3d q_leg(a, h, k);
          setLeg(q, leg, q_leg);
          out[static_cast<int>(leg)].push_back(
              {q_leg, momentsOf(robot, robot.calcLinkPoses(q), static_cast<int>(leg))});
        }
  }
  return out;
}

double inertiaOf(const Moments& m) {
  return m.a - (m.sx * m.sx + m.sz * m.sz) / m.mass;
}

}  // namespace

double calcPitchInertia(const RobotModel& robot, const Eigen::VectorXd& q) {
  return robot.calcCompositeInertia(q).inertia_com(1, 1);
}

PitchInertiaRange calcPitchInertiaRange(const RobotModel& robot, double step_rad) {
  if (!(step_rad > 0.0 && step_rad <= 0.5))
    throw std::invalid_argument("grid_step_rad must lie in (0, 0.5] rad, got " +
                                std::to_string(step_rad));
  const auto samples = legSamples(robot, step_rad);
  const Eigen::VectorXd q0 = Eigen::VectorXd::Zero(model::kNumJoints);
  const Moments base = momentsOf(robot, robot.calcLinkPoses(q0), -1);
  const double mass = robot.totalMass();
  // The box of every CoM the postures reach: each leg's first moment spans its own range.
  double x_lo = base.sx, x_hi = base.sx, z_lo = base.sz, z_hi = base.sz;
  for (const auto& leg : samples) {
    double a = kInf, b = -kInf, c = kInf, d = -kInf;
    for (const auto& s : leg) {
      a = std::min(a, s.m.sx), b = std::max(b, s.m.sx);
      c = std::min(c, s.m.sz), d = std::max(d, s.m.sz);
    }
    x_lo += a, x_hi += b, z_lo += c, z_hi += d;
  }
  x_lo /= mass, x_hi /= mass, z_lo /= mass, z_hi /= mass;

  // I(q) = min over c of the moments about c; for a fixed c the legs separate. The minimum over
  // a cell of half-width h is bounded below by the value at its centre less the gradient's
  // reach (each term is convex in c), which makes the minimum over the cells a lower bound.
  auto lowerOnCell = [&](double cx, double cz, double h, std::array<int, 4>* arg) {
    double total = base.at(cx, cz) - base.slack(cx, cz, h);
    for (int l = 0; l < model::kNumLegs; ++l) {
      double best = kInf;
      for (std::size_t i = 0; i < samples[l].size(); ++i) {
        const Moments& m = samples[l][i].m;
        const double v = m.a - 2.0 * (cx * m.sx + cz * m.sz) - m.slack(cx, cz, h);
        if (v < best) best = v, (*arg)[l] = static_cast<int>(i);
      }
      total += best + samples[l][0].m.mass * (cx * cx + cz * cz);
    }
    return total;
  };
  // The largest I is bounded above at every c by the sum of each group's largest moments.
  auto upperAt = [&](double cx, double cz, std::array<int, 4>* arg) {
    double total = base.at(cx, cz);
    for (int l = 0; l < model::kNumLegs; ++l) {
      double best = -kInf;
      for (std::size_t i = 0; i < samples[l].size(); ++i) {
        const double v = samples[l][i].m.at(cx, cz);
        if (v > best) best = v, (*arg)[l] = static_cast<int>(i);
      }
      total += best;
    }
    return total;
  };
  auto inertiaOfChoice = [&](const std::array<int, 4>& arg) {
    Moments m = base;
    for (int l = 0; l < model::kNumLegs; ++l) m += samples[l][arg[l]].m;
    return inertiaOf(m);
  };
  // Coordinate descent (sign -1) or ascent (+1) over the legs' grid postures, others held.
  auto coordinate = [&](std::array<int, 4> arg, double sign) {
    for (int sweep = 0; sweep < 20; ++sweep) {
      bool moved = false;
      for (int l = 0; l < model::kNumLegs; ++l) {
        const std::array<int, 4> start = arg;
        double best = sign * inertiaOfChoice(arg);
        for (std::size_t i = 0; i < samples[l].size(); ++i) {
          std::array<int, 4> trial = arg;
          trial[l] = static_cast<int>(i);
          const double v = sign * inertiaOfChoice(trial);
          if (v > best + 1e-12) best = v, arg = trial;
        }
        moved = moved || arg != start;
      }
      if (!moved) break;
    }
    return arg;
  };

  const double cell = 0.005;  // [m] coarse cell width; refined by 10 where it matters
  struct Cell {
    double cx, cz, lower;
  };
  std::vector<Cell> cells;
  PitchInertiaRange out;
  out.i_max_upper = kInf;
  double best_upper_of_min = kInf;
  std::array<int, 4> arg_min{}, arg_max{}, arg{};
  for (double cx = x_lo; cx <= x_hi + cell; cx += cell)
    for (double cz = z_lo; cz <= z_hi + cell; cz += cell) {
      const double lower = lowerOnCell(cx, cz, 0.5 * cell, &arg);
      cells.push_back({cx, cz, lower});
      const double found = inertiaOfChoice(arg);
      if (found < best_upper_of_min) best_upper_of_min = found, arg_min = arg;
      const double upper = upperAt(cx, cz, &arg);
      if (upper < out.i_max_upper) out.i_max_upper = upper, arg_max = arg;
    }
  arg_min = coordinate(arg_min, -1.0);
  best_upper_of_min = inertiaOfChoice(arg_min);
  out.i_min_lower = kInf;
  const double fine = cell / 10.0;
  for (const Cell& c : cells) {
    if (c.lower >= best_upper_of_min) {
      out.i_min_lower = std::min(out.i_min_lower, best_upper_of_min);
      continue;
    }
    for (int i = 0; i < 10; ++i)
      for (int k = 0; k < 10; ++k) {
        const double cx = c.cx - 0.5 * cell + (i + 0.5) * fine;
        const double cz = c.cz - 0.5 * cell + (k + 0.5) * fine;
        out.i_min_lower = std::min(out.i_min_lower, lowerOnCell(cx, cz, 0.5 * fine, &arg));
      }
  }
  arg_max = coordinate(arg_max, +1.0);
  out.i_min = best_upper_of_min;
  out.i_max_found = inertiaOfChoice(arg_max);
  out.q_min = out.q_max = Eigen::VectorXd::Zero(model::kNumJoints);
  for (const Leg leg : model::kLegs) {
    setLeg(out.q_min, leg, samples[static_cast<int>(leg)][arg_min[static_cast<int>(leg)]].q);
    setLeg(out.q_max, leg, samples[static_cast<int>(leg)][arg_max[static_cast<int>(leg)]].q);
  }
  return out;
}

double calcMaxPower(const model::ActuatorEnvelope& e) {
  // P(w) = peak w up to the corner, peak (w0 - w) / (w0 - wc) w beyond: a parabola with its
  // vertex at w0 / 2, so the best speed is the larger of the corner and w0 / 2.
  const double w = std::max(e.corner_speed_rad_s, 0.5 * e.no_load_speed_rad_s);
  return e.torqueLimit(w) * w;
}

double calcJointWorkBound(const model::JointSpec& joint, int strokes, double stance_time_s) {
  const double by_power = calcMaxPower(joint.actuator) * stance_time_s;
  if (joint.continuous) return by_power;
  return std::min(by_power,
                  joint.actuator.peak_torque_nm * (joint.upper_rad - joint.lower_rad) * strokes);
}

double calcLiftoffPitchMax(const RobotModel& robot, double joint_step_rad, double pitch_step_rad) {
  // Every wheel axle (x, z) in the base frame over the sagittal leg postures (HAA 0: a leg
  // turned out of the plane reaches less far in it).
  std::vector<Eigen::Vector2d> axles;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(model::kNumJoints);
  for (const Leg leg : model::kLegs) {
    const auto& hfe = robot.joint(leg, JointKind::HFE);
    const auto& kfe = robot.joint(leg, JointKind::KFE);
    for (const double h : gridOf(hfe.lower_rad, hfe.upper_rad, joint_step_rad))
      for (const double k : gridOf(kfe.lower_rad, kfe.upper_rad, joint_step_rad)) {
        setLeg(q, leg, Eigen::Vector3d(0.0, h, k));
        const auto X = robot.calcLinkPoses(q);
        const Eigen::Vector3d p = X[robot.joint(leg, JointKind::Wheel).child_link].translation();
        axles.emplace_back(p.x(), p.z());
      }
    setLeg(q, leg, Eigen::Vector3d::Zero());
  }
  const Eigen::Vector3d box = robot.baseBoxSize();
  const double r = robot.wheelRadius();
  // Pitch nose-up by theta: a base point (x, z) is at height x sin(theta) + z cos(theta).
  auto standable = [&](double theta) {
    const double s = std::sin(theta), c = std::cos(theta);
    const double lowest_corner = -0.5 * box.x() * std::abs(s) - 0.5 * box.z() * std::abs(c);
    for (const auto& a : axles)
      if (a.x() * s + a.y() * c - r <= lowest_corner) return true;
    return false;
  };
  double theta = 0.0;
  while (theta < 2.0 * M_PI && standable(theta + pitch_step_rad)) theta += pitch_step_rad;
  return theta + pitch_step_rad;  // the first pitch found not standable, or 2 pi
}

double calcComHeightMin(const RobotModel& robot) {
  const double tilt = std::max(std::abs(robot.joint(Leg::LF, JointKind::HAA).lower_rad),
                               std::abs(robot.joint(Leg::LF, JointKind::HAA).upper_rad));
  double first_moment = 0.0;
  for (std::size_t i = 0; i < robot.links().size(); ++i) {
    const model::LinkSpec& link = robot.links()[i];
    double lowest = 0.0;  // a link without a shape: its CoM at least on the ground
    if (i == 0) {
      lowest = 0.5 * robot.baseBoxSize().minCoeff();
    } else if (robot.joints()[link.parent_joint].kind == JointKind::Wheel) {
      lowest = robot.wheelRadius() * std::cos(tilt);
    } else {
      for (const auto& shape : link.shapes) lowest = std::max(lowest, 0.5 * shape.size.minCoeff());
    }
    first_moment += link.inertia.mass * lowest;
  }
  return first_moment / robot.totalMass();
}

double calcWheelMomentumMax(const RobotModel& robot, double wheel_speed_rad_s) {
  double h = 0.0;
  for (const Leg leg : model::kLegs) {
    const auto& wheel = robot.joint(leg, JointKind::Wheel);
    h += robot.links()[wheel.child_link].inertia.inertia_com(1, 1) * wheel_speed_rad_s;
  }
  return h;
}

std::array<double, 3> calcShapeCouplingMax(const RobotModel& robot, double step_rad) {
  std::array<double, 3> out{};
  const Eigen::VectorXd stand = standingPosture();
  for (const Leg leg : model::kLegs) {
    const auto& haa = robot.joint(leg, JointKind::HAA);
    const auto& hfe = robot.joint(leg, JointKind::HFE);
    const auto& kfe = robot.joint(leg, JointKind::KFE);
    Eigen::VectorXd q = stand;
    for (const double a : gridOf(haa.lower_rad, haa.upper_rad, 2.0 * step_rad))
      for (const double h : gridOf(hfe.lower_rad, hfe.upper_rad, step_rad))
        for (const double k : gridOf(kfe.lower_rad, kfe.upper_rad, step_rad)) {
          setLeg(q, leg, Eigen::Vector3d(a, h, k));
          const double inertia = calcPitchInertia(robot, q);
          for (int kind = 0; kind < 3; ++kind) {
            Eigen::VectorXd qd = Eigen::VectorXd::Zero(model::kNumJoints);
            qd[model::jointIndex(leg, model::kJointKinds[kind])] = 1.0;
            const Eigen::Vector3d H = model::calcCentralAngularMomentum(
                robot, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), q, qd);
            out[kind] = std::max(out[kind], std::abs(H.y()) / inertia);
          }
        }
  }
  return out;
}

Geometry calcGeometry(const RobotModel& robot, const BoundSettings& settings) {
  Geometry g;
  g.inertia = calcPitchInertiaRange(robot, settings.grid_step_rad);
  g.theta_liftoff_max_rad =
      calcLiftoffPitchMax(robot, 0.5 * settings.grid_step_rad, settings.pitch_step_rad);
  g.z_min_m = calcComHeightMin(robot);
  g.z_start_m = planner::JumpModel::standingComHeight(robot, standingPosture());
  g.wheel_momentum_max = calcWheelMomentumMax(robot, settings.wheel_speed_max_rad_s);
  g.shape_coupling = calcShapeCouplingMax(robot, settings.grid_step_rad);
  return g;
}

double maxFlightRotation(double energy_j, double mass_kg, double i_min, double i_max,
                         double wheel_momentum, double* momentum_out, double* vz_out) {
  // f(H) = (H + h_w) sqrt(E - H^2 / (2 I_max)) is concave where it matters: a golden-section
  // search on [0, sqrt(2 I_max E)] finds its maximum.
  if (!(energy_j > 0.0)) {
    if (momentum_out) *momentum_out = 0.0;
    if (vz_out) *vz_out = 0.0;
    return 0.0;
  }
  auto rotation = [&](double H) {
    const double left = std::max(0.0, energy_j - H * H / (2.0 * i_max));
    const double vz = std::sqrt(2.0 * left / mass_kg);
    return (H + wheel_momentum) / i_min * 2.0 * vz / kGravity;
  };
  double lo = 0.0, hi = std::sqrt(2.0 * i_max * energy_j);
  const double phi = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 200; ++it) {
    const double a = hi - phi * (hi - lo), b = lo + phi * (hi - lo);
    if (rotation(a) < rotation(b))
      lo = a;
    else
      hi = b;
  }
  const double H = 0.5 * (lo + hi);
  if (momentum_out) *momentum_out = H;
  if (vz_out) *vz_out = std::sqrt(2.0 * std::max(0.0, energy_j - H * H / (2.0 * i_max)) / mass_kg);
  return rotation(H);
}

namespace {

double shapeRotation(const RobotModel& robot, const Geometry& g, const BoundSettings& s) {
  // Zero-momentum rotation: |dtheta| <= sum_j max |dH/dqd_j| / I |dq_j| over each joint's
  // path, at most strokes x range per joint.
  double turn = 0.0;
  for (const auto& joint : robot.joints()) {
    if (joint.continuous) continue;
    turn += g.shape_coupling[static_cast<int>(joint.kind)] * (joint.upper_rad - joint.lower_rad) *
            s.strokes_per_joint_flight;
  }
  return turn;
}

}  // namespace

double calcBoundFromLiftoff(const RobotModel& robot, const Geometry& g, const BoundSettings& s,
                            const LiftoffState& lo, std::array<double, 3>* terms_out) {
  if (!(lo.drop_m >= 0.0))
    throw std::invalid_argument("liftoff.drop_m must be >= 0 m, got " + std::to_string(lo.drop_m));
  const double i_min = std::min(g.inertia.i_min_lower, g.inertia.i_min);
  const double t_flight =
      (lo.vz_m_s + std::sqrt(lo.vz_m_s * lo.vz_m_s + 2.0 * kGravity * lo.drop_m)) / kGravity;
  const std::array<double, 3> terms = {
      lo.pitch_rad, (std::abs(lo.momentum) + g.wheel_momentum_max) / i_min * t_flight,
      shapeRotation(robot, g, s)};
  if (terms_out) *terms_out = terms;
  return terms[0] + terms[1] + terms[2];
}

BoundTerms calcBound(const RobotModel& robot, const Geometry& g, const BoundSettings& s,
                     double run_up_speed_m_s) {
  BoundTerms t;
  t.knee_peak_nm = robot.joint(Leg::LF, JointKind::KFE).actuator.peak_torque_nm;
  t.run_up_speed_m_s = run_up_speed_m_s;
  t.mass_kg = robot.totalMass();
  t.i_min = std::min(g.inertia.i_min_lower, g.inertia.i_min);
  t.i_max = g.inertia.i_max_upper;
  t.theta_liftoff_max_rad = g.theta_liftoff_max_rad;
  t.z_start_m = g.z_start_m;
  t.z_min_m = g.z_min_m;
  t.run_up_energy_j = 0.5 * t.mass_kg * run_up_speed_m_s * run_up_speed_m_s;
  for (const auto& joint : robot.joints())
    t.work_by_kind_j[static_cast<int>(joint.kind)] +=
        calcJointWorkBound(joint, s.strokes_per_joint_stance, s.stance_time_max_s);
  // The wheels' work also passes the friction: the motor gives torque only below its no-load
  // speed w0, and tau = F r with |F| <= mu N, so its power is at most mu r w0 N and its work
  // mu r w0 times the normal impulse m (g T + vz), plus the spin energy the wheels may keep.
  const double w0 = robot.joint(Leg::LF, JointKind::Wheel).actuator.no_load_speed_rad_s;
  const double mu_r_w = s.friction_mu * robot.wheelRadius() * w0;
  double energy = t.run_up_energy_j + t.mass_kg * kGravity * (t.z_start_m - t.z_min_m);
  for (int k = 0; k < 3; ++k) energy += t.work_by_kind_j[k];
  double wheels = t.work_by_kind_j[3];
  for (int it = 0; it < 50; ++it) {
    const double vz = std::sqrt(2.0 * (energy + wheels) / t.mass_kg);
    const double spin = 0.5 * g.wheel_momentum_max * s.wheel_speed_max_rad_s;
    wheels = std::min(t.work_by_kind_j[3],
                      mu_r_w * t.mass_kg * (kGravity * s.stance_time_max_s + vz) + spin);
  }
  t.work_by_kind_j[3] = wheels;
  t.work_j = t.work_by_kind_j[0] + t.work_by_kind_j[1] + t.work_by_kind_j[2] + wheels;
  t.energy_j = energy + wheels;
  t.wheel_momentum_max = g.wheel_momentum_max;
  t.flight_rotation_rad =
      maxFlightRotation(t.energy_j, t.mass_kg, t.i_min, t.i_max, t.wheel_momentum_max,
                        &t.momentum_at_best, &t.vz_at_best);
  t.flight_time_at_best_s = 2.0 * t.vz_at_best / kGravity;
  t.shape_rotation_rad = shapeRotation(robot, g, s);
  t.need_rad = s.need_rad;
  t.bound_rad = t.theta_liftoff_max_rad + t.flight_rotation_rad + t.shape_rotation_rad;
  // The largest energy whose flight still leaves the bound at the need (bisection).
  const double room = t.need_rad - t.theta_liftoff_max_rad - t.shape_rotation_rad;
  if (room > 0.0) {
    double lo = 0.0, hi = t.energy_j;
    if (t.bound_rad <= t.need_rad) lo = hi;
    for (int it = 0; it < 100 && lo < hi; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (maxFlightRotation(mid, t.mass_kg, t.i_min, t.i_max, t.wheel_momentum_max, nullptr,
                            nullptr) <= room)
        lo = mid;
      else
        hi = mid;
    }
    t.energy_to_certify_j = lo;
  }
  // Which terms alone reach the need, and the largest of the three (for the flight, the
  // joint kind that supplies most of its energy).
  if (t.theta_liftoff_max_rad >= t.need_rad) t.alone_exceed_need.push_back("theta_liftoff_max");
  if (t.flight_rotation_rad >= t.need_rad) t.alone_exceed_need.push_back("flight_rotation");
  if (t.shape_rotation_rad >= t.need_rad) t.alone_exceed_need.push_back("shape_rotation");
  if (t.bound_rad < t.need_rad) {
    t.loosest_term = "none: the bound certifies";
  } else if (t.flight_rotation_rad >= std::max(t.theta_liftoff_max_rad, t.shape_rotation_rad)) {
    static const char* names[4] = {"HAA", "HFE", "KFE", "WHEEL"};
    int worst = 0;
    for (int k = 1; k < 4; ++k)
      if (t.work_by_kind_j[k] > t.work_by_kind_j[worst]) worst = k;
    t.loosest_term = std::string("flight_rotation (energy; most work: ") + names[worst] + ")";
  } else {
    t.loosest_term =
        t.shape_rotation_rad > t.theta_liftoff_max_rad ? "shape_rotation" : "theta_liftoff_max";
  }
  return t;
}

}  // namespace wj::bound
