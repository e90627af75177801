// The stance torques' accelerations (planner/src/jump_model_stance_dynamics.h) against finite
// differences of converged contact samples: the joints' from their rates, the base origin's
// from its position, over each contact segment of every preset and the backflip, its first
// and last instants included (one-sided differences there); the whole robot's momentum rate,
// and the pairs' balanced split that makes it.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>

#include "jump_model_internal.h"
#include "jump_model_stance_dynamics.h"
#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"

namespace wj::planner::detail {
namespace {

// A converged sample (to 1e-14 m, so that the differences see no iteration noise).
Sample sampleAt(const JumpModelConstants& M, const Solved& S, double t, bool phase2) {
  Sample smp;
  contactSample(M, S, t, smp, phase2, M.c0, /*converge=*/true, 1e-14);
  return smp;
}

// The derivative at t of f over [a, b], second order: central, or one-sided at an end.
template <class F>
auto derivativeAt(F f, double t, double a, double b, double h) {
  if (t - h < a) return ((-3.0 * f(t) + 4.0 * f(t + h) - f(t + 2.0 * h)) / (2.0 * h)).eval();
  if (t + h > b) return ((3.0 * f(t) - 4.0 * f(t - h) + f(t - 2.0 * h)) / (2.0 * h)).eval();
  return ((f(t + h) - f(t - h)) / (2.0 * h)).eval();
}

// The second derivative likewise (one-sided: the four-point formula, second order).
template <class F>
auto secondDerivativeAt(F f, double t, double a, double b, double h) {
  if (t - h < a)
    return ((2.0 * f(t) - 5.0 * f(t + h) + 4.0 * f(t + 2.0 * h) - f(t + 3.0 * h)) / (h * h)).eval();
  if (t + h > b)
    return ((2.0 * f(t) - 5.0 * f(t - h) + 4.0 * f(t - 2.0 * h) - f(t - 3.0 * h)) / (h * h)).eval();
  return ((f(t + h) - 2.0 * f(t) + f(t - h)) / (h * h)).eval();
}

// A preset's plan (the DE's, seed 7, 2 threads) solved by its model.
struct SolvedPreset {
  Scenario sc;
  JumpModel model;
  Solved S;
  bool solved = false;
  SolvedPreset(const JumpPlanner& planner, const char* task)
      : sc(makePreset(planner, task)),
        model(planner.robot(), planner.settings(), sc.task, sc.initial) {
    PlanOptions opts;
    opts.seed = 7;
    opts.threads = 2;
    solved = solve(model.constants(), planner.plan(sc.task, sc.initial, opts).u, S);
  }
};

// Each contact sample's joint rates against differences of its neighbours' angles, and its
// accelerations against differences of their rates and base positions, over every preset and
// the backflip with `settings`.
void checkAccelerations(const PlannerSettings& settings) {
  const auto robot = model::RobotModel::loadDefault();
  const JumpPlanner planner(robot, settings);
  for (const char* task : {"forward_hw", "forward", "vertical", "backflip"}) {
    SCOPED_TRACE(task);
    SolvedPreset preset(planner, task);
    ASSERT_TRUE(preset.solved);
    const JumpModelConstants& M = preset.model.constants();
    const Solved& S = preset.S;
    const StanceDynamics D(M, S);
    // The contact segments: [0, t1] on four wheels and (t1, t2] on the hind pair if two-step.
    struct Segment {
      double a, b;
      bool phase2;
    };
    std::vector<Segment> segments{{0.0, S.two_step ? S.t1 : S.t2, false}};
    if (S.two_step) segments.push_back({S.t1, S.t2, true});
    double worst_qd = 0.0, worst_qdd = 0.0, worst_base = 0.0;
    int checked = 0;
    for (const Segment& seg : segments) {
      // Inside a two-step's hind-only segment the lifted front pair's braking has corners
      // (its envelope-limited part's end, rest), where q'' jumps: differences skip them.
      auto across_corner = [&](double t, double reach) {
        if (!seg.phase2) return false;
        for (const JointBrake& b : S.front_brake)
          for (const double corner : {S.t1 + b.t_a, S.t1 + b.t_stop})
            if (std::abs(t - corner) <= reach) return true;
        return false;
      };
      constexpr int kPoints = 41;
      for (int k = 0; k < kPoints; ++k) {
        const double t = seg.a + (seg.b - seg.a) * k / (kPoints - 1);
        if (across_corner(t, 4e-4)) continue;
        const Sample smp = sampleAt(M, S, t, seg.phase2);
        const StanceAccelerations acc = stanceAccelerations(M, S, D, smp);
        auto rates = [&](double ti) {
          const Sample s = sampleAt(M, S, ti, seg.phase2);
          Eigen::Vector4d v;
          v << s.hind.qd, s.front.qd;
          return v;
        };
        auto base = [&](double ti) {
          const Sample s = sampleAt(M, S, ti, seg.phase2);
          return Eigen::Vector2d(Eigen::Vector2d(s.s.x, s.s.z) - s.R * s.c);
        };
        auto angles = [&](double ti) {
          const Sample s = sampleAt(M, S, ti, seg.phase2);
          Eigen::Vector4d v;
          v << s.hind.q, s.front.q;
          return v;
        };
        Eigen::Vector4d qd;
        qd << smp.hind.qd, smp.front.qd;
        worst_qd = std::max(
            worst_qd, (qd - derivativeAt(angles, t, seg.a, seg.b, 1e-6)).cwiseAbs().maxCoeff() /
                          std::max(1.0, qd.cwiseAbs().maxCoeff()));
        const Eigen::Vector4d qdd_fd = derivativeAt(rates, t, seg.a, seg.b, 1e-6);
        const Eigen::Vector2d base_fd = secondDerivativeAt(base, t, seg.a, seg.b, 1e-4);
        Eigen::Vector4d qdd;
        qdd << acc.qdd[0], acc.qdd[1];
        // Relative to the size of the accelerations (up to ~1,000 rad/s^2 at the knees).
        worst_qdd = std::max(worst_qdd, (qdd - qdd_fd).cwiseAbs().maxCoeff() /
                                            std::max(1.0, qdd.cwiseAbs().maxCoeff()));
        worst_base =
            std::max(worst_base, (acc.base - base_fd).norm() / std::max(1.0, acc.base.norm()));
        EXPECT_NEAR((acc.base_pos - base(t)).norm(), 0.0, 1e-12);
        ++checked;
      }
    }
    std::cout << task << ": " << checked << " samples, largest relative difference q' " << worst_qd
              << ", q'' " << worst_qdd << ", base " << worst_base << "\n";
    EXPECT_GT(checked, 40);
    EXPECT_LT(worst_qd, 1e-6);
    EXPECT_LT(worst_qdd, 1e-6);
    EXPECT_LT(worst_base, 1e-3);
  }
}

TEST(StanceDynamics, AccelerationsMatchFiniteDifferencesOfTheContactSamples) {
  checkAccelerations(PlannerSettings{});
}

// The same with the tyres' sink (PlannerSettings::tyre_contact_modulus_pa at Simbody's
// wheels'): the axles rise out of it as the push unloads them, at its rate and acceleration.
TEST(StanceDynamics, AccelerationsMatchFiniteDifferencesWithTheTyresSink) {
  PlannerSettings settings;
  settings.tyre_contact_modulus_pa = 8e6 / std::pow(2.0, 1.5);
  checkAccelerations(settings);
}

// The rate of the whole robot's angular momentum about its CoM (momentumRate, a directional
// difference along the sample's rates and accelerations) against a central difference of the
// momentum of converged samples 1e-6 s apart; and the balanced split (balancePairForces): the
// pairs' moment is then that rate, their total force the model's. Over the four-wheel segment
// of every simultaneous preset, its ends included.
TEST(StanceDynamics, MomentumRateMatchesDifferencesAndTheBalanceMakesIt) {
  const auto robot = model::RobotModel::loadDefault();
  const JumpPlanner planner(robot, PlannerSettings{});
  for (const char* task : {"forward_hw", "forward", "vertical"}) {
    SCOPED_TRACE(task);
    SolvedPreset preset(planner, task);
    ASSERT_TRUE(preset.solved);
    const JumpModelConstants& M = preset.model.constants();
    const Solved& S = preset.S;
    ASSERT_FALSE(S.two_step);
    const StanceDynamics D(M, S);
    auto momentum = [&](double t) {
      const Sample smp = sampleAt(M, S, t, false);
      return Eigen::Matrix<double, 1, 1>(stanceMomentumExcess(M, smp) +
                                         M.inertia * smp.s.pitch_rate);
    };
    double worst = 0.0, largest = 0.0, at_end = 0.0;
    constexpr int kPoints = 41;
    for (int k = 0; k < kPoints; ++k) {
      const double t = S.t2 * k / (kPoints - 1);
      Sample smp = sampleAt(M, S, t, false);
      const StanceAccelerations acc = stanceAccelerations(M, S, D, smp);
      const double rate = momentumRate(M, smp, acc);
      const double rate_fd = derivativeAt(momentum, t, 0.0, S.t2, 1e-6)(0);
      worst = std::max(worst, std::abs(rate - rate_fd));
      largest = std::max(largest, std::abs(rate));
      const double fz = smp.hind.f.y() + smp.front.f.y();
      const double moment_before = groundMoment(smp);
      balancePairForces(M, acc, smp);
      EXPECT_NEAR(groundMoment(smp), rate, 1e-9) << "t = " << t;
      EXPECT_NEAR(smp.hind.f.y() + smp.front.f.y(), fz, 1e-9) << "t = " << t;
      if (k == kPoints - 1) at_end = rate - moment_before;
    }
    std::cout << task << ": momentum rate within " << worst << " Nm of the differences (largest "
              << largest << " Nm); the legs' share at t2 " << at_end << " Nm\n";
    EXPECT_LT(worst, 1e-3);
    // What the rigid-body pitch leaves out is largest at the push's end (20-40 Nm, seed 7).
    EXPECT_GT(std::abs(at_end), 10.0);
  }
}

}  // namespace
}  // namespace wj::planner::detail

