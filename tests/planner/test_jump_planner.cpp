// The planner's search: the presets, a warm start from the neighbouring bin, the same plan
// at any thread count, the polish with either solver, and clear errors for bad arguments.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "error_of.h"
#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "test_robot.h"

namespace wj::planner {
namespace {

using model::JointKind;
using model::Leg;

using wj::test::robot;

JumpPlanner makePlanner(PlannerSettings s = {}) {
  return JumpPlanner(robot(), s);
}

TEST(JumpPlanner, HardwareForwardPresetIsFeasible) {
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "forward_hw");
  const PlannerResult r = planner.plan(sc.task, sc.initial);
  EXPECT_TRUE(r.evaluation.feasible) << r.summary;
  EXPECT_NEAR(r.evaluation.predicted.touchdown.state.x, sc.task.target.dx,
              planner.settings().tolerance_dx_m);
  EXPECT_GE(r.evaluation.predicted.min_obstacle_clearance, planner.settings().obstacle_margin_m);
  EXPECT_LE(r.final_cost, r.de_cost);
  EXPECT_GE(r.plan.numSamples(), static_cast<int>(r.plan.t3 / 0.002));
  EXPECT_EQ(r.plan.q.rows(), r.plan.numSamples());
}

// What the cache does on a miss: the plan of the neighbouring velocity bin as warm start. Its
// cloud of perturbations puts a feasible point in the first generations, and the polish keeps
// its margins off their bounds.
TEST(JumpPlanner, WarmStartFromTheNeighbouringBinIsFeasibleInAThirdOfAColdSearch) {
  const JumpPlanner planner = makePlanner();
  const Scenario a = makePreset(planner, "forward_hw", 3.0);
  const PlannerResult ra = planner.plan(a.task, a.initial);
  ASSERT_TRUE(ra.evaluation.feasible) << ra.summary;
  const Scenario b = makePreset(planner, "forward_hw", 3.05);
  PlanOptions o;
  o.warm_start = ra.u;
  const PlannerResult rb = planner.plan(b.task, b.initial, o);
  EXPECT_TRUE(rb.evaluation.feasible) << rb.summary;
  // A cold solve at this speed needs ~1,100-1,500 evaluations. From the sqp-polished
  // neighbour, which sits on its back-off margins, it takes 2 generations since session 16 (64
  // evaluations; 16 with session 15's plans, whose first wheel switched between the pairs at
  // the level touchdown, 11 before them); from the Ipopt-polished one, which its stall rule
  // leaves further inside, 2 (docs/planner.md).
  const long cold_evals = planner.plan(b.task, b.initial).de.evaluations;
  std::printf("warm start: %ld evaluations (%ld generations), cold %ld\n",
              static_cast<long>(rb.de.evaluations),
              static_cast<long>(rb.de.evaluations / planner.settings().de.population_size),
              cold_evals);
  EXPECT_LE(rb.de.evaluations, 12 * planner.settings().de.population_size);
  EXPECT_LT(3 * rb.de.evaluations, cold_evals);
  // The same seed and warm start give the same plan.
  EXPECT_EQ(planner.plan(b.task, b.initial, o).u, rb.u);
  // Polished with a back-off: every class keeps a margin.
  for (int i = 0; i < kNumConstraintClasses; ++i)
    EXPECT_GT(rb.evaluation.margins[i].worst, 0.0) << toString(static_cast<ConstraintClass>(i));
}

TEST(JumpPlanner, UnreachableTargetNamesTheBindingConstraints) {
  // The paper's vertical target (base apex 0.7 m) is beyond this model's knee range and
  // torque-speed envelope: the answer is a best-effort plan with the binding classes named.
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "vertical");
  const PlannerResult r = planner.plan(sc.task, sc.initial);
  EXPECT_FALSE(r.evaluation.feasible);
  EXPECT_TRUE(r.evaluation.constraints_ok) << r.summary;
  EXPECT_FALSE(r.binding.empty());
  EXPECT_THAT(r.summary, test::HasSubstr("binding")) << r.summary;
  EXPECT_LT(r.evaluation.predicted.apex.state.z, sc.task.target.height);
  EXPECT_GT(r.evaluation.predicted.apex.state.z, sc.task.target.height - 0.1);
}

// Two plans made the same DE decisions: the same best cost in every generation, the same point.
void expectSameSearch(const PlannerResult& a, const PlannerResult& b) {
  ASSERT_EQ(a.de.log.size(), b.de.log.size());
  for (std::size_t i = 0; i < a.de.log.size(); ++i)
    EXPECT_EQ(a.de.log[i].best_cost, b.de.log[i].best_cost) << "generation " << i;
  EXPECT_EQ(a.u, b.u);
}

