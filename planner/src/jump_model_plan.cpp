// The plan export of the jump model: the dense references (buildPlan), the adaptive knots
// (buildKnots) and the header they share (phase times, force polynomials, decision vector).

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "jump_model_internal.h"
#include "jump_model_stance_dynamics.h"
#include "planner/plan_knots.h"

namespace wj::planner {

namespace detail {
namespace {

using Joints = Eigen::Matrix<double, model::kNumJoints, 1>;

// One instant of the references, except the wheel joint angles, which the caller integrates
// from the wheel rates.
struct PlanRow {
  PlanarState s;
  Joints q = Joints::Zero(), qd = Joints::Zero(), tau = Joints::Zero();
};

enum class Segment { FourWheels, HindOnly, Flight };

constexpr std::array<int, model::kNumLegs> kWheelJoints = {
    model::jointIndex(model::Leg::LF, model::JointKind::Wheel),
    model::jointIndex(model::Leg::RF, model::JointKind::Wheel),
    model::jointIndex(model::Leg::LH, model::JointKind::Wheel),
    model::jointIndex(model::Leg::RH, model::JointKind::Wheel)};

Segment segmentAt(const Solved& S, double t) {
  if (t > S.t2) return Segment::Flight;
  return S.two_step && t > S.t1 ? Segment::HindOnly : Segment::FourWheels;
}

// The references at time t in `segment` (the segment's own values at its boundaries).
// `c_guess` warm-starts the contact sample's CoM-offset iteration and is updated.
void planRow(const JumpModelConstants& M, const Solved& S, const StanceDynamics& D, double t,
             Segment segment, Eigen::Vector2d& c_guess, PlanRow& out) {
  using model::JointKind;
  using model::Leg;
  std::array<Eigen::Vector2d, 2> q, qd;
  std::array<double, 2> wheel_rate{}, wheel_tau{}, haa_fz{};
  out.tau.setZero();
  Sample smp;
  StanceAccelerations acc;
  if (segment != Segment::Flight) {
    contactSample(M, S, t, smp, segment == Segment::HindOnly, c_guess,
                  /*converge=*/true);
    c_guess = smp.c;
    acc = stanceAccelerations(M, S, D, smp);
    // The pairs' normal forces that make the moment the motion needs (docs/planner.md, "The
    // balanced stance"); a two-step take-off (the backflips) keeps the model's split, as does
    // every take-off without settings.balanced_stance.
    if (!S.two_step && M.settings.balanced_stance) balancePairForces(M, acc, smp);
    out.s = smp.s;
    int i = 0;
    for (const PairSample* p : {&smp.hind, &smp.front}) {
      q[i] = p->q;
      qd[i] = p->qd;  // a lifted front pair: its braking
      wheel_rate[i] = p->wheel_rate;
      wheel_tau[i] = p->contact ? p->wheel_tau : 0.0;
      haa_fz[i] = p->contact ? p->haa_fz : 0.0;
      ++i;
    }
    for (int pair = 0; pair < 2; ++pair) {
      const PairSample& p = pair == 0 ? smp.hind : smp.front;
      for (const Leg leg : model::kLegs) {
        if ((pair == 0) == model::isFront(leg)) continue;
        out.tau[model::jointIndex(leg, JointKind::HFE)] = p.contact ? p.tau[0] : 0.0;
        out.tau[model::jointIndex(leg, JointKind::KFE)] = p.contact ? p.tau[1] : 0.0;
      }
    }
  } else {
    out.s = flightState(M, S, t);
    for (int pair = 0; pair < 2; ++pair) {
      q[pair] = flightPosture(M, S, pair, t, &qd[pair]);
      wheel_rate[pair] = flightWheelRate(M, S, pair, t);
    }
  }
  // The legs' braking torques after their lift-off: the hind pair's (and a simultaneous
  // take-off's front pair's) from t2, a two-step take-off's front pair's from t1.
  std::array<Eigen::Vector2d, 2> brake_tau = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  if (segment == Segment::Flight)
    for (int pair = 0; pair < 2; ++pair) brake_tau[pair] = brakeTorque(S.brake[pair], t - S.t2);
  if (segment == Segment::HindOnly) brake_tau[1] = brakeTorque(S.front_brake, t - S.t1);
  for (const Leg leg : model::kLegs) {
    const int pair = model::isFront(leg) ? 1 : 0;
    const int haa = model::jointIndex(leg, JointKind::HAA);
    const double lever =
        M.robot.legGeometry(leg).p_HT.y() + M.robot.legGeometry(leg).wheel_lateral_offset;
    out.q[haa] = M.init_input.q[haa];
    out.qd[haa] = 0.0;
    out.tau[haa] = -lever * haa_fz[pair];
    out.q[haa + 1] = q[pair][0];
    out.q[haa + 2] = q[pair][1];
    if (segment == Segment::Flight || (segment == Segment::HindOnly && pair == 1)) {
      out.tau[haa + 1] = brake_tau[pair][0];
      out.tau[haa + 2] = brake_tau[pair][1];
    }
    out.qd[haa + 1] = qd[pair][0];
    out.qd[haa + 2] = qd[pair][1];
    out.qd[haa + 3] = wheel_rate[pair];
    out.tau[haa + 3] = wheel_tau[pair];
  }
  // The legs' own dynamics in place of the statics (docs/planner.md, "Stance torques"), and
  // in flight the torques that move them along the references.
  if (segment != Segment::Flight)
    addStanceTorques(M, D, smp, acc, out.tau);
  else if (M.settings.flight_feedforward)
    flightTorques(M, D, S, t, out.tau);
}

// D = [s(t1/2), s(t2), s(t3), t1, t2, t3] of a solved candidate.
Eigen::VectorXd decisionOf(const Solved& S) {
  Eigen::VectorXd D(12);
  D << S.mid.x, S.mid.z, S.mid.pitch, S.takeoff.x, S.takeoff.z, S.takeoff.pitch, S.touchdown.x,
      S.touchdown.z, S.touchdown.pitch, S.t1, S.t2, S.t3;
  return D;
}

// The plan's phase times, force polynomials, postures and decision vector: all but the sampled
// trajectory.
void fillPlanHeader(const Solved& S, const JumpTask& task, const InitialState& init,
                    const Eigen::Vector2d& q_landing, const PlanarState& initial, JumpPlan& plan) {
  using model::JointKind;
  plan.mode = task.mode;
  plan.t1 = S.t1;
  plan.t2 = S.t2;
  plan.t3 = S.t3;
  ForcePhase p1;
  p1.t_start = 0.0;
  p1.t_end = S.t1;
  p1.hind = {toPolynomial(S.fHx1), toPolynomial(S.fHz1)};
  p1.front = {toPolynomial(S.fFx1), toPolynomial(S.fFz1)};
  plan.force_phases.push_back(p1);
  if (S.two_step) {
    ForcePhase p2;
    p2.t_start = S.t1;
    p2.t_end = S.t2;
    p2.hind = {toPolynomial(S.fHx2), toPolynomial(S.fHz2)};
    p2.front = {Polynomial{{0.0}}, Polynomial{{0.0}}};
    plan.force_phases.push_back(p2);
  }
  plan.initial = initial;
  plan.q_initial = init.q;
  plan.q_landing = init.q;
  for (const model::Leg leg : model::kLegs) {
    plan.q_landing[model::jointIndex(leg, JointKind::HFE)] = q_landing[0];
    plan.q_landing[model::jointIndex(leg, JointKind::KFE)] = q_landing[1];
  }
  plan.decision = decisionOf(S);
}

/// The candidate's trajectory; `caller` names the JumpModel function in the error.
Solved solvedOrThrow(const JumpModelConstants& k, const Eigen::Ref<const Eigen::VectorXd>& u,
                     const char* caller) {
  Solved S;
  if (!solve(k, u, S))
    throw std::runtime_error(std::string("JumpModel::") + caller +
                             ": candidate has no valid trajectory");
  return S;
}

// The knots' tolerances at an interval's midpoint: joint position [rad], velocity [rad/s], and
// torque [Nm] (against the chord while refining, then against densify()'s curve).
constexpr double kKnotQTol = 5e-4;
constexpr double kKnotQdTol = 0.05;
constexpr double kKnotTauTol = 0.25;
// ... at the three points checked against densify()'s curve: a fifth is kept for the error
// between them (0.254 Nm at 1 kHz with 0.25 there on a standing jump).
constexpr double kKnotSlopeTauTol = 0.2;

// One knot of buildKnots, with the wheels' rates at the middle of the interval ending at it
// (Simpson's rule for the wheel angles).
struct Knot {
  double t;
  Segment segment;
  PlanRow row;
  Eigen::Vector4d wheel_mid_rate = Eigen::Vector4d::Zero();
};

// densify() interpolates the torques between knots with slopes from finite differences over
// three knots, which the chord test of the refinement does not see: next to a corner of the
// legs' braking (its corner speed, rest) or a phase's steep start the slopes of one side leak
// into the other. Every interval whose torques at a quarter, half and three quarters on that
// curve miss the plan's by more than kKnotSlopeTauTol is halved (down to min_dt / 8: the braking's
// ramps last a few milliseconds), and its neighbours, whose slopes change, are checked again.
void splitForTorqueSlopes(const JumpModelConstants& M, const Solved& S, const StanceDynamics& D,
                          double min_dt, Eigen::Vector2d c_guess, std::vector<Knot>& knots) {
  std::vector<char> check(knots.size(), 1);  // the interval ending at each knot
  for (int pass = 0; pass < 16; ++pass) {
    PlanKnots K;
    const int n = static_cast<int>(knots.size());
    K.t.resize(n);
    K.tau.resize(n, model::kNumJoints);
    for (int k = 0; k < n; ++k) {
      K.t[k] = knots[k].t;
      K.tau.row(k) = knots[k].row.tau.transpose();
    }
    const Eigen::MatrixXd slope = knotTorqueSlopes(K);
    std::vector<Knot> out;
    std::vector<char> split_at;  // per knot of `out`: its interval was just split
    out.reserve(2 * knots.size());
    out.push_back(knots.front());
    split_at.push_back(0);
    bool split = false;
    for (int k = 1; k < n; ++k) {
      const Knot &a = knots[k - 1], &b = knots[k];
      const double h = b.t - a.t;
      std::array<PlanRow, 3> rows;  // at a quarter, half and three quarters
      bool miss = false;
      if (check[k] && h > 0.25 * min_dt) {
        for (int i = 0; i < 3; ++i) {
          const double x = 0.25 * (i + 1), x2 = x * x, x3 = x2 * x;
          const double h00 = 2 * x3 - 3 * x2 + 1, h10 = (x3 - 2 * x2 + x) * h;
          const double h01 = -2 * x3 + 3 * x2, h11 = (x3 - x2) * h;
          planRow(M, S, D, a.t + x * h, a.segment, c_guess, rows[i]);
          for (int j = 0; j < model::kNumJoints && !miss; ++j) {
            const double tau = h00 * K.tau(k - 1, j) + h10 * slope(k - 1, j) + h01 * K.tau(k, j) +
                               h11 * slope(k, j);
            miss = std::abs(tau - rows[i].tau[j]) > kKnotSlopeTauTol;
          }
        }
      }
      if (!miss) {
        out.push_back(b);
        split_at.push_back(0);
        continue;
      }
      split = true;
      Knot m{a.t + 0.5 * h, a.segment, rows[1], {}};
      Knot second = b;
      for (int i = 0; i < 4; ++i) {  // the halves' midpoints are the quarters
        m.wheel_mid_rate[i] = rows[0].qd[kWheelJoints[i]];
        second.wheel_mid_rate[i] = rows[2].qd[kWheelJoints[i]];
      }
      out.push_back(m);
      out.push_back(second);
      split_at.push_back(1);
      split_at.push_back(1);
    }
    knots.swap(out);
    if (!split) return;
    // Check again the intervals whose knots' slopes the new knots change (two either side).
    const int m = static_cast<int>(knots.size());
    check.assign(m, 0);
    for (int k = 0; k < m; ++k)
      if (split_at[k])
        for (int i = std::max(1, k - 2); i <= std::min(m - 1, k + 2); ++i) check[i] = 1;
  }
}

/// A plan with its header (phases, forces, postures, decision) filled, no samples yet.
JumpPlan planHeader(const JumpModelConstants& k, const Solved& S) {
  JumpPlan plan;
  fillPlanHeader(S, k.task, k.init_input, k.q_landing, k.initial, plan);
  return plan;
}

}  // namespace
}  // namespace detail

Eigen::VectorXd JumpModel::decisionVector(const Eigen::Ref<const Eigen::VectorXd>& u) const {
  return detail::decisionOf(detail::solvedOrThrow(k_, u, "decisionVector"));
}

JumpOutcome JumpModel::predictedOutcome(const Eigen::Ref<const Eigen::VectorXd>& u,
                                        const Evaluation* evaluation) const {
  if (evaluation != nullptr && evaluation->valid && !evaluation->cut_off)
    return evaluation->predicted;
  Evaluation ev;
  evaluate(u, ev);
  return ev.predicted;
}

JumpPlan JumpModel::buildPlan(const Eigen::Ref<const Eigen::VectorXd>& u,
                              const Evaluation* evaluation) const {
  const detail::Solved S = detail::solvedOrThrow(k_, u, "buildPlan");
  JumpPlan plan = detail::planHeader(k_, S);
  plan.dt = k_.settings.output_dt_s;
  const int N = static_cast<int>(std::ceil(S.t3 / plan.dt - 1e-9)) + 1;
  plan.centroidal.resize(N);
  // Every row is written whole below (no zero fill: 7 % of buildPlan's instructions).
  plan.q.resize(N, model::kNumJoints);
  plan.qd.resize(N, model::kNumJoints);
  plan.tau.resize(N, model::kNumJoints);
  Eigen::Vector2d c_guess = k_.c0, c_before = k_.c0;
  detail::PlanRow row;
  const detail::StanceDynamics D(k_, S);
  for (int k = 0; k < N; ++k) {
    const double t = std::min(k * plan.dt, S.t3);
    // The CoM offset's iteration starts from its linear extrapolation over the last two samples.
    const Eigen::Vector2d c_last = c_guess;
    if (k >= 2) c_guess = 2.0 * c_last - c_before;
    c_before = c_last;
    detail::planRow(k_, S, D, t, detail::segmentAt(S, t), c_guess, row);
    plan.centroidal[k] = row.s;
    plan.q.row(k) = row.q.transpose();
    plan.qd.row(k) = row.qd.transpose();
    plan.tau.row(k) = row.tau.transpose();
    // Wheel angles: the trapezoid rule over the rates.
    for (const int w : detail::kWheelJoints)
      plan.q(k, w) = k == 0 ? k_.init_input.q[w]
                            : plan.q(k - 1, w) + 0.5 * (plan.qd(k - 1, w) + plan.qd(k, w)) *
                                                     (t - std::min((k - 1) * plan.dt, S.t3));
  }
  plan.predicted = predictedOutcome(u, evaluation);
  plan.liftoff_correction = k_.liftoff_correction;
  return plan;
}

JumpPlan JumpModel::buildKnots(const Eigen::Ref<const Eigen::VectorXd>& u,
                               const Evaluation* evaluation) const {
  const detail::Solved S = detail::solvedOrThrow(k_, u, "buildKnots");
  const detail::StanceDynamics D(k_, S);
  JumpPlan plan = detail::planHeader(k_, S);
  plan.dt = 0.0;
  // Phases and the corners of the leg motion (the braking's, tucked, extending, extended),
  // where the postures' second derivatives jump: a knot sits on each.
  struct Piece {
    double a, b;
    detail::Segment segment;
  };
  std::vector<Piece> pieces;
  // Pieces of one segment from `a` to `b`, cut at the instants `cuts` (those inside).
  auto add_pieces = [&](double a, double b, detail::Segment segment, std::vector<double> cuts) {
    std::sort(cuts.begin(), cuts.end());
    double from = a;
    for (const double c : cuts) {
      if (c <= from + 1e-9 || c >= b - 1e-9) continue;
      pieces.push_back({from, c, segment});
      from = c;
    }
    pieces.push_back({from, b, segment});
  };
  // The corners of the legs' braking (the end of the envelope-limited part, and rest).
  auto brake_corners = [](double start, const std::array<detail::JointBrake, 2>& b,
                          std::vector<double>& out) {
    for (const detail::JointBrake& j : b) {
      out.push_back(start + j.t_a);
      out.push_back(start + j.t_stop);
    }
  };
  if (S.two_step) {
    pieces.push_back({0.0, S.t1, detail::Segment::FourWheels});
    std::vector<double> cuts;
    brake_corners(S.t1, S.front_brake, cuts);
    add_pieces(S.t1, S.t2, detail::Segment::HindOnly, cuts);
  } else {
    pieces.push_back({0.0, S.t2, detail::Segment::FourWheels});
  }
  std::vector<double> cuts;
  for (const double f :
       {k_.settings.tuck_end_fraction, k_.extend_start, k_.settings.extend_end_fraction})
    cuts.push_back(S.t2 + f * S.Tf);
  for (int pair = 0; pair < 2; ++pair) {
    brake_corners(S.t2, S.brake[pair], cuts);
    for (int j = 0; j < 2; ++j)  // each joint's end of the tuck
      cuts.push_back(S.t2 + S.brake[pair][j].t_stop + S.tuck_duration[pair][j]);
  }
  add_pieces(S.t2, S.t3, detail::Segment::Flight, cuts);
  // Each piece starts with even knots at most knot_dt_s apart. An interval is then halved
  // while the references at its midpoint differ from what densify() makes of its two knots by
  // more than the tolerances below (the legs move fast as they straighten at the end of the
  // push), down to output_dt_s. The midpoint rows also give the wheel angles (Simpson).
  using detail::kKnotQdTol;
  using detail::kKnotQTol;
  using detail::kKnotTauTol;
  using detail::Knot;
  std::vector<Knot> knots;
  Eigen::Vector2d c_guess = k_.c0;
  const double min_dt = k_.settings.output_dt_s;
  auto accurate = [](const Knot& a, const Knot& m, const Knot& b) {
    const double h = b.t - a.t;
    for (int j = 0; j < model::kNumJoints; ++j) {
      if (model::isWheel(j)) continue;
      const double q0 = a.row.q[j], q1 = b.row.q[j], m0 = a.row.qd[j], m1 = b.row.qd[j];
      // Cubic Hermite at s = 1/2: value and derivative.
      const double q_mid = 0.5 * (q0 + q1) + h / 8.0 * (m0 - m1);
      const double qd_mid = 1.5 * (q1 - q0) / h - 0.25 * (m0 + m1);
      if (std::abs(q_mid - m.row.q[j]) > kKnotQTol || std::abs(qd_mid - m.row.qd[j]) > kKnotQdTol ||
          std::abs(0.5 * (a.row.tau[j] + b.row.tau[j]) - m.row.tau[j]) > kKnotTauTol)
        return false;
    }
    // The body's pitch (the legs' braking turns it within a few milliseconds after a lift-off).
    const double p_mid =
        0.5 * (a.row.s.pitch + b.row.s.pitch) + h / 8.0 * (a.row.s.pitch_rate - b.row.s.pitch_rate);
    return std::abs(p_mid - m.row.s.pitch) <= kKnotQTol;
  };
  auto refine = [&](auto&& self, const Knot& a, const Knot& b) -> void {
    Knot m{0.5 * (a.t + b.t), a.segment, {}, {}};
    Eigen::Vector2d c_mid = c_guess;
    detail::planRow(k_, S, D, m.t, m.segment, c_mid, m.row);
    if (b.t - a.t > 2.0 * min_dt && !accurate(a, m, b)) {
      self(self, a, m);
      self(self, m, b);
      return;
    }
    Knot accepted = b;
    for (int i = 0; i < 4; ++i) accepted.wheel_mid_rate[i] = m.row.qd[detail::kWheelJoints[i]];
    knots.push_back(accepted);
  };
  const double h_max = k_.settings.knot_dt_s;
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    const Piece& p = pieces[i];
    const int n = std::max(1, static_cast<int>(std::ceil((p.b - p.a) / h_max - 1e-9)));
    // A piece continues the one before it in the same segment: its first knot is that
    // piece's last.
    const bool continues = i > 0 && p.segment == pieces[i - 1].segment;
    Knot prev{p.a, p.segment, {}, {}};
    if (continues) {
      prev = knots.back();
    } else {
      detail::planRow(k_, S, D, p.a, p.segment, c_guess, prev.row);
      knots.push_back(prev);
    }
    for (int k = 1; k <= n; ++k) {
      Knot next{k == n ? p.b : p.a + (p.b - p.a) * k / n, p.segment, {}, {}};
      detail::planRow(k_, S, D, next.t, next.segment, c_guess, next.row);
      refine(refine, prev, next);
      prev = next;
    }
  }
  detail::splitForTorqueSlopes(k_, S, D, min_dt, k_.c0, knots);
  PlanKnots& K = plan.knots;
  const int count = static_cast<int>(knots.size());
  K.t.resize(count);
  K.centroidal.resize(count);
  K.q.setZero(count, model::kNumJoints);
  K.qd.setZero(count, model::kNumJoints);
  K.tau.setZero(count, model::kNumJoints);
  for (int k = 0; k < count; ++k) {
    const Knot& kn = knots[k];
    K.t[k] = kn.t;
    K.centroidal[k] = kn.row.s;
    K.q.row(k) = kn.row.q.transpose();
    K.qd.row(k) = kn.row.qd.transpose();
    K.tau.row(k) = kn.row.tau.transpose();
    // Wheel angles: Simpson's rule over the rates of each interval, continuous across a phase
    // boundary.
    for (int i = 0; i < 4; ++i) {
      const int w = detail::kWheelJoints[i];
      if (k == 0) {
        K.q(k, w) = k_.init_input.q[w];
        continue;
      }
      const double h = kn.t - knots[k - 1].t;  // 0 at a phase boundary's second knot
      K.q(k, w) =
          K.q(k - 1, w) + h / 6.0 * (K.qd(k - 1, w) + 4.0 * kn.wheel_mid_rate[i] + kn.row.qd[w]);
    }
  }
  plan.predicted = predictedOutcome(u, evaluation);
  plan.liftoff_correction = k_.liftoff_correction;
  return plan;
}

}  // namespace wj::planner
