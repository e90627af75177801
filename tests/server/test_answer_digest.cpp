// Answer digests: the service's answer for every preset at seed 7, through the PlanningCore with
// the Simbody verifier, serialized as the PlanJump response and reduced to a 64-bit digest of its
// bytes, compared with tests/server/golden/answer_digests.txt. Three answers per preset: the miss
// (DE, polish, verification of the top K, the choice), the hit that follows (the compact cache
// entry regenerated), and the same hit asked for as knots. The wall-clock fields (de_ms,
// polish_ms, verify_ms, total_ms) are zeroed; every other bit counts. A refactoring commit must
// leave the file unchanged; a commit that changes answers on purpose regenerates it and says why:
//   WJ_UPDATE_ANSWER_DIGESTS=1 ./build/release/bin/server_test_answer_digest
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <future>
#include <iostream>
#include <string>

#include "golden_digests.h"
#include "planner/presets.h"
#include "server/planning_core.h"
#include "server/response_conversion.h"
#include "server_test_util.h"

namespace wj::server {
namespace {

const char* const kGoldenFile = WJ_SERVER_GOLDEN_DIR "/answer_digests.txt";

std::string fnv1aHex(const std::string& bytes) {
  wj::test::Fnv1a h;
  h.add(bytes.data(), bytes.size());
  return h.hex();
}

/// The response's bytes (deterministic serialization) with the wall-clock fields zeroed.
std::string answerDigest(const PlanOutcome& o, const model::RobotModel& robot,
                         TrajectoryFormat format) {
  if (o.error) return "error:" + std::to_string(static_cast<int>(o.error->code()));
  v1::PlanJumpResponse r;
  toProto(o.answer, robot, "digest", format, &r);
  auto* s = r.mutable_stats();
  s->set_de_ms(0.0);
  s->set_polish_ms(0.0);
  s->set_verify_ms(0.0);
  s->set_total_ms(0.0);
  std::string bytes;
  google::protobuf::io::StringOutputStream stream(&bytes);
  google::protobuf::io::CodedOutputStream coded(&stream);
  coded.SetSerializationDeterministic(true);
  r.SerializeToCodedStream(&coded);
  coded.Trim();
  return fnv1aHex(bytes);
}

TEST(AnswerDigest, EveryPresetsAnswerIsUnchanged) {
  if (!simVerifierAvailable()) GTEST_SKIP() << "built without the sim component";
  const ServerConfig config = test::verifyingDefaultsConfig();
  const model::RobotModel robot = model::RobotModel::loadDefault();
  PlanningCore core(config, robot, planner::PlannerSettings{},
                    makeSimVerifier(robot, config.verification), nullptr);
  wj::test::Digests now;
  for (const std::string& name : planner::presetNames()) {
    PlanRequest r = test::presetRequest(core, name, 7, "digest");
    const PlanOutcome miss = test::ask(core, r);
    ASSERT_FALSE(miss.error.has_value()) << name << ": " << miss.error->what();
    EXPECT_EQ(miss.answer.source, PlanSource::CacheMiss) << name;
    EXPECT_GT(miss.answer.plan.numSamples(), 0) << name;
    EXPECT_NE(miss.answer.verification.status, VerificationStatus::NotRun) << name;
    std::cout << name << ": " << miss.answer.stats.evaluations << " evaluations, feasible "
              << miss.answer.evaluation.feasible << ", verification "
              << static_cast<int>(miss.answer.verification.status) << " ("
              << miss.answer.verification.candidates_verified << " verified, rank "
              << miss.answer.verification.returned_candidate_rank << ")\n";
    now[name + "/miss"] = answerDigest(miss, core.robot(), r.trajectory);
    const PlanOutcome hit = test::ask(core, r);
    EXPECT_EQ(hit.answer.source, PlanSource::CacheHit) << name;
    now[name + "/hit"] = answerDigest(hit, core.robot(), r.trajectory);
    r.trajectory = TrajectoryFormat::Knots;
    now[name + "/hit_knots"] = answerDigest(test::ask(core, r), core.robot(), r.trajectory);
  }
  if (wj::test::updateRequested("WJ_UPDATE_ANSWER_DIGESTS")) {
    wj::test::writeGoldenDigests(
        kGoldenFile,
        "preset/path digest (tests/server/test_answer_digest.cpp; seed 7, Simbody verifier)", now);
    GTEST_SKIP() << "rewrote " << kGoldenFile;
  }
  wj::test::expectGoldenDigests(kGoldenFile, now, "WJ_UPDATE_ANSWER_DIGESTS");
  // The digest sees every bit: a hit and a miss of one preset differ (the source at least).
  EXPECT_NE(now["forward/miss"], now["forward/hit"]);
}

}  // namespace
}  // namespace wj::server