TEST(JumpPlanner, SameSeedSamePlanAtAnyThreadCount) {
  const JumpPlanner planner = makePlanner();
  const Scenario sc = makePreset(planner, "forward");
  PlanOptions o;
  o.seed = 7;
  o.max_evaluations = 3000;
  o.polish = false;
  o.threads = 1;
  const PlannerResult a = planner.plan(sc.task, sc.initial, o);
  o.threads = 2;
  const PlannerResult b = planner.plan(sc.task, sc.initial, o);
  expectSameSearch(a, b);
  o.seed = 8;
  const PlannerResult c = planner.plan(sc.task, sc.initial, o);
  EXPECT_NE(a.u, c.u);
}

TEST(JumpPlanner, CutOffTrialsGiveTheSamePlan) {
  PlannerSettings s;
  s.de.bounded_trials = false;
  const JumpPlanner full_planner = makePlanner(s);
  s.de.bounded_trials = true;
  const JumpPlanner bounded_planner = makePlanner(s);
  const Scenario sc = makePreset(full_planner, "forward");
  PlanOptions o;
  o.seed = 3;
  o.max_evaluations = 2000;
  o.polish = false;
  o.threads = 2;
  const PlannerResult a = full_planner.plan(sc.task, sc.initial, o);
  const PlannerResult b = bounded_planner.plan(sc.task, sc.initial, o);
  expectSameSearch(a, b);
}

TEST(JumpPlanner, PolishBetweenAttemptsStopsAtTheFirstFeasiblePolish) {
  // Forward preset, seed 7: the first DE attempt ends trapped next to a feasible plan (seed 2
  // until the legs braked after the lift-off, seed 4 until the balanced stance of session 18,
  // seed 11 until session 33's flight attitude; seed 7 now restarts three times without the
  // polish between attempts, 5600 evaluations, and stops after the first with it, 832).
  PlannerSettings s;
  s.polish_between_attempts = false;
  const JumpPlanner after_all = makePlanner(s);
  s.polish_between_attempts = true;
  const JumpPlanner between = makePlanner(s);
  const Scenario sc = makePreset(between, "forward");
  PlanOptions o;
  o.seed = 7;
  const PlannerResult a = after_all.plan(sc.task, sc.initial, o);
  const PlannerResult b = between.plan(sc.task, sc.initial, o);
  EXPECT_TRUE(a.evaluation.feasible);
  ASSERT_TRUE(b.evaluation.feasible) << b.summary;
  EXPECT_EQ(b.polish, PolishOutcome::Improved);
  EXPECT_EQ(b.de_restarts, 0);
  EXPECT_GT(a.de_restarts, 0);
  EXPECT_LT(b.de.evaluations, a.de.evaluations);
}

PlannerSettings withPolishSolver(PolishSolver solver) {
  PlannerSettings s;
  s.polish_solver = solver;
  return s;
}

TEST(JumpPlanner, PolishNeverWorsensTheCost) {
  for (const PolishSolver solver : {PolishSolver::Sqp, PolishSolver::Ipopt}) {
    const JumpPlanner planner = makePlanner(withPolishSolver(solver));
    for (const auto& name : presetNames()) {
      const Scenario sc = makePreset(planner, name);
      PlanOptions o;
      o.max_evaluations = 2000;  // a rough DE result leaves room for the polish
      const PlannerResult r = planner.plan(sc.task, sc.initial, o);
      EXPECT_LE(r.final_cost, r.de_cost) << name << ' ' << toString(solver);
      EXPECT_NE(r.polish, PolishOutcome::NotRun) << name << ' ' << toString(solver);
    }
  }
}

TEST(JumpPlanner, PolishSameSeedSamePlanAtAnyThreadCountWithEitherSolver) {
  // The polish's threads share its finite-difference Jacobians column by column: the same
  // numbers as one thread computing them all.
  for (const PolishSolver solver : {PolishSolver::Sqp, PolishSolver::Ipopt}) {
    const JumpPlanner planner = makePlanner(withPolishSolver(solver));
    const Scenario sc = makePreset(planner, "forward_hw");
    PlanOptions o;
    o.seed = 5;
    o.threads = 1;
    const PlannerResult a = planner.plan(sc.task, sc.initial, o);
    o.threads = 3;
    const PlannerResult b = planner.plan(sc.task, sc.initial, o);
    ASSERT_GT(a.polish_iterations, 0) << toString(solver);
    EXPECT_EQ(a.u, b.u) << toString(solver);
    EXPECT_EQ(a.polish_iterations, b.polish_iterations) << toString(solver);
    EXPECT_EQ(a.polish, b.polish) << toString(solver);
  }
}

