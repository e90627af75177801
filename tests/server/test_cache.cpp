// The cache: keys and their quantization, the settings hash, the compact solution codec and its
// size, the SQLite store (checksums, corruption, kill -9 during writes), the LRU and the
// neighbour index.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <random>
#include <set>
#include <thread>

#include "planner/jump_planner.h"
#include "server/cache_key.h"
#include "server/cached_solution.h"
#include "server/hot_responses.h"
#include "server/solution_cache.h"
#include "server/solution_store.h"
#include "server_test_util.h"

namespace wj::server {
namespace {

planner::JumpTask vertical(double height = 0.8) {
  planner::JumpTask t;
  t.target = {0.0, height, 0.0, planner::TargetEvent::Apex};
  return t;
}

planner::InitialState standing(double v0) {
  planner::InitialState s;
  s.v0 = v0;
  for (int leg = 0; leg < 4; ++leg) {
    s.q[leg * 4 + 1] = 1.0;
    s.q[leg * 4 + 2] = -2.0;
  }
  return s;
}

CachedSolution solution(double seed_value) {
  CachedSolution s;
  for (std::size_t i = 0; i < s.u.size(); ++i) s.u[i] = seed_value + 0.01 * static_cast<double>(i);
  s.t1 = 0.3;
  s.t2 = 0.3;
  s.t3 = 0.9 + seed_value * 1e-3;
  s.feasible = true;
  s.constraints_ok = true;
  s.de_complete = true;
  s.final_cost = 1.0;
  s.verification.status = VerificationStatus::Passed;
  s.verification.simulated.apex.state.z = 0.8;
  s.created_unix_ms = 1234;
  return s;
}

CacheKey keyAt(std::int32_t v0_bin, std::uint64_t seed = 1) {
  const KeyQuantizer q(CacheConfig{}, 11, 22);
  CacheKey k = q.make(vertical(), standing(0.0), seed);
  k.v0_bin = v0_bin;
  return k;
}

TEST(CacheKey, QuantizesTheRunUpSpeedIn005Bins) {
  const KeyQuantizer q(CacheConfig{}, 11, 22);
  const auto k = [&](double v0) { return q.make(vertical(), standing(v0), 1); };
  EXPECT_EQ(k(3.0), k(3.02));
  EXPECT_EQ(k(3.0), k(2.976));
  EXPECT_NE(k(3.0), k(3.03));
  EXPECT_EQ(k(3.0).v0_bin, 60);
  EXPECT_EQ(k(-0.5).v0_bin, -10);
  EXPECT_DOUBLE_EQ(q.v0Of(60), 3.0);
  // Everything else of the key.
  EXPECT_NE(k(1.0), q.make(vertical(0.81), standing(1.0), 1));
  EXPECT_NE(k(1.0), q.make(vertical(), standing(1.0), 2));
  planner::JumpTask two = vertical();
  two.mode = planner::TakeoffMode::TwoStep;
  EXPECT_NE(k(1.0), q.make(two, standing(1.0), 1));
  planner::JumpTask wall = vertical();
  wall.obstacle = planner::BoxObstacle{1.0, 1.1, 0.2};
  EXPECT_NE(k(1.0), q.make(wall, standing(1.0), 1));
  planner::InitialState bent = standing(1.0);
  bent.q[1] = 1.1;
  EXPECT_NE(k(1.0), q.make(vertical(), bent, 1));
  planner::InitialState wheels = standing(1.0);
  wheels.q[3] = 123.0;  // wheel angles are not part of the key
  EXPECT_EQ(k(1.0), q.make(vertical(), wheels, 1));
  EXPECT_NE(k(1.0), KeyQuantizer(CacheConfig{}, 12, 22).make(vertical(), standing(1.0), 1));
  EXPECT_NE(k(1.0), KeyQuantizer(CacheConfig{}, 11, 23).make(vertical(), standing(1.0), 1));
}

TEST(CacheKey, BytesRoundTripAndFamilyIgnoresV0) {
  const CacheKey a = keyAt(7);
  EXPECT_EQ(a.bytes().size(), CacheKey::kBytes);
  const auto back = CacheKey::fromBytes(a.bytes());
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(*back, a);
  EXPECT_FALSE(CacheKey::fromBytes(a.bytes().substr(1)).has_value());
  EXPECT_EQ(a.hex().size(), 2 * CacheKey::kBytes);
  EXPECT_EQ(a.family(), keyAt(-3).family());
  EXPECT_NE(a.family(), keyAt(7, 2).family());
}

TEST(SettingsHash, StableAndSensitiveToEveryKindOfSetting) {
  const model::RobotModel robot = model::RobotModel::loadDefault();
  const auto hashOf = [&](const planner::PlannerSettings& s) {
    return hashPlannerSettings(planner::JumpPlanner(robot, s));
  };
  const planner::PlannerSettings base;
  const auto h = hashOf(base);
  EXPECT_EQ(h, hashOf(planner::PlannerSettings{}));
  auto changed = [&](auto mutate) {
    planner::PlannerSettings s;
    mutate(s);
    return hashOf(s) != h;
  };
  // The model's settings, through what they compute.
  EXPECT_TRUE(changed([](auto& s) { s.gravity = 9.8; }));
  EXPECT_TRUE(changed([](auto& s) { s.friction_mu = 0.5; }));
  EXPECT_TRUE(changed([](auto& s) { s.takeoff_unload_s = 0.0; }));
  EXPECT_TRUE(changed([](auto& s) { s.balanced_stance = false; }));
  EXPECT_TRUE(changed([](auto& s) { s.stance_momentum = true; }));
  EXPECT_TRUE(changed([](auto& s) { s.flight_feedforward = true; }));
  EXPECT_TRUE(changed([](auto& s) { s.drive_limited_tuck = true; }));
  EXPECT_TRUE(changed([](auto& s) { s.tyre_contact_modulus_pa = 2.83e6; }));
  EXPECT_TRUE(changed([](auto& s) { s.stand_kfe_rad = -1.9; }));
  EXPECT_TRUE(changed([](auto& s) { s.landing_hfe_rad = 0.7; }));
  EXPECT_TRUE(changed([](auto& s) { s.samples_phase1 = 30; }));
  EXPECT_TRUE(changed([](auto& s) { s.output_dt_s = 0.002; }));
  EXPECT_TRUE(changed([](auto& s) { s.t1_s[1] = 0.55; }));
  EXPECT_TRUE(changed([](auto& s) { s.energy_weight = 2e-3; }));
  EXPECT_TRUE(changed([](auto& s) { s.tolerance_dx_m = 0.03; }));
  EXPECT_TRUE(changed([](auto& s) { s.obstacle_margin_m = 0.05; }));
  EXPECT_TRUE(changed([](auto& s) { s.platform_margin_m = 0.03; }));  // no probe lands on a box
  EXPECT_TRUE(changed([](auto& s) { s.tuck_end_fraction = 0.15; }));
  EXPECT_TRUE(changed([](auto& s) { s.wall_extend_start_fraction = 0.65; }));
  // A backflip's knee clearance and front brake (no probe is a flip).
  EXPECT_TRUE(changed([](auto& s) { s.flip_hind_knee_clearance_rad = 0.25; }));
  EXPECT_TRUE(changed([](auto& s) { s.flip_front_brake_share = 0.6; }));
  // The solver's settings, field by field.
  EXPECT_TRUE(changed([](auto& s) { s.de.population_size = 33; }));
  EXPECT_TRUE(changed([](auto& s) { s.de.strategy = planner::de::Strategy::Rand1Bin; }));
  EXPECT_TRUE(changed([](auto& s) { s.de.seed = 2; }));
  EXPECT_TRUE(changed([](auto& s) { s.de_restarts = s.de_restarts + 1; }));
  EXPECT_TRUE(changed([](auto& s) { s.polish = !s.polish; }));
  EXPECT_TRUE(changed([](auto& s) { s.polish_tolerance = 1e-7; }));
  // The thread count and the log switch do not change plans.
  EXPECT_FALSE(changed([](auto& s) { s.de.threads = 7; }));
  EXPECT_FALSE(changed([](auto& s) { s.de.keep_log = false; }));
}

TEST(CachedSolution, CodecRoundTripsAndRefusesDamage) {
  CachedSolution s = solution(0.5);
  s.verification.failure_bits = 0x42;
  s.verification.candidates_verified = 3;
  s.evaluations = 1234567;
  s.max_evaluations = 2000000;
  const std::string payload = encodeSolution(s);
  const auto back = decodeSolution(payload);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(encodeSolution(*back), payload);
  EXPECT_EQ(back->u, s.u);
  EXPECT_EQ(back->verification.failure_bits, 0x42u);
  EXPECT_FALSE(decodeSolution(payload.substr(0, payload.size() - 1)).has_value());
  EXPECT_FALSE(decodeSolution(payload + "x").has_value());
  std::string wrong_version = payload;
  wrong_version[0] = 9;
  EXPECT_FALSE(decodeSolution(wrong_version).has_value());
  // The search's evaluation budget (format 2) round-trips; format 1 rows (without it) are still
  // read, with the evaluations the search used as its budget.
  EXPECT_EQ(back->max_evaluations, s.max_evaluations);
  constexpr std::size_t kFlags = 2 + 8 * planner::kNumDecision + 3 * 8;  // the flags byte
  constexpr std::size_t kCorrection = 3 * 8;  // format 4's lift-off correction, at the end
  std::string v1 = payload.substr(0, payload.size() - kCorrection - 8);
  v1[0] = 1;
  v1[kFlags] = 1 | 2;  // feasible, de_complete: format 1 has no other flag
  ASSERT_TRUE(decodeSolution(v1).has_value());
  EXPECT_EQ(decodeSolution(v1)->max_evaluations, 1234567);
  std::string v2_short = payload.substr(0, payload.size() - kCorrection - 8);
  v2_short[0] = 2;
  EXPECT_FALSE(decodeSolution(v2_short).has_value());
  // Whether every constraint held (format 3) round-trips; a closest approach holds them without
  // being feasible. Older rows know it of their feasible solutions only, and a payload that
  // calls a solution feasible with a constraint violated is refused.
  EXPECT_EQ(static_cast<int>(payload[kFlags]), 1 | 2 | 4);
  CachedSolution closest = s;
  closest.feasible = false;
  ASSERT_TRUE(decodeSolution(encodeSolution(closest)).has_value());
  EXPECT_TRUE(decodeSolution(encodeSolution(closest))->constraints_ok);
  EXPECT_FALSE(decodeSolution(encodeSolution(closest))->feasible);
  closest.constraints_ok = false;
  EXPECT_FALSE(decodeSolution(encodeSolution(closest))->constraints_ok);
  std::string v2 = encodeSolution(closest);
  v2.resize(v2.size() - kCorrection);
  v2[0] = 2;
  EXPECT_FALSE(decodeSolution(v2)->constraints_ok);
  v2[kFlags] = 1;  // feasible
  EXPECT_TRUE(decodeSolution(v2)->constraints_ok);
  v2[kFlags] = 4;  // format 2 has no such flag
  EXPECT_FALSE(decodeSolution(v2).has_value());
  CachedSolution contradiction = s;
  contradiction.constraints_ok = false;
  EXPECT_FALSE(decodeSolution(encodeSolution(contradiction)).has_value());
  CachedSolution nan = s;
  nan.u[3] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(decodeSolution(encodeSolution(nan)).has_value());
  // The lift-off correction (format 4) round-trips; format 3 rows have none; one out of its
  // bounds, or NaN, is refused.
  CachedSolution corrected = s;
  corrected.liftoff_correction = {0.004, -0.008, -0.041};
  const auto c = decodeSolution(encodeSolution(corrected));
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(c->liftoff_correction.vz, -0.008);
  EXPECT_EQ(c->liftoff_correction.momentum, -0.041);
  std::string v3 = encodeSolution(corrected);
  v3.resize(v3.size() - kCorrection);
  v3[0] = 3;
  ASSERT_TRUE(decodeSolution(v3).has_value());
  EXPECT_TRUE(decodeSolution(v3)->liftoff_correction.isZero());
  corrected.liftoff_correction.momentum = 2.5;
  EXPECT_FALSE(decodeSolution(encodeSolution(corrected)).has_value());
  corrected.liftoff_correction.momentum = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(decodeSolution(encodeSolution(corrected)).has_value());
  // The checksum covers key and payload.
  const std::string k = keyAt(1).bytes();
  EXPECT_NE(rowChecksum(k, payload), rowChecksum(keyAt(2).bytes(), payload));
  std::string flipped = payload;
  flipped[20] ^= 1;
  EXPECT_NE(rowChecksum(k, payload), rowChecksum(k, flipped));
}

TEST(CachedSolution, EntryFitsInOneKilobyte) {
  // Payload on disk, and key + value + LRU and map nodes in memory (node overheads: two
  // pointers per list node, key + pointer + next + hash per map node, one tree node per bin).
  EXPECT_LE(encodeSolution(solution(1.0)).size(), 512u);
  const std::size_t in_memory = sizeof(CacheKey) + sizeof(CachedSolution) + 2 * sizeof(void*) +
                                sizeof(CacheKey) + 3 * sizeof(void*) + 48;
  EXPECT_LE(in_memory, 1024u) << in_memory;
}

TEST(CachedSolution, AtEqualCostALargerBudgetIsBetter) {
  CachedSolution small = solution(1), large = solution(1);
  small.feasible = large.feasible = false;
  small.max_evaluations = 100;
  large.max_evaluations = 10000;
  EXPECT_TRUE(isBetterSolution(large, small));
  EXPECT_FALSE(isBetterSolution(small, large));
  EXPECT_FALSE(isBetterSolution(small, small));
  large.final_cost += 1e-9;  // cost first
  EXPECT_FALSE(isBetterSolution(large, small));
}

TEST(CachedSolution, BetterMeansVerifiedThenFeasibleThenCheaper) {
  CachedSolution passed = solution(1), failed = solution(1), unverified = solution(1);
  failed.verification.status = VerificationStatus::Failed;
  unverified.verification.status = VerificationStatus::NotRun;
  EXPECT_TRUE(isBetterSolution(passed, failed));
  EXPECT_TRUE(isBetterSolution(failed, unverified));
  EXPECT_FALSE(isBetterSolution(unverified, passed));
  CachedSolution cheaper = passed;
  cheaper.final_cost = 0.5;
  EXPECT_TRUE(isBetterSolution(cheaper, passed));
  CachedSolution infeasible = cheaper;
  infeasible.feasible = false;
  EXPECT_FALSE(isBetterSolution(infeasible, passed));
}

TEST(SolutionStore, PersistsAcrossReopen) {
  test::TempDir dir("wj-store");
  const auto path = dir / "c.sqlite";
  {
    SolutionStore store(path, true, 1000);
    for (int i = 0; i < 20; ++i) store.put(keyAt(i), solution(i));
    store.put(keyAt(3), solution(103));  // replaces
    EXPECT_EQ(store.count(), 20);
  }
  SolutionStore store(path, true, 1000);
  EXPECT_EQ(store.count(), 20);
  ASSERT_TRUE(store.get(keyAt(3)).has_value());
  EXPECT_EQ(store.get(keyAt(3))->u, solution(103).u);
  EXPECT_FALSE(store.get(keyAt(99)).has_value());
  std::vector<std::int32_t> order;
  store.forEachNewest(5,
                      [&](const CacheKey& k, const CachedSolution&) { order.push_back(k.v0_bin); });
  EXPECT_EQ(order, (std::vector<std::int32_t>{3, 19, 18, 17, 16}));
  EXPECT_EQ(store.counters().corrupt_rows, 0);
}

TEST(SolutionStore, UsesWriteAheadLogging) {
  test::TempDir dir("wj-store");
  const auto path = dir / "c.sqlite";
  SolutionStore store(path, true, 10);
  store.put(keyAt(1), solution(1));
  EXPECT_TRUE(std::filesystem::exists(path.string() + "-wal"));
}

TEST(SolutionStore, CorruptRowIsDeletedNeverServed) {
  test::TempDir dir("wj-store");
  const auto path = dir / "c.sqlite";
  {
    SolutionStore store(path, true, 1000);
    store.put(keyAt(1), solution(1));
    store.put(keyAt(2), solution(2));
  }
  {
    // Flip one payload byte behind the store's back; the checksum no longer matches.
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    const std::string k = keyAt(2).bytes();
    sqlite3_stmt* st = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db,
                                 "UPDATE solutions SET payload = "
                                 "substr(payload, 1, 10) || x'ff' || substr(payload, 12) "
                                 "WHERE key = ?1",
                                 -1, &st, nullptr),
              SQLITE_OK);
    sqlite3_bind_blob(st, 1, k.data(), static_cast<int>(k.size()), SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
    ASSERT_EQ(sqlite3_changes(db), 1);
    sqlite3_finalize(st);
    sqlite3_close(db);
  }
  SolutionStore store(path, true, 1000);
  EXPECT_FALSE(store.get(keyAt(2)).has_value());
  EXPECT_TRUE(store.get(keyAt(1)).has_value());
  EXPECT_EQ(store.counters().corrupt_rows, 1);
  EXPECT_EQ(store.count(), 1);  // deleted
}

TEST(SolutionStore, UnreadableFileIsMovedAsideAndReplaced) {
  test::TempDir dir("wj-store");
  const auto path = dir / "c.sqlite";
  {
    std::ofstream out(path);
    out << std::string(8192, 'x');  // not a database
  }
  SolutionStore store(path, true, 10);
  EXPECT_TRUE(store.counters().recreated);
  store.put(keyAt(1), solution(1));
  EXPECT_TRUE(store.get(keyAt(1)).has_value());
  int aside = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    aside += e.path().filename().string().find(".corrupt-") != std::string::npos ? 1 : 0;
  EXPECT_GE(aside, 1);
}

TEST(SolutionStore, PrunesOldestBeyondTheRowBound) {
  test::TempDir dir("wj-store");
  SolutionStore store(dir / "c.sqlite", false, 10);
  for (int i = 0; i < 25; ++i) store.put(keyAt(i), solution(i));
  EXPECT_LE(store.count(), 10);
  EXPECT_TRUE(store.get(keyAt(24)).has_value());
  EXPECT_FALSE(store.get(keyAt(0)).has_value());
  EXPECT_GT(store.counters().pruned_rows, 0);
}

// A child process writes rows as fast as it can and reports each committed put on a pipe; it
// is killed with SIGKILL at a random instant. Every reported row must be there, intact.
TEST(SolutionStore, KillNineDuringWritesLosesNoCommittedRow) {
  test::TempDir dir("wj-store");
  const auto path = dir / "c.sqlite";
  std::mt19937 rng(12345);
  std::set<std::int32_t> committed;
  for (int round = 0; round < 5; ++round) {
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::close(fds[0]);
      SolutionStore store(path, true, 1000000);
      for (std::int32_t i = round * 100000;; ++i) {
        store.put(keyAt(i), solution(i));
        if (::write(fds[1], &i, sizeof i) != sizeof i) ::_exit(3);
      }
    }
    ::close(fds[1]);
    // The first commit, then a random instant among the later ones: on a loaded machine the
    // child may not have committed anything yet 50 ms after the fork.
    std::int32_t i = 0;
    ASSERT_EQ(::read(fds[0], &i, sizeof i), static_cast<ssize_t>(sizeof i));
    committed.insert(i);
    std::this_thread::sleep_for(std::chrono::milliseconds(50 + rng() % 200));
    ::kill(pid, SIGKILL);
    while (::read(fds[0], &i, sizeof i) == sizeof i) committed.insert(i);
    ::close(fds[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status));
    ASSERT_FALSE(committed.empty());
    SolutionStore reopened(path, true, 1000000);
    std::int64_t lost = 0;
    for (const std::int32_t c : committed) {
      const auto s = reopened.get(keyAt(c));
      if (!s || s->u != solution(c).u) ++lost;
    }
    EXPECT_EQ(lost, 0) << "round " << round << ": " << committed.size() << " committed";
    EXPECT_EQ(reopened.counters().corrupt_rows, 0);
    EXPECT_FALSE(reopened.counters().recreated);
  }
}

