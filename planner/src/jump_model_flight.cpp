// The flight of the jump model (docs/planner.md, "Flight"): the ballistic CoM, the legs'
// tuck-and-extend motion, and the body's attitude from the conservation of the whole robot's
// angular momentum about its CoM.

#include <algorithm>
#include <cmath>
#include <limits>

#include "jump_model_internal.h"

namespace wj::planner::detail {

namespace {

// Sub-intervals of the attitude's Simpson rule in a flight interval the braking overlaps: the
// legs come to rest within 10-25 ms, less than one interval, and hand their momentum to the
// body meanwhile; and in one a tuck overlaps: a tuck folds a leg within 40-75 ms, two to four
// intervals, and the body's rate follows the bump of the legs' momentum. Elsewhere the legs
// hold a posture or extend slowly, and the trapezoid rule is kept. Against the trapezoid rule
// with 48 sub-steps in every interval, on 300 points of the DE's runs per preset, the
// touchdown pitch's median error fell from 0.003-0.006 rad (six trapezoid sub-steps while
// braking, none while tucking) to 0.0003-0.0004, at the same cost per evaluation (issue 22,
// session 33; docs/planner.md, "Flight").
constexpr int kBrakeSubintervals = 4;
constexpr int kTuckSubintervals = 2;

// Whether the flight interval [lo, hi] (from t2) overlaps a joint's tuck.
bool overlapsTuck(const Solved& S, double lo, double hi) {
  for (int pair = 0; pair < 2; ++pair)
    for (int j = 0; j < 2; ++j) {
      const double start = S.brake[pair][j].t_stop, end = start + S.tuck_duration[pair][j];
      if (end > start && lo < end && hi > start) return true;
    }
  return false;
}

// Flight attitude: the total angular momentum about the CoM is conserved from the lift-off
// on. It is taken from the take-off kinematics the joint controllers track (body pitch rate,
// legs still extending, wheels spinning): as the legs brake and tuck, their momentum goes into
// the body. The body's pitch rate follows, and is integrated (trapezoid; Simpson's rule while
// the legs brake or tuck).
void integrateFlightAttitude(const JumpModelConstants& M, Solved& S) {
  const int n = M.settings.samples_flight;
  S.n_flight = n;
  double i_to = 0.0, h_to = 0.0;
  const Sample& to = S.takeoff_sample;
  flightMomentum(M, {to.hind.q, to.front.q}, {to.hind.qd, to.front.qd}, i_to, h_to);
  // (about +y; the unloading tail's impulse is nose-up positive)
  const double h_y = -i_to * S.takeoff.pitch_rate + h_to - S.tail_h;
  S.flight_h = -h_y;
  // The body's nose-up pitch rate at time t (about -y), and the legs' posture and CoM offset.
  // While the legs hold a posture (tucked, or landing) the inertia and CoM offset are those of
  // the last call with the same posture at rest, so they are kept instead of recomputed.
  // Zero-initialized although read only once valid: GCC 12 cannot see that and warns.
  struct Held {
    std::array<Eigen::Vector2d, 2> q = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
    double i_total = 0.0;
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    bool valid = false;
  } held;
  auto rate_at = [&](double t, std::array<Eigen::Vector2d, 2>& q, Eigen::Vector2d* c) {
    std::array<Eigen::Vector2d, 2> qd;
    for (int pair = 0; pair < 2; ++pair) q[pair] = flightPosture(M, S, pair, t, &qd[pair]);
    const bool at_rest = qd[0].isZero(0.0) && qd[1].isZero(0.0);
    if (at_rest && held.valid && q == held.q) {
      if (c) *c = held.c;
      return -h_y / held.i_total;
    }
    double i_total = 0.0, h = 0.0;
    Eigen::Vector2d c_here;
    flightMomentum(M, q, qd, i_total, h, &c_here);
    if (c) *c = c_here;
    if (at_rest) held = {q, i_total, c_here, true};
    return -(h_y - h) / i_total;
  };
  const double dt = S.Tf / n;
  // The pitch's change over the interval ending at t by Simpson's rule on m (even)
  // sub-intervals, from the rates at its ends.
  auto simpson = [&](double t, double rate_start, double rate_end, int m) {
    double sum = rate_start + rate_end;
    for (int i = 1; i < m; ++i) {
      std::array<Eigen::Vector2d, 2> q_sub;
      sum += (i % 2 ? 4.0 : 2.0) * rate_at(t - dt + dt * i / m, q_sub, nullptr);
    }
    return sum * dt / (3.0 * m);
  };
  double prev_rate = 0.0;
  for (int k = 0; k <= n; ++k) {
    const double t = S.t2 + S.Tf * k / n;
    std::array<Eigen::Vector2d, 2> q;
    const double rate = rate_at(t, q, &S.flight_c[k]);
    S.flight_q[0][k] = q[0];
    S.flight_q[1][k] = q[1];
    S.flight_rate[k] = rate;
    if (k == 0) {
      S.flight_pitch[k] = S.takeoff.pitch;
    } else if (dt * (k - 1) < S.brake_end) {
      S.flight_pitch[k] = S.flight_pitch[k - 1] + simpson(t, prev_rate, rate, kBrakeSubintervals);
    } else if (overlapsTuck(S, dt * (k - 1), dt * k)) {
      S.flight_pitch[k] = S.flight_pitch[k - 1] + simpson(t, prev_rate, rate, kTuckSubintervals);
    } else {
      S.flight_pitch[k] = S.flight_pitch[k - 1] + 0.5 * (prev_rate + rate) * dt;
    }
    prev_rate = rate;
  }
}

// The touchdown (docs/planner.md, "Touchdown"): the first instant a wheel's lowest point
// reaches the landing surface, from the flight table (pitch, the legs' posture and the CoM in
// the base at its instants, the CoM ballistic): back from the table's end (the CoM at the
// landing height) to the last instant with every wheel above the surface, and the crossing
// between it and the next by linear interpolation of the lowest wheel's height (sub-mm over
// one interval: the gap's curvature is g's and the legs' slow extension). Not before t3_min,
// and the table's end if no wheel is down by then (legs not yet out).
double touchdownTime(const JumpModelConstants& M, const Solved& S) {
  const int n = S.n_flight;
  const double g = M.settings.gravity, dt = S.Tf / n;
  auto gap = [&](int k) {
    const double tau = dt * k;
    const double z = S.takeoff.z + S.takeoff.vz * tau - 0.5 * g * tau * tau;
    const Rot2 R(S.flight_pitch[k]);
    double lowest = std::numeric_limits<double>::infinity();
    for (int pair = 0; pair < 2; ++pair) {
      const PairGeometry& geo = pair == 0 ? M.hind : M.front;
      const Eigen::Vector2d axle = geo.hfe_b + M.leg.forward(S.flight_q[pair][k]) - S.flight_c[k];
      lowest = std::min(lowest, (R * axle).y());
    }
    return z + lowest - M.wheel_radius - M.landing_surface;
  };
  double next = gap(n);
  if (next >= 0.0) return S.t3;
  for (int k = n - 1; k >= 0; --k) {
    const double t = S.t2 + dt * k;
    if (t < S.t3_min) return S.t3_min;
    const double here = gap(k);
    if (here >= 0.0) return std::max(t + dt * here / (here - next), S.t3_min);
    next = here;
  }
  return S.t3_min;
}

// The constant acceleration of a drive-limited tuck of joint j (0 HFE, 1 KFE) [rad/s^2]:
// kTuckTorqueShare of the peak torque over the fixed-base leg's inertia about the joint, the
// hip's with the knee where it came to rest.
double tuckAcceleration(const JumpModelConstants& M, const Solved& S, int pair, int j) {
  const JumpModelConstants::LegInertia& li = M.leg_inertia[pair];
  const double inertia =
      j == 0 ? li.i_hip + 2.0 * li.m_l1_c * std::cos(S.brake[pair][1].q_stop) : li.i_knee;
  return kTuckTorqueShare * (j == 0 ? M.env_hfe : M.env_kfe).peak_torque_nm / inertia;
}

}  // namespace

// Pitch inertia of the whole robot about its CoM, and the angular momentum of the legs'
// motion relative to the base (both about +y of the base), for the pairs' postures q and
// rates qd. The wheels count as point masses on their axles: in flight they spin freely, so
// their spin momentum stays with them and exchanges nothing with the body.
void flightMomentum(const JumpModelConstants& M, const std::array<Eigen::Vector2d, 2>& q,
                    const std::array<Eigen::Vector2d, 2>& qd, double& i_total, double& h,
                    Eigen::Vector2d* com_in_base) {
  auto cross = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.y() * b.x() - a.x() * b.y();  // y component of (a_x, 0, a_z) x (b_x, 0, b_z)
  };
  const double l1 = M.leg.l1;
  std::array<Eigen::Vector2d, 4> p, v;  // thigh and lower CoMs of each pair, and rates
  std::array<double, 4> m{}, i{}, w{};
  Eigen::Vector2d first = M.moment_fixed, rate = Eigen::Vector2d::Zero();
  for (int pair = 0; pair < 2; ++pair) {
    const PairGeometry& g = pair == 0 ? M.hind : M.front;
    const double s1 = std::sin(q[pair][0]), c1 = std::cos(q[pair][0]);
    const double s12 = std::sin(q[pair][0] + q[pair][1]), c12 = std::cos(q[pair][0] + q[pair][1]);
    const Eigen::Vector2d knee(-l1 * s1, -l1 * c1);
    const Eigen::Vector2d dknee(-l1 * c1, l1 * s1);
    p[2 * pair] = g.hfe_b + Rv(s1, c1, g.c_thigh);
    v[2 * pair] = dRv(s1, c1, g.c_thigh) * qd[pair][0];
    p[2 * pair + 1] = g.hfe_b + knee + Rv(s12, c12, g.c_lower);
    v[2 * pair + 1] = dknee * qd[pair][0] + dRv(s12, c12, g.c_lower) * (qd[pair][0] + qd[pair][1]);
    m[2 * pair] = 2.0 * g.m_thigh;
    m[2 * pair + 1] = 2.0 * g.m_lower;
    i[2 * pair] = 2.0 * g.i_thigh;
    i[2 * pair + 1] = 2.0 * g.i_lower;
    w[2 * pair] = qd[pair][0];
    w[2 * pair + 1] = qd[pair][0] + qd[pair][1];
  }
  for (int k = 0; k < 4; ++k) {
    first += m[k] * p[k];
    rate += m[k] * v[k];
  }
  const Eigen::Vector2d c = first / M.mass, c_dot = rate / M.mass;
  if (com_in_base) *com_in_base = c;
  const Eigen::Vector2d c_fixed = M.moment_fixed / M.mass_fixed;
  i_total = M.i_fixed + M.mass_fixed * (c_fixed - c).squaredNorm();
  h = M.mass_fixed * cross(c_fixed - c, -c_dot);
  for (int k = 0; k < 4; ++k) {
    i_total += i[k] + m[k] * (p[k] - c).squaredNorm();
    h += i[k] * w[k] + m[k] * cross(p[k] - c, v[k] - c_dot);
  }
}