TEST(JumpPlanner, PolishMeetsTheTargetWhenFeasibleWithEitherSolver) {
  // forward_hw is feasible on every seed but one. The solvers return the best point that met
  // the polish's constraints to 1e-6, or else their last iterate, which the planner keeps if
  // the full evaluation finds it feasible and cheaper: the target errors stay far inside the
  // cost tolerances (5 cm, 0.25 rad) either way. Since session 33's flight attitude the DE
  // ends seed 7 10.7 cm short of the target's dx (cost 4.7), which the SQP polishes onto the
  // target and Ipopt's 15 iterations do not reach: that plan meets every constraint and is no
  // worse than the DE's.
  for (const PolishSolver solver : {PolishSolver::Sqp, PolishSolver::Ipopt}) {
    const JumpPlanner planner = makePlanner(withPolishSolver(solver));
    const Scenario sc = makePreset(planner, "forward_hw");
    int improved = 0, short_of_target = 0;
    // Ipopt over twelve seeds since session 18 (below).
    const std::uint64_t seeds = solver == PolishSolver::Ipopt ? 12 : 3;
    for (std::uint64_t seed = 1; seed <= seeds; ++seed) {
      PlanOptions o;
      o.seed = seed;
      const PlannerResult r = planner.plan(sc.task, sc.initial, o);
      if (solver == PolishSolver::Ipopt && !r.evaluation.feasible) {
        ++short_of_target;
        EXPECT_TRUE(r.evaluation.constraints_ok) << "seed " << seed << ' ' << r.summary;
        EXPECT_LE(r.final_cost, r.de_cost) << "seed " << seed;
        continue;
      }
      ASSERT_TRUE(r.evaluation.feasible)
          << toString(solver) << " seed " << seed << ' ' << r.summary;
      EXPECT_NE(r.polish, PolishOutcome::Failed) << toString(solver) << " seed " << seed;
      EXPECT_LE(r.final_cost, r.de_cost);
      if (r.polish != PolishOutcome::Improved) continue;  // the DE's plan is kept as it was
      ++improved;
      // The SQP converges onto the target; Ipopt may stop at its 15 iterations short of it,
      // inside the tolerances.
      const double tol_dx = solver == PolishSolver::Sqp ? 1e-3 : planner.settings().tolerance_dx_m;
      const double tol_pitch =
          solver == PolishSolver::Sqp ? 1e-3 : planner.settings().tolerance_pitch_rad;
      EXPECT_LT(std::abs(r.evaluation.err_dx), tol_dx) << toString(solver) << " seed " << seed;
      EXPECT_LT(std::abs(r.evaluation.err_pitch), tol_pitch)
          << toString(solver) << " seed " << seed;
    }
    // Ipopt improved one seed of three in session 16 (two before): a take-off with the
    // unloading tail ends half-way between two control instants, so t1 is flat within a period
    // and the polish moves the other six take-off variables only. Since session 18's balanced
    // unloading tail, whose moment follows the legs' accelerations at t2, it improves two of
    // twelve (seeds 10 and 11) within its 15 iterations; the SQP every one.
    EXPECT_GE(improved, solver == PolishSolver::Ipopt ? 1 : 2) << toString(solver);
    EXPECT_LE(short_of_target, 1) << toString(solver);
  }
}