TEST(SolutionCache, LruEvictsAndCountsButSqliteKeepsEverything) {
  test::TempDir dir("wj-cache");
  SolutionCache cache(3, std::make_unique<SolutionStore>(dir / "c.sqlite", false, 100));
  for (int i = 0; i < 3; ++i) cache.put(keyAt(i), solution(i));
  ASSERT_TRUE(cache.find(keyAt(0)).has_value());  // 0 is now the most recent
  cache.put(keyAt(3), solution(3));               // evicts 1
  EXPECT_FALSE(cache.find(keyAt(1)).has_value());
  EXPECT_TRUE(cache.find(keyAt(0)).has_value());
  EXPECT_EQ(cache.counters().evictions, 1);
  EXPECT_EQ(cache.counters().entries, 3);
  // Still persisted: the slow path finds and promotes it.
  ASSERT_TRUE(cache.findPersisted(keyAt(1)).has_value());
  EXPECT_TRUE(cache.find(keyAt(1)).has_value());
  EXPECT_EQ(cache.counters().persisted_hits, 1);
}

TEST(SolutionCache, KeepsTheBetterSolution) {
  SolutionCache cache(10, nullptr);
  CachedSolution good = solution(1);
  EXPECT_TRUE(cache.put(keyAt(0), good));
  CachedSolution worse = solution(2);
  worse.verification.status = VerificationStatus::NotRun;
  EXPECT_FALSE(cache.put(keyAt(0), worse));
  EXPECT_EQ(cache.find(keyAt(0))->u, good.u);
}

