// Plans sent as knots (JumpModel::buildKnots, the contract's TrajectoryKnots) against the dense
// plan of the same candidate: the interpolation densify() does must reproduce the references
// the robot would have got, and malformed knots must be refused with a reason.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/plan_knots.h"
#include "planner/presets.h"
#include "test_robot.h"

namespace wj::planner {
namespace {

using wj::test::robot;

struct Errors {
  double q = 0, qd = 0, tau = 0, com = 0, com_v = 0, pitch = 0;
};

// Largest differences between two dense plans of the same period, over joints that are not
// wheels (wheel angles are integrated differently: trapezoid vs Simpson) and, separately, the
// CoM.
Errors compare(const JumpPlan& a, const JumpPlan& b) {
  Errors e;
  EXPECT_EQ(a.numSamples(), b.numSamples());
  const int n = std::min(a.numSamples(), b.numSamples());
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < model::kNumJoints; ++j) {
      if (!model::isWheel(j)) e.q = std::max(e.q, std::abs(a.q(k, j) - b.q(k, j)));
      e.qd = std::max(e.qd, std::abs(a.qd(k, j) - b.qd(k, j)));
      e.tau = std::max(e.tau, std::abs(a.tau(k, j) - b.tau(k, j)));
    }
    const PlanarState &s = a.centroidal[k], &r = b.centroidal[k];
    e.com = std::max({e.com, std::abs(s.x - r.x), std::abs(s.z - r.z)});
    e.com_v = std::max({e.com_v, std::abs(s.vx - r.vx), std::abs(s.vz - r.vz)});
    e.pitch = std::max(e.pitch, std::abs(s.pitch - r.pitch));
  }
  return e;
}

// The dense plan resampled linearly at `dt` from `coarse` (what the executor does between the
// samples of a dense plan): the error the dense contract itself carries at that period.
JumpPlan linearResample(const JumpPlan& coarse, const JumpPlan& fine) {
  JumpPlan out = fine;
  const int n = coarse.numSamples();
  for (int k = 0; k < fine.numSamples(); ++k) {
    const double t = std::min(k * fine.dt, fine.t3);
    const double s = std::clamp(t / coarse.dt, 0.0, n - 1.0);
    const int k0 = std::min(static_cast<int>(s), n - 2);
    // The last row is at t3, less than a period after the one before it.
    const double t_next = k0 + 1 == n - 1 ? coarse.t3 : (k0 + 1) * coarse.dt;
    const double a = std::clamp((t - k0 * coarse.dt) / (t_next - k0 * coarse.dt), 0.0, 1.0);
    out.q.row(k) = (1 - a) * coarse.q.row(k0) + a * coarse.q.row(k0 + 1);
    out.qd.row(k) = (1 - a) * coarse.qd.row(k0) + a * coarse.qd.row(k0 + 1);
    out.tau.row(k) = (1 - a) * coarse.tau.row(k0) + a * coarse.tau.row(k0 + 1);
    const PlanarState &c0 = coarse.centroidal[k0], &c1 = coarse.centroidal[k0 + 1];
    out.centroidal[k] = {
        (1 - a) * c0.x + a * c1.x,         (1 - a) * c0.z + a * c1.z,
        (1 - a) * c0.pitch + a * c1.pitch, (1 - a) * c0.vx + a * c1.vx,
        (1 - a) * c0.vz + a * c1.vz,       (1 - a) * c0.pitch_rate + a * c1.pitch_rate};
  }
  return out;
}

class KnotsOfAPlannedJump : public ::testing::TestWithParam<const char*> {};