// Wheel joint rate of a pair in flight: from its take-off rate towards the ground speed it
// will meet at touchdown, done by the end of the legs' landing extension.
double flightWheelRate(const JumpModelConstants& M, const Solved& S, int pair, double t) {
  const double xi = (t - S.t2) / (M.settings.extend_end_fraction * S.Tf);
  const double w0 = S.takeoff_sample.pair(pair).wheel_rate;
  return w0 + (S.takeoff.vx / M.wheel_radius - w0) * smoothstep(xi);
}

void JointBrake::start(double q, double v, double decel_rad_s2, double torque_nm,
                       const model::ActuatorEnvelope& env) {
  q0 = q;
  sign = v < 0.0 ? -1.0 : 1.0;
  decel = decel_rad_s2;
  torque = torque_nm;
  const double w_c = env.corner_speed_rad_s;
  w_nl = env.no_load_speed_rad_s;
  // Within the no-load speed (an infeasible candidate may exceed it; the speed constraint
  // rejects it, the profile only has to stay finite).
  w0 = std::min(std::abs(v), w_c + 0.999 * (w_nl - w_c));
  t_a = 0.0;
  q_a = q;
  w_a = w0;
  lambda = 0.0;
  if (w0 > w_c) {
    // w' = -decel (w_nl - w) / (w_nl - w_c): w_nl - w grows as exp(lambda t).
    lambda = decel / (w_nl - w_c);
    t_a = std::log((w_nl - w_c) / (w_nl - w0)) / lambda;
    q_a = q + sign * (w_nl * t_a - (w0 - w_c) / lambda);
    w_a = w_c;
  }
  // Below the corner speed the deceleration is decel p(s / T_b), p the cubic from 1 with the
  // envelope part's slope (lambda T_b per unit x) to 0 with slope 0 at rest, so the torque is
  // C1 throughout (the knots' torque slopes follow it). At rest: w_a = decel T_b (1/2 +
  // kappa / 12) with kappa = lambda T_b, a quadratic in T_b.
  if (lambda > 0.0) {
    const double r = lambda * w_a / decel;
    t_b = 6.0 * (std::sqrt(0.25 + r / 3.0) - 0.5) / lambda;
  } else {
    t_b = 2.0 * w_a / decel;
  }
  kappa = lambda * t_b;
  t_stop = t_a + t_b;
  q_stop = q_a + sign * (w_a * t_b - decel * t_b * t_b * (0.35 + 0.05 * kappa));
}

