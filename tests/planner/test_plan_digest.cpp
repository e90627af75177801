// Plan digests: every preset's plan at a fixed seed, reduced to a 64-bit digest of its bits and
// compared with tests/planner/golden/plan_digests.txt. A refactoring commit must leave them
// unchanged; a commit that changes plans on purpose regenerates the file and says why:
//   WJ_UPDATE_PLAN_DIGESTS=1 ctest --preset release -R PlanDigest
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <string>

#include "golden_digests.h"
#include "planner/jump_planner.h"
#include "planner/presets.h"

namespace wj::planner {
namespace {

const char* const kGoldenFile = WJ_PLANNER_GOLDEN_DIR "/plan_digests.txt";

/// A plan's values into a digest: every bit of every value counts.
class Digest {
 public:
  void add(double v) { h_.add(&v, sizeof v); }
  void add(const Eigen::MatrixXd& m) {
    add(static_cast<double>(m.rows()));
    add(static_cast<double>(m.cols()));
    h_.add(m.data(), sizeof(double) * static_cast<std::size_t>(m.size()));
  }
  void add(const PlanarState& s) {
    for (const double v : {s.x, s.z, s.pitch, s.vx, s.vz, s.pitch_rate}) add(v);
  }
  std::string hex() const { return h_.hex(); }

 private:
  test::Fnv1a h_;
};

/// The digest of everything a plan hands on: the search vector, the evaluation's cost and
/// predicted events, and the dense references the robot executes.
std::string planDigest(const PlannerResult& r) {
  Digest d;
  d.add(r.u);
  d.add(r.evaluation.cost);
  d.add(static_cast<double>(r.evaluation.feasible));
  for (const JumpEvent* e : {&r.evaluation.predicted.takeoff, &r.evaluation.predicted.apex,
                             &r.evaluation.predicted.touchdown}) {
    d.add(e->t);
    d.add(e->state);
  }
  for (const double v : {r.plan.t1, r.plan.t2, r.plan.t3, r.plan.dt}) d.add(v);
  d.add(r.plan.decision);
  d.add(r.plan.q_initial);
  d.add(r.plan.q_landing);
  for (const PlanarState& s : r.plan.centroidal) d.add(s);
  d.add(r.plan.q);
  d.add(r.plan.qd);
  d.add(r.plan.tau);
  return d.hex();
}

TEST(PlanDigest, EveryPresetIsUnchanged) {
  const JumpPlanner planner(model::RobotModel::loadDefault(), PlannerSettings{});
  test::Digests now;
  for (const std::string& name : presetNames()) {
    const Scenario sc = makePreset(planner, name);
    PlanOptions o;
    o.seed = 7;
    o.threads = 2;
    now[name] = planDigest(planner.plan(sc.task, sc.initial, o));
  }
  if (test::updateRequested("WJ_UPDATE_PLAN_DIGESTS")) {
    test::writeGoldenDigests(
        kGoldenFile, "preset digest (tests/planner/test_plan_digest.cpp; seed 7, 2 threads)", now);
    GTEST_SKIP() << "rewrote " << kGoldenFile;
  }
  test::expectGoldenDigests(kGoldenFile, now, "WJ_UPDATE_PLAN_DIGESTS");
}

// The digest is a property of the seed, not of the thread count or the run.
TEST(PlanDigest, IndependentOfThreadsAndRepeatable) {
  const JumpPlanner planner(model::RobotModel::loadDefault(), PlannerSettings{});
  const Scenario sc = makePreset(planner, "forward_hw");
  PlanOptions o;
  o.seed = 7;
  o.threads = 1;
  const std::string one = planDigest(planner.plan(sc.task, sc.initial, o));
  o.threads = 2;
  EXPECT_EQ(one, planDigest(planner.plan(sc.task, sc.initial, o)));
  EXPECT_EQ(one, planDigest(planner.plan(sc.task, sc.initial, o)));
  o.seed = 8;
  EXPECT_NE(one, planDigest(planner.plan(sc.task, sc.initial, o)));
}

}  // namespace
}  // namespace wj::planner