TEST_P(KnotsOfAPlannedJump, ReproduceTheDensePlan) {
  PlannerSettings s;
  s.output_dt_s = 0.001;
  const JumpPlanner planner(robot(), s);
  const Scenario sc = makePreset(planner, GetParam());
  PlanOptions o;
  o.seed = 1;
  o.polish = false;
  o.max_evaluations = 3000;
  const PlannerResult r = planner.plan(sc.task, sc.initial, o);
  ASSERT_TRUE(r.evaluation.valid);
  const JumpModel m(robot(), s, sc.task, sc.initial);
  const JumpPlan truth = m.buildPlan(r.u);
  JumpPlan knots = m.buildKnots(r.u);
  EXPECT_EQ(knots.numSamples(), 0);
  EXPECT_EQ(knots.decision, truth.decision);
  EXPECT_EQ(knots.t3, truth.t3);
  EXPECT_EQ(checkKnots(knots), "");
  // Knots every knot_dt_s at most, on both sides of every phase boundary.
  const PlanKnots& K = knots.knots;
  for (int k = 1; k < K.size(); ++k) EXPECT_LE(K.t[k] - K.t[k - 1], s.knot_dt_s + 1e-12);
  const int boundaries = truth.mode == TakeoffMode::TwoStep ? 2 : 1;
  int repeated = 0;
  for (int k = 1; k < K.size(); ++k) repeated += K.t[k] == K.t[k - 1] ? 1 : 0;
  EXPECT_EQ(repeated, boundaries);
  // Every knot equals the dense plan where the two share a time (the dense plan takes the
  // ending phase's value at a boundary), to the take-off postures' fixed-point tolerance (1e-7
  // m of CoM offset): the knots' samples and the rows converge from other warm starts (equal
  // to the last bit only while they happened to share them, before session 16's t2 half-way
  // between two control instants).
  for (int k = 0; k < K.size(); ++k) {
    const double idx = K.t[k] / truth.dt;
    if (std::abs(idx - std::round(idx)) > 1e-9 || (k > 0 && K.t[k] == K.t[k - 1])) continue;
    const int i = static_cast<int>(std::lround(idx));
    for (int j = 0; j < model::kNumJoints; ++j) {
      if (model::isWheel(j)) continue;
      EXPECT_NEAR(K.q(k, j), truth.q(i, j), 1e-6) << k << " " << j;
    }
  }

  densify(knots, 0.001);
  const Errors e = compare(knots, truth);
  const Errors lin = compare(linearResample(m.buildPlan(r.u), truth), truth);  // same here
  PlannerSettings s2 = s;
  s2.output_dt_s = 0.002;
  const JumpModel m2(robot(), s2, sc.task, sc.initial);
  const Errors dense500 = compare(linearResample(m2.buildPlan(r.u), truth), truth);
  std::printf(
      "%s: %d knots; knots->1 kHz: q %.2e rad, qd %.2e rad/s, tau %.2e Nm, CoM %.2e m, v %.2e "
      "m/s, pitch %.2e rad | 500 Hz linear: q %.2e, qd %.2e, tau %.2e, CoM %.2e, v %.2e, pitch "
      "%.2e\n",
      GetParam(), K.size(), e.q, e.qd, e.tau, e.com, e.com_v, e.pitch, dense500.q, dense500.qd,
      dense500.tau, dense500.com, dense500.com_v, dense500.pitch);
  EXPECT_LE(lin.q, 1e-12);  // the identity resample, up to rounding (4 ulp on the backflip)
  // The knots are at least as faithful as the dense contract at 500 Hz with the executor's
  // linear interpolation, within these bounds.
  EXPECT_LT(e.q, 5e-4);
  EXPECT_LT(e.com, 1e-5);
  // The knots' own refinement tolerances (5e-4 rad, the body's pitch included: the legs'
  // braking after a lift-off turns it within a few milliseconds), and 0.25 Nm on densify()'s
  // torque curve (the braking's C1 ramps, checked with the finite-difference slopes).
  EXPECT_LT(e.pitch, 5e-4);
  EXPECT_LT(e.tau, 0.25);  // 0.14-0.16 (session 16; forward 0.34 with session 15's plan)
  EXPECT_LT(e.qd, 0.2);
  EXPECT_LT(e.com_v, 1e-3);
  // Wheel angles at touchdown: Simpson over the knots against the trapezoid over 0.1 ms (the
  // 1 ms trapezoid of the dense plan is off by up to 16 mrad on the backflip; wheels are
  // velocity-controlled, their angle reference is not tracked).
  PlannerSettings s3 = s;
  s3.output_dt_s = 1e-4;
  const JumpPlan fine = JumpModel(robot(), s3, sc.task, sc.initial).buildPlan(r.u);
  for (int j = 3; j < model::kNumJoints; j += 4)
    EXPECT_NEAR(knots.q(knots.numSamples() - 1, j), fine.q(fine.numSamples() - 1, j), 5e-3);
}

INSTANTIATE_TEST_SUITE_P(Presets, KnotsOfAPlannedJump,
                         ::testing::Values("forward", "forward_hw", "vertical", "backflip"));

TEST(PlanKnots, MalformedKnotsAreRefusedWithAReason) {
  const JumpPlanner planner(robot(), PlannerSettings{});
  const Scenario sc = makePreset(planner, "forward_hw");
  const JumpModel m(robot(), planner.settings(), sc.task, sc.initial);
  Eigen::VectorXd u = 0.5 * (m.lowerBounds() + m.upperBounds());
  const JumpPlan good = m.buildKnots(u);
  ASSERT_EQ(checkKnots(good), "");
  auto expectRefused = [&](JumpPlan p, const std::string& what) {
    const std::string why = checkKnots(p);
    EXPECT_NE(why.find(what), std::string::npos) << why;
    EXPECT_THROW(densify(p, 0.001), std::invalid_argument);
  };
  JumpPlan p = good;
  p.knots.t[2] = p.knots.t[1] - 1e-3;
  expectRefused(p, "must not decrease");
  p = good;
  p.knots.q(3, 1) = std::nan("");
  expectRefused(p, "not finite");
  p = good;
  p.knots.tau.conservativeResize(p.knots.size() - 1, Eigen::NoChange);
  expectRefused(p, "x 16");
  p = good;
  p.knots.t.back() += 0.01;
  expectRefused(p, "t3");
  p = good;
  p.knots.t[1] = 0.0;
  expectRefused(p, "two distinct");
  p = good;
  p.knots.t = {0.0};
  expectRefused(p, "fewer than 2");
  p = good;
  EXPECT_THROW(densify(p, 0.004), std::invalid_argument);
  EXPECT_THROW(densify(p, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace wj::planner