double JointBrake::at(double tau, double* qd) const {
  if (tau >= t_stop) {
    if (qd) *qd = 0.0;
    return q_stop;
  }
  if (tau < t_a) {
    const double e = std::exp(lambda * tau);
    if (qd) *qd = sign * (w_nl - (w_nl - w0) * e);
    return q0 + sign * (w_nl * tau - (w_nl - w0) * (e - 1.0) / lambda);
  }
  // The cubic's first and second integrals in x = s / T_b.
  const double s = tau - t_a, x = s / t_b, x2 = x * x, x3 = x2 * x, x4 = x3 * x, x5 = x4 * x;
  const double p1 = 0.5 * x4 - x3 + x + kappa * (0.25 * x4 - 2.0 / 3.0 * x3 + 0.5 * x2);
  const double p2 = 0.1 * x5 - 0.25 * x4 + 0.5 * x2 + kappa * (0.05 * x5 - x4 / 6.0 + x3 / 6.0);
  if (qd) *qd = sign * (w_a - decel * t_b * p1);
  return q_a + sign * (w_a * s - decel * t_b * t_b * p2);
}

double JointBrake::torqueAt(double tau) const {
  if (tau >= t_stop) return 0.0;
  if (tau >= t_a) {
    const double x = (tau - t_a) / t_b, x2 = x * x, x3 = x2 * x;
    return -sign * torque * (2.0 * x3 - 3.0 * x2 + 1.0 + kappa * (x3 - 2.0 * x2 + x));
  }
  // Above the corner speed (w_a) the torque falls with the envelope, as the deceleration does.
  return -sign * torque * (w_nl - w0) * std::exp(lambda * tau) / (w_nl - w_a);
}

