// The flight of the jump model (docs/planner.md, "Flight"): the ballistic CoM, the legs'
// tuck-and-extend motion, and the body's attitude from the conservation of the whole robot's
// angular momentum about its CoM.

#include <algorithm>
#include <cmath>

#include "jump_model_internal.h"

namespace wj::planner::detail {

namespace {

// Flight attitude: the total angular momentum about the CoM is conserved from the lift-off
// on. It is taken from the take-off kinematics the joint controllers track (body pitch rate,
// legs still extending, wheels spinning): when the legs stop and tuck, their momentum goes
// into the body. The body's pitch rate follows, and is integrated (trapezoid).
void integrateFlightAttitude(const JumpModelConstants& M, Solved& S) {
  const int n = M.settings.samples_flight;
  S.n_flight = n;
  double i_to = 0.0, h_to = 0.0;
  flightMomentum(M, S.q_to, S.qd_to, i_to, h_to);
  const double h_y = -i_to * S.takeoff.pitch_rate + h_to;
  double prev_rate = 0.0;
  for (int k = 0; k <= n; ++k) {
    const double t = S.t2 + S.Tf * k / n;
    std::array<Eigen::Vector2d, 2> q, qd;
    for (int pair = 0; pair < 2; ++pair) q[pair] = flightPosture(M, S, S.q_to[pair], t, &qd[pair]);
    double i_total = 0.0, h = 0.0;
    flightMomentum(M, q, qd, i_total, h, &S.flight_c[k]);
    S.flight_q[0][k] = q[0];
    S.flight_q[1][k] = q[1];
    const double rate = -(h_y - h) / i_total;  // nose-up = about -y
    S.flight_rate[k] = rate;
    S.flight_pitch[k] =
        k == 0 ? S.takeoff.pitch : S.flight_pitch[k - 1] + 0.5 * (prev_rate + rate) * S.Tf / n;
    prev_rate = rate;
  }
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
  return S.wheel_to[pair] + (S.takeoff.vx / M.wheel_radius - S.wheel_to[pair]) * smoothstep(xi);
}

// The flight attitude and the touchdown state of a solved take-off.
void solveFlight(const JumpModelConstants& M, Solved& S) {
  integrateFlightAttitude(M, S);
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
  s.pitch_rate = (1 - a) * S.flight_rate[k] + a * S.flight_rate[k + 1];
  return s;
}

// (HFE, KFE) of a pair in flight at time t: from the take-off posture to the tuck posture
// over [0, tuck_end], held, then to the landing posture over [extend_start, extend_end]
// (fractions of the flight), with smoothstep blends.
Eigen::Vector2d flightPosture(const JumpModelConstants& M, const Solved& S,
                              const Eigen::Vector2d& q_takeoff, double t, Eigen::Vector2d* qd) {
  const auto& st = M.settings;
  const double xi = (t - S.t2) / S.Tf;
  const Eigen::Vector2d q_tuck(st.tuck_hfe_rad, st.tuck_kfe_rad);
  auto blend = [&](const Eigen::Vector2d& from, const Eigen::Vector2d& to, double a, double b) {
    const double T = (b - a) * S.Tf, u = (xi - a) / (b - a);
    if (qd) *qd = (to - from) * smoothstepRate(u) / T;
    return Eigen::Vector2d(from + (to - from) * smoothstep(u));
  };
  if (xi < st.tuck_end_fraction) return blend(q_takeoff, q_tuck, 0.0, st.tuck_end_fraction);
  return blend(q_tuck, M.q_landing, st.extend_start_fraction, st.extend_end_fraction);
}

}  // namespace wj::planner::detail