TEST(SolutionCache, ReloadsNewestRowsAtStart) {
  test::TempDir dir("wj-cache");
  {
    SolutionCache cache(100, std::make_unique<SolutionStore>(dir / "c.sqlite", false, 100));
    for (int i = 0; i < 10; ++i) cache.put(keyAt(i), solution(i));
  }
  SolutionCache cache(4, std::make_unique<SolutionStore>(dir / "c.sqlite", false, 100));
  EXPECT_EQ(cache.counters().entries, 4);
  for (int i = 6; i < 10; ++i) EXPECT_TRUE(cache.find(keyAt(i)).has_value()) << i;
  EXPECT_FALSE(cache.find(keyAt(5)).has_value());
}

TEST(SolutionCache, NearestNeighboursInV0) {
  SolutionCache cache(100, nullptr);
  for (const int bin : {2, 5, 9, 20}) cache.put(keyAt(bin), solution(bin));
  cache.put(keyAt(6, 99), solution(6));  // another family (seed): never a neighbour
  const auto n = cache.nearestByV0(keyAt(6), 2, 10);
  ASSERT_EQ(n.size(), 2u);
  EXPECT_EQ(n[0].first, 5);
  EXPECT_EQ(n[1].first, 9);
  EXPECT_EQ(cache.nearestByV0(keyAt(6), 5, 3).size(), 2u);  // 2 and 20 are too far
  EXPECT_TRUE(cache.nearestByV0(keyAt(6), 0, 10).empty());
  EXPECT_EQ(cache.nearestByV0(keyAt(5), 3, 100)[0].first, 2);  // itself excluded
}

