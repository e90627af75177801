// The constraints and the cost of the jump model (docs/planner.md, "Constraints" and "Cost"):
// every sampled margin of the take-off and the flight, the target errors, and the prioritized
// penalty (paper Eq. 10) that evaluate() adds up, with its early cut-off.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "jump_model_internal.h"

namespace wj::planner {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

namespace detail {
namespace {

// Signed distance from point p to the obstacle box [x_min, x_max] x [0, height] (x-z).
double boxDistance(const BoxObstacle& box, const Eigen::Vector2d& p) {
  const double dx = std::max({box.x_min - p.x(), 0.0, p.x() - box.x_max});
  const double dz = std::max(p.y() - box.height, 0.0);
  if (dx == 0.0 && dz == 0.0)
    return -std::min({p.x() - box.x_min, box.x_max - p.x(), box.height - p.y()});
  return std::sqrt(dx * dx + dz * dz);  // not std::hypot: 10x slower, no overflow risk here
}

// The target's position terms of the target cost (dx and height over their tolerances,
// squared): the ballistic CoM gives them before the flight attitude is known; a touchdown's dx
// is the smallest over [t3_min, t2 + Tf], where the touchdown lies (touchdownTime). The same
// arithmetic as targetErrors() and the cost, so it never exceeds the full target cost.
double targetPositionCost(const JumpModelConstants& M, const Solved& S) {
  const auto& tgt = M.task.target;
  const auto& st = M.settings;
  const double g = st.gravity;
  const bool apex = tgt.event == TargetEvent::Apex;
  const double t_apex = std::max(S.takeoff.vz / g, 0.0);
  const PlanarState at = ballisticG(S.takeoff, apex ? (S.t2 + t_apex) - S.t2 : S.Tf, g);
  double e0 = at.x - M.initial.x - tgt.dx;
  if (!apex) {
    const double e_min = e0 - S.takeoff.vx * (S.t2 + S.Tf - S.t3_min);
    e0 = e_min * e0 <= 0.0 ? 0.0 : std::min(std::abs(e0), std::abs(e_min));
  }
  const double e1 = apex ? at.z - tgt.height : 0.0;
  return std::pow(e0 / st.tolerance_dx_m, 2) + std::pow(e1 / st.tolerance_height_m, 2);
}

// Clearance of a disc (centre p, radius r) to the obstacle. While the robot is on the ground
// (take-off), a point below the obstacle's top must stay in front of it: this cannot be
// tunnelled through between two samples, however fast the run-up.
// A wheel disc (r > 0) in flight over a platform the jump lands on (`platform`): the top is
// where it lands, like the ground, so only the near face and its edge are an obstacle.
double obstacleMargin(const BoxObstacle& box, const Eigen::Vector2d& p, double r, bool on_ground,
                      bool platform = false) {
  if (on_ground && p.y() - r < box.height) return box.x_min - (p.x() + r);
  if (platform && r > 0.0 && p.x() >= box.x_min) {
    if (p.y() < box.height) return p.y() - box.height - r;  // centre below the top: inside
    const double dx = p.x() - box.x_min, dz = p.y() - box.height;
    return std::sqrt(dx * dx + dz * dz) - r;  // to the near top edge
  }
  return boxDistance(box, p) - r;
}

// The clearance kept from the task's obstacle: a wall's (jumped over) or a platform's (landed on).
double requiredClearance(const JumpModelConstants& M) {
  return M.task.landsOnObstacle() ? M.settings.platform_margin_m : M.settings.obstacle_margin_m;
}

// Body height and obstacle margins at one instant. In take-off the wheel axles come from the
// sample; in flight from the blended leg posture `flight_q` (HFE, KFE) per pair.
template <class Sink>
void emitBody(const JumpModelConstants& M, double t, const PlanarState& s, const Rot2& R,
              const Eigen::Vector2d& c, const Sample* smp,
              const std::array<Eigen::Vector2d, 2>* flight_q, Sink& sink) {
  const Eigen::Vector2d com(s.x, s.z);
  double clearance = kInf;
  const auto* box = M.task.obstacle ? &*M.task.obstacle : nullptr;
  // The base box: its centre and half axes in the world.
  const Eigen::Vector2d centre = com - R * c;
  const Eigen::Vector2d ax = R * Eigen::Vector2d(M.box_half.x(), 0.0);
  const Eigen::Vector2d az = R * Eigen::Vector2d(0.0, M.box_half.y());
  // Its lowest point is a corner.
  const double lowest = centre.y() - std::abs(ax.y()) - std::abs(az.y());
  sink(ConstraintClass::BodyHeight, lowest - M.settings.min_body_clearance_m, t, -3);
  if (box) {
    // 4 corners and 4 edge midpoints of the base box.
    static constexpr std::array<std::array<double, 2>, 8> kPts = {
        {{1, 1}, {1, -1}, {-1, 1}, {-1, -1}, {0, 1}, {0, -1}, {1, 0}, {-1, 0}}};
    for (const auto& k : kPts) {
      const Eigen::Vector2d p = centre + k[0] * ax + k[1] * az;
      clearance = std::min(clearance, obstacleMargin(*box, p, 0.0, smp != nullptr));
    }
    for (int pair = 0; pair < 2; ++pair) {
      Eigen::Vector2d axle;
      if (smp) {
        axle = pair == 0 ? smp->hind.axle : smp->front.axle;
      } else {
        const auto& geo = pair == 0 ? M.hind : M.front;
        axle = com + R * (-c + geo.hfe_b + M.leg.forward((*flight_q)[pair]));
      }
      clearance = std::min(clearance, obstacleMargin(*box, axle, M.wheel_radius, smp != nullptr,
                                                     M.task.landsOnObstacle()));
    }
    sink(ConstraintClass::ObstacleClearance, clearance - requiredClearance(M), t, -3);
  }
}

// How far a joint of `pair` that brakes from a lift-off comes to rest inside its limits, less
// the clearance it must keep there.
double brakeStopMargin(const JumpModelConstants& M, int pair, int j, const PairSample& p) {
  const std::array<double, 2>& lim = j == 0 ? M.lim_hfe : M.lim_kfe;
  const double clearance =
      pair == 0 && j == 0 && M.task.isBackflip() ? kFlipHindHipClearance : kBrakeLimitClearance;
  return std::min(p.q_stop[j] - lim[0], lim[1] - p.q_stop[j]) - clearance;
}

// Feeds every sampled margin of one take-off sample to `sink(class, margin, t, location)`.
template <class Sink>
void emitContact(const JumpModelConstants& M, const Sample& smp, Sink& sink) {
  const auto& st = M.settings;
  for (int pair = 0; pair < 2; ++pair) {
    const PairSample& p = pair == 0 ? smp.hind : smp.front;
    const model::Leg leg = pair == 0 ? model::Leg::LH : model::Leg::LF;
    const int base = model::jointIndex(leg, model::JointKind::HAA);
    const int loc_pair = pair == 0 ? -1 : -2;
    const double lever = pair == 0 ? M.hind.haa_lever : M.front.haa_lever;
    const bool lift_off = pair == 1 && M.task.mode == TakeoffMode::TwoStep && smp.t >= smp.t1;
    if (p.contact && !lift_off) {
      // In a two-step take-off the front pair unloads linearly to zero at its lift-off (t1),
      // so its minimum normal force ramps down with it.
      const double f_min = (pair == 1 && M.task.mode == TakeoffMode::TwoStep)
                               ? st.min_normal_force_n * std::max(0.0, 1.0 - smp.t / smp.t1)
                               : st.min_normal_force_n;
      sink(ConstraintClass::NormalForce, p.f.y() - f_min, smp.t, loc_pair);
      sink(ConstraintClass::FrictionCone, st.friction_mu * p.f.y() - std::abs(p.f.x()), smp.t,
           loc_pair);
    } else {
      sink(ConstraintClass::NormalForce, JumpModel::classScale(ConstraintClass::NormalForce), smp.t,
           loc_pair);
      sink(ConstraintClass::FrictionCone, JumpModel::classScale(ConstraintClass::FrictionCone),
           smp.t, loc_pair);
    }
    sink(ConstraintClass::JointPosition, p.reach / M.leg.l1, smp.t, base + 2);
    // Within the limits, and at a lift-off also where the braking joint comes to rest.
    auto within = [&](int j, const std::array<double, 2>& lim) {
      const double m = std::min(p.q[j] - lim[0], lim[1] - p.q[j]);
      return p.brakes ? std::min(m, brakeStopMargin(M, pair, j, p)) : m;
    };
    sink(ConstraintClass::JointPosition, within(0, M.lim_hfe), smp.t, base + 1);
    // A backflip's hind knee pushes settings.flip_hind_knee_clearance_rad short of its stop.
    const bool flip_knee = pair == 0 && p.contact && M.task.isBackflip();
    sink(ConstraintClass::JointPosition,
         std::min(
             within(1, M.lim_kfe),
             flip_knee ? M.lim_kfe[1] - M.settings.flip_hind_knee_clearance_rad - p.q[1] : kInf),
         smp.t, base + 2);
    sink(ConstraintClass::JointSpeed, M.env_hfe.speedMargin(p.qd[0]), smp.t, base + 1);
    sink(ConstraintClass::JointSpeed, M.env_kfe.speedMargin(p.qd[1]), smp.t, base + 2);
    const double tau_haa = lever * p.haa_fz;
    sink(ConstraintClass::JointTorque, M.env_haa.peak_torque_nm - std::abs(tau_haa), smp.t, base);
    sink(ConstraintClass::JointTorque, M.env_hfe.peak_torque_nm - std::abs(p.tau[0]), smp.t,
         base + 1);
    sink(ConstraintClass::JointTorque, M.env_kfe.peak_torque_nm - std::abs(p.tau[1]), smp.t,
         base + 2);
    sink(ConstraintClass::ActuatorEnvelope, M.env_haa.drivingMargin(tau_haa, 0.0), smp.t, base);
    sink(ConstraintClass::ActuatorEnvelope, M.env_hfe.drivingMargin(p.tau[0], p.qd[0]), smp.t,
         base + 1);
    sink(ConstraintClass::ActuatorEnvelope, M.env_kfe.drivingMargin(p.tau[1], p.qd[1]), smp.t,
         base + 2);
    sink(ConstraintClass::WheelTraction,
         M.env_wheel.drivingMargin(p.wheel_tau, p.wheel_rate_loaded), smp.t, base + 3);
    sink(ConstraintClass::WheelSpeed, M.env_wheel.speedMargin(p.wheel_rate_loaded), smp.t,
         base + 3);
  }
  emitBody(M, smp.t, smp.s, smp.R, smp.c, &smp, nullptr, sink);
}

// |P|, or its smooth version sqrt(P^2 + 1 W^2) for the gradient-based polish.
double absPower(double p, bool smooth) {
  return smooth ? std::sqrt(p * p + 1.0) : std::abs(p);
}

// The take-off part of sweep(): every contact sample, the energy and the joint maxima. It
// asks `stop()` after every sample whether to give up (evaluate()'s cut-off; asking every 8
// samples instead costs 5-7 % more instructions per solve) and returns false if it did.
// Each sample is computed in two halves:
// - its posture (contactPosture), in the order of settings.contact_chain, each one step of
//   the CoM-offset iteration from the sample before it in that order: FromStart in time
//   order from the standing posture's offset; FromTakeoff t = 0 (from that offset, exact
//   there), then the take-off t2 (from the converged take-off posture) and backwards;
// - its statics and margins (contactStatics, about half of a sample's cost), in the order
//   t = 0, then from the take-off t2 backwards, computing postures as they are needed.
//   Most cut-offs come at t = 0 or near t2, where the push starts and where the speeds and
//   torques peak: seed 1, forward preset, 70 % of the cut-offs in the take-off at t = 0;
//   backflip, 54 % at t2 once t2 comes first. Instructions per DE solve against time order
//   (callgrind, seed 1): backflip -12 %, forward +0.6 %, vertical and forward_hw -1.6 %.
//   The order changes no number: the energy is summed in time order, and evaluate() breaks
//   ties of the worst margins towards the earliest instant.
// `slot`, if given, receives each sample's index in time order before its margins go out.
template <class Sink, class Stop>
bool sweepContact(const JumpModelConstants& M, const Solved& S, Sink& sink, Evaluation* ev,
                  bool smooth_energy, Stop&& stop, int* slot = nullptr) {
  const auto& st = M.settings;
  const bool from_takeoff = chainsFromTakeoff(M);
  const int n1 = st.samples_phase1, n2 = S.two_step ? st.samples_phase2 : 0;
  const int count = n1 + n2;
  // Per-thread scratch, grown once: the DE evaluates on a fixed team of threads.
  thread_local std::vector<Sample> samples;
  thread_local std::vector<double> power;
  if (static_cast<int>(samples.size()) < count) {
    samples.resize(count);
    power.resize(count);
  }
  // Postures. j: the sample's index in time order (phase 1's n1 samples on [0, t1], then
  // phase 2's n2 on [t1, t2]; both have one at t1); e: its place in the chain.
  int chained = 0;  // postures done, in chain order
  Eigen::Vector2d c_guess = M.c0;
  auto posture_up_to = [&](int j) {
    const int e_of_j = from_takeoff && j > 0 ? count - j : j;
    for (; chained <= e_of_j; ++chained) {
      const int e = chained;
      const int k = from_takeoff && e > 0 ? count - e : e;
      const bool phase2 = k >= n1;
      const double t = phase2 ? S.t1 + S.T2 * (k - n1) / (n2 - 1) : 0.0 + S.t1 * k / (n1 - 1);
      if (from_takeoff && e == 1) c_guess = S.takeoff_sample.c;
      contactPosture(M, S, t, samples[k], phase2, c_guess, /*converge=*/false);
      c_guess = samples[k].c;
    }
  };
  // Trapezoids between neighbours in time, none across the instant t1 (where phase 1's last
  // sample and phase 2's first coincide).
  auto trapezoid = [&](int j) {  // from sample j - 1 to j
    const double t = samples[j].t, prev_t = samples[j - 1].t;
    return t > prev_t ? 0.5 * (power[j] + power[j - 1]) * (t - prev_t) : 0.0;
  };
  double energy = 0.0;  // the trapezoids between samples done so far: a lower bound
  for (int i = 0; i < count; ++i) {
    const int j = i == 0 ? 0 : count - i;
    posture_up_to(j);
    Sample& smp = samples[j];
    contactStatics(M, S, smp);
    if (slot) *slot = j;
    emitContact(M, smp, sink);
    double p_sum = 0.0;
    for (const PairSample* p : {&smp.hind, &smp.front}) {
      if (!p->contact) continue;
      p_sum += 2.0 * (absPower(p->tau[0] * p->qd[0], smooth_energy) +
                      absPower(p->tau[1] * p->qd[1], smooth_energy) +
                      absPower(p->wheel_tau * p->wheel_rate, smooth_energy));
      if (ev) {
        const double haa = std::abs((p == &smp.hind ? M.hind : M.front).haa_lever * p->haa_fz);
        auto& mt = ev->max_abs_torque_nm;
        auto& ms = ev->max_abs_speed_rad_s;
        mt[0] = std::max(mt[0], haa);
        mt[1] = std::max(mt[1], std::abs(p->tau[0]));
        mt[2] = std::max(mt[2], std::abs(p->tau[1]));
        mt[3] = std::max(mt[3], std::abs(p->wheel_tau));
        ms[1] = std::max(ms[1], std::abs(p->qd[0]));
        ms[2] = std::max(ms[2], std::abs(p->qd[1]));
        ms[3] = std::max(ms[3], std::abs(p->wheel_rate));
      }
    }
    power[j] = p_sum;
    if (i > 0 && j + 1 < count) energy += trapezoid(j + 1);
    if (i > 0 && j == 1) energy += trapezoid(1);
    // A lower bound of the final sum, which adds the same >= 0 terms and more in another
    // order: each sum is within (count - 1) eps of its exact value (~1e-14 relative for
    // 100 samples), so 1e-12 less never exceeds it.
    if (ev) ev->energy_j = energy * (1.0 - 1e-12);
    if (stop()) return false;
  }
  energy = 0.0;
  for (int j = 1; j < count; ++j) energy += trapezoid(j);
  if (ev) ev->energy_j = energy;
  return true;
}

// The flight part of sweep(): body and wheels against the ground and the obstacle, and the
// landing beyond the obstacle; `stop()` is asked once, after the flight samples.
template <class Sink, class Stop>
bool sweepFlight(const JumpModelConstants& M, const Solved& S, Sink& sink, Stop&& stop) {
  // Flight: the postures and CoM offsets tabulated with the attitude (same instants).
  for (int k = 1; k <= S.n_flight; ++k) {
    const double t = S.t2 + S.Tf * k / S.n_flight;
    const PlanarState s = flightState(M, S, t);
    const std::array<Eigen::Vector2d, 2> q = {S.flight_q[0][k], S.flight_q[1][k]};
    emitBody(M, t, s, Rot2(s.pitch), S.flight_c[k], nullptr, &q, sink);
  }
  if (stop()) return false;
  if (M.task.obstacle) {
    // Clearing the obstacle means landing beyond it: the rear wheel touches down past its
    // far face (otherwise stopping short of the wall would count as clearing it). Landing on
    // it (a platform): both pairs' wheels touch down on its top, each wheel disc inside the
    // near and the far face by the margin (one row: the smaller of the two).
    const PlanarState& td = S.touchdown;
    const BoxObstacle& box = *M.task.obstacle;
    const Eigen::Vector2d com(td.x, td.z);
    const Rot2 R(td.pitch);
    const Eigen::Vector2d leg = M.leg.forward(M.q_landing);
    const Eigen::Vector2d hind = com + R * (-M.c_land + M.hind.hfe_b + leg);
    double m = hind.x() - M.wheel_radius - box.x_max - requiredClearance(M);
    if (M.task.landsOnObstacle()) {
      const Eigen::Vector2d front = com + R * (-M.c_land + M.front.hfe_b + leg);
      m = std::min(hind.x() - M.wheel_radius - box.x_min,
                   box.x_max - (front.x() + M.wheel_radius)) -
          requiredClearance(M);
    }
    sink(ConstraintClass::ObstacleClearance, m, S.t3, -1);
  }
  // The legs' braking from the converged take-off state, which the flight's references follow
  // (solveFlight; docs/planner.md, "Flight: the legs brake"): each joint comes to rest inside
  // its limits. The lift-off sample above checks the same on the chained posture, whose joint
  // speeds are up to 2.5 rad/s slower; near the no-load speed, where the envelope leaves the
  // brake a few Nm, that is 0.2 rad more travel: vertical at 1 m/s, whose plans' own
  // references ran the hind knee 0.29 rad past its stop.
  for (int pair = 0; pair < 2; ++pair) {
    const PairSample& p = S.takeoff_sample.pair(pair);
    const int base =
        model::jointIndex(pair == 0 ? model::Leg::LH : model::Leg::LF, model::JointKind::HAA);
    for (int j = 0; j < 2; ++j)
      sink(ConstraintClass::JointPosition,
           p.brakes ? brakeStopMargin(M, pair, j, p)
                    : JumpModel::classScale(ConstraintClass::JointPosition),
           S.t2, base + 1 + j);
  }
  return true;
}

// Sweeps every constraint sample of a solved take-off and flight through `sink`, and
// accumulates energy and joint maxima into the optional evaluation. `slot` as in sweepContact;
// it is -1 once the flight's margins are emitted.
template <class Sink>
void sweep(const JumpModelConstants& M, const Solved& S, Sink& sink, Evaluation* ev,
           bool smooth_energy = false, int* slot = nullptr) {
  const auto never = [] { return false; };
  sweepContact(M, S, sink, ev, smooth_energy, never, slot);
  if (slot) *slot = -1;
  sweepFlight(M, S, sink, never);
}

// The target residuals (dx, height, pitch, landing pitch) and the predicted events.
void targetErrors(const JumpModelConstants& M, const Solved& S, Eigen::Vector4d& e,
                  JumpOutcome& out) {
  const auto& tgt = M.task.target;
  const PlanarState& to = S.takeoff;
  const double g = M.settings.gravity;
  auto event = [&](double t, const PlanarState& s, const Eigen::Vector2d& c) {
    JumpEvent ev;
    ev.t = t;
    ev.state = s;
    ev.base_z = s.z + rot(s.pitch, -c).y();
    return ev;
  };
  // The base at take-off from the take-off posture; in flight the legs are taken at the
  // landing posture they are moving to.
  out.takeoff = event(S.t2, to, S.takeoff_sample.c);
  out.takeoff.momentum = S.flight_h;
  const double t_apex = std::max(to.vz / g, 0.0);
  std::array<Eigen::Vector2d, 2> q_apex;
  for (int pair = 0; pair < 2; ++pair)
    q_apex[pair] = flightPosture(M, S, pair, S.t2 + t_apex, nullptr);
  out.apex = event(S.t2 + t_apex, flightState(M, S, S.t2 + t_apex),
                   comOffset(M, poseOf(q_apex[0]), poseOf(q_apex[1])));
  out.touchdown = event(S.t3, S.touchdown, M.c_land);
  const PlanarState& s0 = M.initial;
  const PlanarState& at = tgt.event == TargetEvent::Apex ? out.apex.state : S.touchdown;
  e[0] = at.x - s0.x - tgt.dx;
  e[1] = tgt.event == TargetEvent::Apex ? at.z - tgt.height : 0.0;
  e[2] = at.pitch - s0.pitch - tgt.pitch_change;
  // Apex targets must still land upright (pitch a multiple of 2 pi at touchdown).
  e[3] = tgt.event == TargetEvent::Apex ? wrapToPi(S.touchdown.pitch) : 0.0;
}

}  // namespace
}  // namespace detail

namespace {
constexpr double kInvalidCost = 1e16;
// 10^n, exact, for the penalty's 10^(n+3) and 10^n with priorities n <= 10.
constexpr std::array<double, 14> kPow10 = {1e0, 1e1, 1e2, 1e3,  1e4,  1e5,  1e6,
                                           1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13};
}  // namespace

double JumpModel::classScale(ConstraintClass c) {
  switch (c) {
    case ConstraintClass::NormalForce:
    case ConstraintClass::FrictionCone:
      return 50.0;
    case ConstraintClass::JointPosition:
      return 0.2;
    case ConstraintClass::JointSpeed:
    case ConstraintClass::WheelSpeed:
      return 5.0;
    case ConstraintClass::JointTorque:
    case ConstraintClass::ActuatorEnvelope:
    case ConstraintClass::WheelTraction:
      return 5.0;
    case ConstraintClass::BodyHeight:
    case ConstraintClass::ObstacleClearance:
      return 0.05;
  }
  return 1.0;
}

int JumpModel::classPriority(ConstraintClass c) {
  switch (c) {
    case ConstraintClass::JointPosition:
      return 10;
    case ConstraintClass::NormalForce:
      return 9;
    case ConstraintClass::FrictionCone:
      return 8;
    case ConstraintClass::BodyHeight:
      return 7;
    case ConstraintClass::ObstacleClearance:
      return 6;
    case ConstraintClass::JointTorque:
      return 5;
    case ConstraintClass::ActuatorEnvelope:
      return 4;
    case ConstraintClass::JointSpeed:
      return 3;
    case ConstraintClass::WheelTraction:
      return 2;
    case ConstraintClass::WheelSpeed:
      return 1;
  }
  return 1;
}

void JumpModel::evaluate(const Eigen::Ref<const Eigen::VectorXd>& u, Evaluation& ev,
                         double cutoff) const {
  ev = Evaluation{};
  detail::Solved S;
  // The cost is built up cheapest bound first, and with a finite cut-off the evaluation stops
  // once what is known already exceeds it: every term (penalty, target, energy) is >= 0 and
  // only grows as samples come in. The order changes no value: the same numbers either way.
  if (!detail::solve(k_, u, S, /*complete=*/false)) {
    ev.valid = false;
    ev.cost = kInvalidCost;
    return;
  }
  ev.valid = true;
  const bool bounded = cutoff < std::numeric_limits<double>::infinity();
  // The penalty of the margins so far.
  auto penalty = [&ev, this] {
    double p = 0.0;
    for (int i = 0; i < kNumConstraintClasses; ++i) {
      const double worst = ev.margins[i].worst;
      if (worst < 0.0) {
        const auto c = static_cast<ConstraintClass>(i);
        const int n = classPriority(c);
        p += k_.settings.class_weight[i] * (kPow10[n + 3] + kPow10[n] * (-worst / classScale(c)));
      }
    }
    return p;
  };
  double target_bound = 0.0;
  auto cut = [&] {
    if (!bounded) return false;
    const double lower_bound = penalty() + target_bound + k_.settings.energy_weight * ev.energy_j;
    if (!(lower_bound > cutoff)) return false;
    ev.cut_off = true;
    ev.cost = lower_bound;
    ev.constraints_ok = false;
    ev.target_ok = false;
    ev.feasible = false;
    return true;
  };
  // Ties go to the earliest instant, as if the samples came in time order.
  auto sink = [&ev](ConstraintClass c, double margin, double t, int loc) {
    ClassMargin& m = ev.margins[static_cast<int>(c)];
    if (margin < m.worst || (margin == m.worst && t < m.t)) {
      m.worst = margin;
      m.t = t;
      m.location = loc;
    }
  };
  // 1. The target's position from the ballistic CoM; 2. the take-off samples.
  if (bounded) target_bound = detail::targetPositionCost(k_, S);
  if (cut()) return;
  // The pitch with the legs' momentum in stance (the target's position does not depend on it).
  if (!detail::solveStanceMomentum(k_, S)) {
    ev = Evaluation{};
    ev.cost = kInvalidCost;
    return;
  }
  // (The converged take-off posture is needed by the flight, and by the FromTakeoff chain.)
  const bool posture_first = detail::chainsFromTakeoff(k_);
  if (posture_first) detail::solveTakeoffPosture(k_, S);
  if (!detail::sweepContact(k_, S, sink, &ev, false, cut)) return;
  // 3. The flight attitude and the whole target error.
  if (!posture_first) detail::solveTakeoffPosture(k_, S);
  detail::solveFlight(k_, S);
  Eigen::Vector4d e;
  detail::targetErrors(k_, S, e, ev.predicted);
  ev.err_dx = e[0];
  ev.err_height = e[1];
  ev.err_pitch = e[2];
  ev.err_landing_pitch = e[3];
  const double landing_excess =
      std::max(std::abs(e[3]) - k_.settings.landing_pitch_tolerance_rad, 0.0);
  ev.target_cost = targetErrorCost(e) +
                   std::pow(landing_excess / k_.settings.landing_pitch_tolerance_rad, 2) * 100.0;
  ev.target_ok = std::abs(e[0]) <= k_.settings.tolerance_dx_m &&
                 std::abs(e[1]) <= k_.settings.tolerance_height_m &&
                 std::abs(e[2]) <= k_.settings.tolerance_pitch_rad && landing_excess == 0.0;
  target_bound = ev.target_cost;
  if (cut()) return;
  // 4. The flight samples.
  if (!detail::sweepFlight(k_, S, sink, cut)) return;
  ev.penalty = penalty();
  ev.constraints_ok = true;
  for (const ClassMargin& m : ev.margins) ev.constraints_ok = ev.constraints_ok && m.worst >= 0.0;
  ev.predicted.min_obstacle_clearance =
      k_.task.obstacle ? ev.margins[static_cast<int>(ConstraintClass::ObstacleClearance)].worst +
                             detail::requiredClearance(k_)
                       : kInf;
  ev.feasible = ev.constraints_ok && ev.target_ok;
  ev.cost = ev.penalty + ev.target_cost + k_.settings.energy_weight * ev.energy_j;
}

double JumpModel::targetErrorCost(const Eigen::Ref<const Eigen::Vector4d>& e) const {
  return std::pow(e[0] / k_.settings.tolerance_dx_m, 2) +
         std::pow(e[1] / k_.settings.tolerance_height_m, 2) +
         std::pow(e[2] / k_.settings.tolerance_pitch_rad, 2);
}

bool JumpModel::evaluateConstraints(const Eigen::Ref<const Eigen::VectorXd>& u,
                                    Eigen::Ref<Eigen::VectorXd> g,
                                    Eigen::Ref<Eigen::Vector4d> target_residual,
                                    double* energy_j) const {
  detail::Solved S;
  if (!detail::solve(k_, u, S)) return false;
  // g is in time order (constraintSampleOrigin) whatever the sweep's order: each take-off
  // sample's margins go to the block of its time index; the flight's follow.
  int i = 0, slot = -1, slot_now = -1, in_slot = 0;
  int next = k_.per_contact_sample * k_.num_contact_samples;
  const int n = static_cast<int>(g.size());
  auto sink = [&](ConstraintClass c, double margin, double, int) {
    if (slot != slot_now) {
      slot_now = slot;
      in_slot = 0;
    }
    const int k = slot >= 0 ? slot * k_.per_contact_sample + in_slot++ : next++;
    if (k < n && (slot < 0 || in_slot <= k_.per_contact_sample)) g[k] = margin / classScale(c);
    ++i;
  };
  Evaluation ev;
  detail::sweep(k_, S, sink, &ev, /*smooth_energy=*/true, &slot);
  if (i != k_.num_constraint_samples || next != k_.num_constraint_samples)
    throw std::logic_error("JumpModel: constraint count " + std::to_string(i) +
                           " != " + std::to_string(k_.num_constraint_samples));
  Eigen::Vector4d e;
  JumpOutcome out;
  detail::targetErrors(k_, S, e, out);
  target_residual = e;
  if (energy_j) *energy_j = ev.energy_j;
  return true;
}

}  // namespace wj::planner