// Each joint brakes with torque_share of its drive's torque (kBrakeTorqueShare; a backflip's
// front pair at t1 settings.flip_front_brake_share). Its deceleration is that of
// the leg as a fixed-base two-link arm (at the start's knee angle) under both joints' braking
// torques, M^-1 tau: when the legs extend, hip and knee turn opposite ways and each joint's
// torque also slows the other; where it would not (a joint turning the other way), the joint's
// own share, tau / (M^-1)_jj^-1. This leaves out that the body gives way in flight (Simbody's
// knees stop faster at the same torque) and that the help ends when the other joint is at rest.
std::array<JointBrake, 2> startBrake(const JumpModelConstants& M, int pair,
                                     const Eigen::Vector2d& q, const Eigen::Vector2d& qd,
                                     double torque_share) {
  const JumpModelConstants::LegInertia& li = M.leg_inertia[pair];
  const double cross = li.m_l1_c * std::cos(q[1]);
  const double m11 = li.i_hip + 2.0 * cross, m12 = li.i_knee + cross, m22 = li.i_knee;
  const double det = m11 * m22 - m12 * m12;
  const double tau_hfe = torque_share * M.env_hfe.peak_torque_nm;
  const double tau_kfe = torque_share * M.env_kfe.peak_torque_nm;
  // Braking torques (against each joint's motion) and the decelerations they give.
  const double t1 = qd[0] < 0.0 ? tau_hfe : -tau_hfe, t2 = qd[1] < 0.0 ? tau_kfe : -tau_kfe;
  const double a1 = (m22 * t1 - m12 * t2) / det, a2 = (m11 * t2 - m12 * t1) / det;
  const double d1 = std::max(tau_hfe * m22 / det, qd[0] < 0.0 ? a1 : -a1);
  const double d2 = std::max(tau_kfe * m11 / det, qd[1] < 0.0 ? a2 : -a2);
  std::array<JointBrake, 2> b;
  b[0].start(q[0], qd[0], d1, tau_hfe, M.env_hfe);
  b[1].start(q[1], qd[1], d2, tau_kfe, M.env_kfe);
  return b;
}