namespace wj::planner::detail {
namespace {

// The tyre's sink: Hertz's x = (F / k)^(2/3) above the blend force, the blend meeting its
// value, slope and curvature there, zero sink at zero force; its rate and acceleration are the
// chain rule's through a force that varies in time (against differences of x(F(t))).
TEST(TyreSink, IsHertzsLawAndItsTimeDerivatives) {
  // Simbody's wheels: E* = 8 MPa / 2^1.5 on the robot's wheel radius.
  const double r = model::RobotModel::loadDefault().wheelRadius();
  const double k = 4.0 / 3.0 * 8e6 / std::pow(2.0, 1.5) * std::sqrt(r);
  EXPECT_EQ(tyreSink(0.0, 200.0).x, 0.0);
  for (const double f : {20.0, 55.0, 200.0, 400.0})
    EXPECT_NEAR(k * std::pow(tyreSink(k, f).x, 1.5), f, 1e-9 * f) << f;
  // The standing robot's 1.4 mm (22.5 kg on four wheels; the closed loop's payload test sees
  // the base 1.7 mm low with the NMPC's rigid wheels).
  EXPECT_NEAR(tyreSink(k, 55.0).x, 1.36e-3, 0.01e-3);
  EXPECT_EQ(tyreSink(k, 0.0).x, 0.0);
  // Continuous in value, slope and curvature across the blend force.
  const double fb = kTyreSinkBlendN, e = 1e-7;
  const auto x = [&](double f) { return tyreSink(k, f).x; };
  EXPECT_NEAR(x(fb - e), x(fb + e), 1e-10);
  EXPECT_NEAR(tyreSink(k, fb - e, 1.0).rate, tyreSink(k, fb + e, 1.0).rate, 1e-11);
  EXPECT_NEAR(tyreSink(k, fb - e, 1.0).acc, tyreSink(k, fb + e, 1.0).acc, 1e-12);
  // A force that unloads through the blend to zero: F(t) = 300 - 2e4 t + 4e5 t^2 on [0, 0.02].
  const auto force = [](double t) { return 300.0 - 2e4 * t + 4e4 * t * t * 10.0; };
  const auto fd = [](double t) { return -2e4 + 8e5 * t; };
  for (double t = 0.0; t <= 0.0205; t += 0.0025) {
    const TyreSink s = tyreSink(k, force(t), fd(t), 8e5);
    const double h = 1e-6;
    const double rate = (x(force(t + h)) - x(force(t - h))) / (2.0 * h);
    const double acc = (x(force(t + h)) - 2.0 * x(force(t)) + x(force(t - h))) / (h * h);
    EXPECT_NEAR(s.rate, rate, 1e-6 * std::max(1.0, std::abs(rate))) << t;
    EXPECT_NEAR(s.acc, acc, 1e-3 * std::max(1.0, std::abs(acc))) << t;
  }
}

}  // namespace
}  // namespace wj::planner::detail