// Every value the cache stores gets a generation of its own: a replaced or re-inserted entry
// is never taken for the one a hot response was built from.
TEST(SolutionCache, EveryStoredValueHasItsOwnGeneration) {
  SolutionCache cache(2, nullptr);
  std::uint64_t g0 = 0, g0_again = 0, g1 = 0, g0_better = 0, g0_back = 0;
  cache.put(keyAt(0), solution(0));
  ASSERT_TRUE(cache.find(keyAt(0), &g0));
  ASSERT_TRUE(cache.find(keyAt(0), &g0_again));
  EXPECT_EQ(g0, g0_again);  // the same value: the same generation
  cache.put(keyAt(1), solution(1));
  ASSERT_TRUE(cache.find(keyAt(1), &g1));
  EXPECT_NE(g1, g0);
  CachedSolution better = solution(0);
  better.final_cost -= 1.0;
  ASSERT_TRUE(cache.put(keyAt(0), better));
  ASSERT_TRUE(cache.find(keyAt(0), &g0_better));
  EXPECT_NE(g0_better, g0);
  // Evicted (2 entries at most) and stored again: a new generation.
  cache.put(keyAt(2), solution(2));
  cache.put(keyAt(3), solution(3));
  ASSERT_FALSE(cache.find(keyAt(0)).has_value());
  cache.put(keyAt(0), better);
  ASSERT_TRUE(cache.find(keyAt(0), &g0_back));
  EXPECT_NE(g0_back, g0_better);
  EXPECT_NE(g0_back, g0);
}