double frontLiftBrakeShare(const JumpModelConstants& M) {
  return M.task.isBackflip() ? M.settings.flip_front_brake_share : kBrakeTorqueShare;
}

Eigen::Vector2d brakeTorque(const std::array<JointBrake, 2>& b, double tau) {
  return Eigen::Vector2d(b[0].torqueAt(tau), b[1].torqueAt(tau));
}

Eigen::Vector2d brakePosture(const std::array<JointBrake, 2>& b, double tau, Eigen::Vector2d* qd) {
  Eigen::Vector2d q;
  for (int j = 0; j < 2; ++j) q[j] = b[j].at(tau, qd ? &(*qd)[j] : nullptr);
  return q;
}

// The flight attitude and the touchdown state of a solved take-off.
void solveFlight(const JumpModelConstants& M, Solved& S) {
  S.brake_end = 0.0;
  for (int pair = 0; pair < 2; ++pair) {
    const PairSample& to = S.takeoff_sample.pair(pair);
    S.brake[pair] = startBrake(M, pair, to.q, to.qd);
    for (const JointBrake& b : S.brake[pair]) S.brake_end = std::max(S.brake_end, b.t_stop);
    for (int j = 0; j < 2; ++j) S.tuck_duration[pair][j] = tuckDuration(M, S, pair, j);
  }
  addUnloadingTailMoment(M, S);
  integrateFlightAttitude(M, S);
  S.t3 = S.t2 + S.Tf;
  S.t3 = touchdownTime(M, S);
  S.touchdown = stateAt(M, S, S.t3, M.settings.gravity);
}

// The state in flight: ballistic CoM, attitude from the table (cubic Hermite).
PlanarState flightState(const JumpModelConstants& M, const Solved& S, double t) {
  PlanarState s = ballisticG(S.takeoff, t - S.t2, M.settings.gravity);
  const double u = std::clamp((t - S.t2) / S.Tf, 0.0, 1.0) * S.n_flight;
  const int k = std::min(static_cast<int>(u), S.n_flight - 1);
  const double a = u - k, dt = S.Tf / S.n_flight;
  const double h00 = 2 * a * a * a - 3 * a * a + 1, h10 = a * a * a - 2 * a * a + a;
  const double h01 = -2 * a * a * a + 3 * a * a, h11 = a * a * a - a * a;
  s.pitch = h00 * S.flight_pitch[k] + h10 * dt * S.flight_rate[k] + h01 * S.flight_pitch[k + 1] +
            h11 * dt * S.flight_rate[k + 1];
  // The Hermite's own derivative, so that a plan's pitch and pitch rate agree (knots).
  const double d00 = 6 * a * a - 6 * a, d10 = 3 * a * a - 4 * a + 1;
  const double d01 = -6 * a * a + 6 * a, d11 = 3 * a * a - 2 * a;
  s.pitch_rate = (d00 * S.flight_pitch[k] + d01 * S.flight_pitch[k + 1]) / dt +
                 d10 * S.flight_rate[k] + d11 * S.flight_rate[k + 1];
  return s;
}