TEST(JumpPlanner, OutOfReachTargetIsApproachedWithinTheConstraintsWithEitherSolver) {
  // Most of a backward turn (3.1 rad, just short of a backflip's pi: the two-step box) from
  // standing at 42 Nm is out of reach: the DE's best meets every constraint and misses the
  // rotation. The polish then minimises the target cost with the constraints hard (closest
  // approach): the answer still meets every constraint and comes closer to the target. (The
  // backflip preset served here until session 12; since its hind contact's roll starts from
  // its phase-1 speed, no DE point of it meets every constraint.)
  for (const PolishSolver solver : {PolishSolver::Sqp, PolishSolver::Ipopt}) {
    const JumpPlanner planner = makePlanner(withPolishSolver(solver));
    Scenario sc = makePreset(planner, "backflip");
    sc.task.target.pitch_change = 3.1;
    ASSERT_FALSE(sc.task.isBackflip());
    int closer = 0;
    for (const std::uint64_t seed : {3u, 5u, 7u}) {
      PlanOptions o;
      o.seed = seed;
      PlanOptions no_polish = o;
      no_polish.polish = false;
      const PlannerResult de_only = planner.plan(sc.task, sc.initial, no_polish);
      ASSERT_TRUE(de_only.evaluation.constraints_ok) << "seed " << seed << ' ' << de_only.summary;
      ASSERT_FALSE(de_only.evaluation.target_ok) << "seed " << seed;
      const PlannerResult r = planner.plan(sc.task, sc.initial, o);
      EXPECT_EQ(r.polish_goal, PolishGoal::ClosestApproach) << toString(solver) << " seed " << seed;
      EXPECT_TRUE(r.evaluation.constraints_ok) << toString(solver) << " seed " << seed;
      EXPECT_LE(r.final_cost, r.de_cost) << toString(solver) << " seed " << seed;
      std::printf("%s seed %d: target cost DE %.4g, polished %.4g\n", toString(solver),
                  static_cast<int>(seed), de_only.evaluation.target_cost, r.evaluation.target_cost);
      // Closer on every seed, by 5 % on most (Ipopt since session 15's touchdown: 3.2, 4.2
      // and 19 %).
      EXPECT_LT(r.evaluation.target_cost, de_only.evaluation.target_cost)
          << toString(solver) << " seed " << seed;
      if (r.evaluation.target_cost < 0.95 * de_only.evaluation.target_cost) ++closer;
    }
    EXPECT_GE(closer, solver == PolishSolver::Ipopt ? 1 : 2) << toString(solver);
  }
}

TEST(JumpPlanner, PolishIgnoresAnIpoptOptionsFileInTheWorkingDirectory) {
  // Ipopt reads ./ipopt.opt by default; the planner's settings alone must decide the plan.
  const JumpPlanner planner = makePlanner(withPolishSolver(PolishSolver::Ipopt));
  const Scenario sc = makePreset(planner, "forward_hw");
  PlanOptions o;
  o.seed = 3;
  const PlannerResult reference = planner.plan(sc.task, sc.initial, o);
  ASSERT_GT(reference.polish_iterations, 1);
  const auto previous = std::filesystem::current_path();
  const auto dir =
      std::filesystem::temp_directory_path() / ("wj_ipopt_opt_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "ipopt.opt") << "max_iter 1\n";
  std::filesystem::current_path(dir);
  const PlannerResult r = planner.plan(sc.task, sc.initial, o);
  std::filesystem::current_path(previous);
  std::filesystem::remove_all(dir);
  EXPECT_EQ(r.polish_iterations, reference.polish_iterations);
  EXPECT_EQ(r.u, reference.u);
}

TEST(JumpPlanner, BadArgumentsGiveClearErrors) {
  const JumpPlanner planner = makePlanner();
  Scenario sc = makePreset(planner, "vertical");
  auto expectError = [&](const Scenario& s, const std::string& needle) {
    EXPECT_THAT(
        test::errorOf<std::invalid_argument>([&] { return planner.plan(s.task, s.initial); }),
        test::HasSubstr(needle));
  };
  Scenario bad = sc;
  bad.initial.v0 = std::nan("");
  expectError(bad, "initial.v0");
  // Faster than the wheels can roll: 0.085 m x 40 rad/s = 3.4 m/s, where their drives have no
  // torque left.
  EXPECT_DOUBLE_EQ(maxRunUpSpeed(planner.robot()), 0.085 * 40.0);
  bad = sc;
  bad.initial.v0 = 3.5;
  expectError(bad, "initial.v0 must be finite and in [-1, 3.4] (up to the wheels' reach");
  bad.initial.v0 = 3.39;
  EXPECT_NO_THROW(bad.initial.validate(planner.robot()));
  bad = sc;
  bad.task.target.height = -0.2;
  expectError(bad, "task.target.height must be finite and in [0.1, 1.5]");
  bad = sc;
  bad.task.obstacle = BoxObstacle{1.0, 0.9, 0.2};
  expectError(bad, "task.obstacle.x_max");
  bad = sc;
  bad.initial.q[model::jointIndex(Leg::RF, JointKind::KFE)] = 0.3;
  expectError(bad, "initial.q[RF_KFE]");
  PlanOptions o;
  o.num_candidates = 0;
  EXPECT_THROW((void)planner.plan(sc.task, sc.initial, o), std::invalid_argument);
  o = {};
  o.warm_start = Eigen::MatrixXd::Zero(3, 2);
  EXPECT_THROW((void)planner.plan(sc.task, sc.initial, o), std::invalid_argument);
  PlannerSettings s;
  s.t1_s = {0.5, 0.2};
  EXPECT_THROW((void)JumpPlanner(robot(), s), std::invalid_argument);
}

}  // namespace
}  // namespace wj::planner