wheeljump::planner::v1::PlanJumpResponse hotResponse(const std::string& id, int samples) {
  wheeljump::planner::v1::PlanJumpResponse r;
  r.set_request_id(id);
  r.set_source(wheeljump::planner::v1::PLAN_SOURCE_CACHE_HIT);
  r.mutable_stats()->set_total_ms(0.25);
  r.mutable_stats()->set_cache_key("abcd");
  r.mutable_stats()->set_evaluations(1234);
  for (int i = 0; i < samples; ++i) r.mutable_plan()->add_decision_vector(0.5 * i);
  return r;
}

// A hot answer is the ready bytes followed by the caller's own fields: parsed, it is the
// response with the caller's request_id and total_ms, every other field as it was (the stats
// message is merged, not replaced), an empty id included.
TEST(HotResponses, ReadyBytesAndTheCallersSuffixParseAsTheCallersResponse) {
  for (const std::string id : {"robot-7", ""}) {
    auto first = hotResponse("first-caller", 50);
    wheeljump::planner::v1::PlanJumpResponse expected = first;
    expected.set_request_id(id);
    expected.mutable_stats()->set_total_ms(0.0625);
    expected.set_ready_response(true);  // says the plan was built for another caller's state
    const std::string ready = readyBytes(first);
    EXPECT_EQ(first.request_id(), "");  // the per-call fields are not in the ready bytes
    EXPECT_EQ(first.stats().total_ms(), 0.0);
    wheeljump::planner::v1::PlanJumpResponse parsed;
    const grpc::Slice suffix = readySuffix(id, 0.0625);
    ASSERT_TRUE(parsed.ParseFromString(
        ready + std::string(reinterpret_cast<const char*>(suffix.begin()), suffix.size())));
    EXPECT_EQ(parsed.SerializeAsString(), expected.SerializeAsString()) << id;
    EXPECT_EQ(parsed.request_id(), id);
    EXPECT_TRUE(parsed.ready_response());
    EXPECT_FALSE(first.ready_response());  // the ready bytes say it only through the suffix
    EXPECT_EQ(parsed.stats().cache_key(), "abcd");
    EXPECT_EQ(parsed.stats().evaluations(), 1234u);
    EXPECT_EQ(parsed.plan().decision_vector_size(), 50);
  }
}