// The tuck from rest, done by tuck_end at the earliest. The smoothstep tuck (the default) of the
// hind pair is slower if its peak speed (1.5 dq / T) would pass kTuckSpeedShare of the no-load
// speed; the front pair's is not limited (its wheels must clear an obstacle first). The
// drive-limited tuck (postures.drive_limited_tuck) of either pair lasts at least as long as a
// constant-acceleration profile at kTuckTorqueShare of the peak torque over the fixed-base
// leg's inertia about the joint (at the knee angle where the knee came to rest), whose peak
// speed (2 dq / T) stays within kTuckSpeedShare of the no-load speed. Either ends by
// extend_start at the latest.
double tuckDuration(const JumpModelConstants& M, const Solved& S, int pair, int j) {
  const auto& st = M.settings;
  const JointBrake& b = S.brake[pair][j];
  const double dq = std::abs((j == 0 ? st.tuck_hfe_rad : st.tuck_kfe_rad) - b.q_stop);
  const model::ActuatorEnvelope& env = j == 0 ? M.env_hfe : M.env_kfe;
  const double t_tuck = st.tuck_end_fraction * S.Tf - b.t_stop;
  const double t_latest = M.extend_start * S.Tf - b.t_stop;
  const double w_max = kTuckSpeedShare * env.no_load_speed_rad_s;
  if (st.drive_limited_tuck) {
    // (Capping the peak at the speed where the envelope still has the acceleration's torque,
    // 24 of 40 rad/s, was measured and not kept: the forward jump kept 3 mm from its wall in
    // Simbody; docs/planner.md, "The drive-limited tuck".)
    const double t_min =
        std::max(2.0 * std::sqrt(dq / tuckAcceleration(M, S, pair, j)), 2.0 * dq / w_max);
    return std::min(std::max(t_tuck, t_min), t_latest);
  }
  if (pair == 1) return t_tuck;  // the front wheels must clear an obstacle first
  return std::min(std::max(t_tuck, 1.5 * dq / w_max), t_latest);
}

// (HFE, KFE) of a pair in flight at time t: from the take-off posture and speeds the joints
// brake to rest (JointBrake), then move to the tuck posture by tuck_end (a fraction of the
// flight), hold it, and move to the landing posture over [extend_start, extend_end], with
// smoothstep blends.
Eigen::Vector2d flightPosture(const JumpModelConstants& M, const Solved& S, int pair, double t,
                              Eigen::Vector2d* qd) {
  const auto& st = M.settings;
  const double tau = t - S.t2, xi = tau / S.Tf;
  const Eigen::Vector2d q_tuck(st.tuck_hfe_rad, st.tuck_kfe_rad);
  if (tau < M.extend_start * S.Tf || tau < S.brake_end) {
    Eigen::Vector2d q;
    for (int j = 0; j < 2; ++j) {
      const JointBrake& b = S.brake[pair][j];
      const double dq = q_tuck[j] - b.q_stop, T = S.tuck_duration[pair][j];
      double rate = 0.0;
      if (tau < b.t_stop) {
        q[j] = b.at(tau, &rate);
      } else if (T > 0.0 && tau < b.t_stop + T) {
        const double u = (tau - b.t_stop) / T;
        q[j] = b.q_stop + dq * (st.drive_limited_tuck ? bangBang(u) : smoothstep(u));
        rate = dq * (st.drive_limited_tuck ? bangBangRate(u) : smoothstepRate(u)) / T;
      } else {
        q[j] = q_tuck[j];  // tucked (or the brake outlasted the tuck: a very short flight)
      }
      if (qd) (*qd)[j] = rate;
    }
    return q;
  }
  const double a = M.extend_start, T = (st.extend_end_fraction - a) * S.Tf;
  const double u = (xi - a) / (st.extend_end_fraction - a);
  if (qd) *qd = (M.q_landing - q_tuck) * smoothstepRate(u) / T;
  return q_tuck + (M.q_landing - q_tuck) * smoothstep(u);
}

}  // namespace wj::planner::detail
