// Plan digests: every preset's plan at a fixed seed, reduced to a 64-bit digest of its bits and
// compared with tests/planner/golden/plan_digests.txt. A refactoring commit must leave them
// unchanged; a commit that changes plans on purpose regenerates the file and says why:
//   WJ_UPDATE_PLAN_DIGESTS=1 ctest --preset release -R PlanDigest
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "planner/jump_planner.h"
#include "planner/presets.h"

namespace wj::planner {
namespace {

const char* const kGoldenFile = WJ_PLANNER_GOLDEN_DIR "/plan_digests.txt";

/// FNV-1a over raw bytes: any change of any bit of any value changes the digest.
class Digest {
 public:
  void add(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h_ = (h_ ^ p[i]) * 0x100000001b3ULL;
  }
  void add(double v) { add(&v, sizeof v); }
  void add(const Eigen::MatrixXd& m) {
    add(static_cast<double>(m.rows()));
    add(static_cast<double>(m.cols()));
    add(m.data(), sizeof(double) * static_cast<std::size_t>(m.size()));
  }
  void add(const PlanarState& s) {
    for (const double v : {s.x, s.z, s.pitch, s.vx, s.vz, s.pitch_rate}) add(v);
  }
  std::string hex() const {
    std::ostringstream o;
    o << std::hex << h_;
    return o.str();
  }

 private:
  std::uint64_t h_ = 0xcbf29ce484222325ULL;
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

std::map<std::string, std::string> readGolden() {
  std::map<std::string, std::string> golden;
  std::ifstream in(kGoldenFile);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string name, hex;
    ls >> name >> hex;
    golden[name] = hex;
  }
  return golden;
}

TEST(PlanDigest, EveryPresetIsUnchanged) {
  const JumpPlanner planner(model::RobotModel::loadDefault(), PlannerSettings{});
  std::map<std::string, std::string> now;
  for (const std::string& name : presetNames()) {
    const Scenario sc = makePreset(planner, name);
    PlanOptions o;
    o.seed = 7;
    o.threads = 2;
    now[name] = planDigest(planner.plan(sc.task, sc.initial, o));
  }
  if (const char* u = std::getenv("WJ_UPDATE_PLAN_DIGESTS"); u != nullptr && *u == '1') {
    std::ofstream out(kGoldenFile);
    out << "# preset digest (tests/planner/test_plan_digest.cpp; seed 7, 2 threads)\n";
    for (const auto& [name, hex] : now) out << name << ' ' << hex << '\n';
    GTEST_SKIP() << "rewrote " << kGoldenFile;
  }
  const auto golden = readGolden();
  ASSERT_FALSE(golden.empty()) << "no digests in " << kGoldenFile;
  for (const auto& [name, hex] : now) {
    const auto it = golden.find(name);
    ASSERT_NE(it, golden.end()) << "no golden digest for preset " << name;
    EXPECT_EQ(hex, it->second) << "the " << name
                               << " plan changed; if on purpose, regenerate (see the file's head)";
  }
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