// The hot tier: bytes are served only while the entry they were built from is the cache's,
// the bound in bytes evicts the least recently used, and 0 MB is off.
TEST(HotResponses, ServesOnlyWhatTheCurrentEntryBuiltWithinItsBound) {
  const auto bytes = [](const std::string& id, int samples) {
    auto r = hotResponse(id, samples);
    r.mutable_stats()->set_cache_key(id);  // tells the responses apart once the id is cleared
    return readyBytes(r);
  };
  const auto keyOf = [](const grpc::Slice& slice) {
    wheeljump::planner::v1::PlanJumpResponse r;
    EXPECT_TRUE(r.ParseFromArray(slice.begin(), static_cast<int>(slice.size())));
    return r.stats().cache_key();
  };
  HotResponses off(0);
  EXPECT_FALSE(off.enabled());
  off.put("a", 1, bytes("a", 10));
  EXPECT_FALSE(off.find("a", 1).has_value());

  const std::string one = bytes("a", 100);  // ~0.9 KB
  const std::size_t size = one.size() + 1;
  HotResponses hot(3 * size);
  hot.put("a", 1, one);
  ASSERT_TRUE(hot.find("a", 1).has_value());
  EXPECT_EQ(keyOf(*hot.find("a", 1)), "a");
  // The cache's entry changed (a better solution, or evicted and recomputed): dropped.
  EXPECT_FALSE(hot.find("a", 2).has_value());
  EXPECT_EQ(hot.entries(), 0u);
  EXPECT_EQ(hot.bytes(), 0u);
  // Least recently used out first, within the bound.
  hot.put("a", 1, bytes("a", 100));
  hot.put("b", 1, bytes("b", 100));
  hot.put("c", 1, bytes("c", 100));
  ASSERT_TRUE(hot.find("a", 1).has_value());  // a is now the most recent
  hot.put("d", 1, bytes("d", 100));
  EXPECT_EQ(hot.entries(), 3u);
  EXPECT_LE(hot.bytes(), 3 * size);
  EXPECT_FALSE(hot.find("b", 1).has_value());
  EXPECT_TRUE(hot.find("a", 1).has_value());
  EXPECT_TRUE(hot.find("d", 1).has_value());
  // Replacing a key keeps one entry; bytes larger than the whole bound are not kept.
  hot.put("d", 2, bytes("D", 100));
  EXPECT_EQ(keyOf(*hot.find("d", 2)), "D");
  EXPECT_EQ(hot.entries(), 3u);
  hot.put("e", 1, bytes("e", 1000));
  EXPECT_FALSE(hot.find("e", 1).has_value());
}

}  // namespace
}  // namespace wj::server
