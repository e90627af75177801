// Golden-message tests of the wheeljump.planner.v1 contract: the committed wire bytes and JSON
// in golden/ must still parse, with every field known, into the same message, and re-serialize
// to exactly the same bytes. A renumbered, retyped or renamed field breaks one of these.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <ostream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include "golden_messages.h"

namespace wj::contract {

// Names a golden in GoogleTest's output.
void PrintTo(const GoldenCase& golden, std::ostream* out) {
  *out << golden.stem;
}

namespace {

namespace v1 = wheeljump::planner::v1;
namespace pb = google::protobuf;

const std::filesystem::path kGoldenDir = WJ_CONTRACT_GOLDEN_DIR;

std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path.string());
  std::string contents(std::filesystem::file_size(path), '\0');
  if (!in.read(contents.data(), static_cast<std::streamsize>(contents.size()))) {
    throw std::runtime_error("cannot read " + path.string());
  }
  return contents;
}

// Paths (e.g. "plan.joints") of every sub-message that holds fields unknown to the current
// proto: a field whose number changed parses as an unknown field and would otherwise survive a
// byte round trip unnoticed.
void collectUnknownFields(const pb::Message& message, const std::string& path,
                          std::vector<std::string>* paths) {
  const pb::Reflection& reflection = *message.GetReflection();
  if (!reflection.GetUnknownFields(message).empty()) paths->push_back(path);
  std::vector<const pb::FieldDescriptor*> fields;
  reflection.ListFields(message, &fields);
  for (const pb::FieldDescriptor* field : fields) {
    if (field->cpp_type() != pb::FieldDescriptor::CPPTYPE_MESSAGE) continue;
    const std::string field_path = path + "." + field->name();
    if (field->is_repeated()) {
      for (int i = 0; i < reflection.FieldSize(message, field); ++i) {
        collectUnknownFields(reflection.GetRepeatedMessage(message, field, i),
                             field_path + "[" + std::to_string(i) + "]", paths);
      }
    } else {
      collectUnknownFields(reflection.GetMessage(message, field), field_path, paths);
    }
  }
}

std::string joined(const std::vector<std::string>& items) {
  std::ostringstream out;
  for (const std::string& item : items) out << item << "; ";
  return out.str();
}

// Empty string when equal, else the differencer's report.
std::string differences(const pb::Message& expected, const pb::Message& actual) {
  std::string report;
  pb::util::MessageDifferencer differencer;
  differencer.ReportDifferencesToString(&report);
  if (differencer.Compare(expected, actual)) return {};
  return report.empty() ? "messages differ" : report;
}

std::unique_ptr<pb::Message> parseJson(const std::string& json, const pb::Message& prototype) {
  std::unique_ptr<pb::Message> message(prototype.New());
  pb::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;  // a renamed field must fail, not vanish
  const auto status = pb::util::JsonStringToMessage(json, message.get(), options);
  if (!status.ok()) {
    throw std::runtime_error("JSON does not parse as " + prototype.GetTypeName() + ": " +
                             status.ToString());
  }
  return message;
}

// A golden file parsed into its message type, via the binary form.
template <typename Message>
Message parseGoldenBinary(std::string_view stem) {
  Message message;
  const std::filesystem::path path = kGoldenDir / (std::string(stem) + ".binpb");
  if (!message.ParseFromString(readFile(path))) {
    throw std::runtime_error("cannot parse " + path.string());
  }
  return message;
}

class GoldenTest : public ::testing::TestWithParam<GoldenCase> {
 protected:
  void SetUp() override {
    const std::string stem(GetParam().stem);
    prototype_ = GetParam().build();
    prototype_->Clear();
    binary_ = readFile(kGoldenDir / (stem + ".binpb"));
    json_ = readFile(kGoldenDir / (stem + ".json"));
    from_binary_.reset(prototype_->New());
    ASSERT_TRUE(from_binary_->ParseFromString(binary_))
        << stem << ".binpb does not parse as " << prototype_->GetTypeName();
  }

  std::unique_ptr<pb::Message> prototype_;    // an empty message of the golden's type
  std::string binary_;                        // <stem>.binpb as committed
  std::string json_;                          // <stem>.json as committed
  std::unique_ptr<pb::Message> from_binary_;  // binary_ parsed
};

TEST_P(GoldenTest, BinaryHasOnlyKnownFields) {
  std::vector<std::string> paths;
  collectUnknownFields(*from_binary_, from_binary_->GetTypeName(), &paths);
  EXPECT_TRUE(paths.empty()) << "fields unknown to the current proto in: " << joined(paths);
}

TEST_P(GoldenTest, BinaryReserializesToTheSameBytes) {
  ASSERT_FALSE(binary_.empty());
  EXPECT_EQ(serializeDeterministic(*from_binary_), binary_)
      << GetParam().stem << ".binpb changed on a parse/serialize round trip";
}

TEST_P(GoldenTest, JsonParsesToTheBinaryMessage) {
  const auto from_json = parseJson(json_, *prototype_);
  EXPECT_EQ(differences(*from_binary_, *from_json), "");
  EXPECT_EQ(serializeDeterministic(*from_json), binary_);
}

TEST_P(GoldenTest, PrintedJsonParsesBackToTheSameMessage) {
  for (const bool preserve_proto_field_names : {false, true}) {
    pb::util::JsonPrintOptions options;
    options.preserve_proto_field_names = preserve_proto_field_names;
    std::string json;
    ASSERT_TRUE(pb::util::MessageToJsonString(*from_binary_, &json, options).ok());
    const auto reparsed = parseJson(json, *prototype_);
    EXPECT_EQ(differences(*from_binary_, *reparsed), "")
        << "preserve_proto_field_names = " << preserve_proto_field_names;
  }
}

// The generator (make_golden) still produces the committed goldens: a golden edited in
// golden_messages.cpp must be regenerated, and vice versa.
TEST_P(GoldenTest, GeneratorProducesTheCommittedGolden) {
  const auto built = GetParam().build();
  EXPECT_EQ(differences(*built, *from_binary_), "")
      << "rerun wj_make_golden tests/contract/golden (see tests/contract/README.md)";
  EXPECT_EQ(serializeDeterministic(*built), binary_);
}

INSTANTIATE_TEST_SUITE_P(Golden, GoldenTest, ::testing::ValuesIn(goldenCases()),
                         [](const ::testing::TestParamInfo<GoldenCase>& param_info) {
                           return std::string(param_info.param.stem);
                         });

// Semantic spot checks of the parsed goldens: the files hold what their names promise.

TEST(GoldenSemantics, PlanJumpRequestIsARunUpAtThreeMetresPerSecondTowardsAWall) {
  const auto request = parseGoldenBinary<v1::PlanJumpRequest>("plan_jump_request");
  const v1::RobotState& state = request.state();
  const v1::Quaternion& q = state.base_orientation_w();
  EXPECT_NEAR(q.w() * q.w() + q.x() * q.x() + q.y() * q.y() + q.z() * q.z(), 1.0, 1e-3);
  // Run-up speed: the velocity projected on the heading (yaw of R_WB).
  const double yaw = std::atan2(2.0 * (q.w() * q.z() + q.x() * q.y()),
                                1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z()));
  const v1::Vector3& v = state.base_linear_velocity_w_m_s();
  EXPECT_NEAR(v.x() * std::cos(yaw) + v.y() * std::sin(yaw), 3.0, 0.01);
  ASSERT_EQ(state.joint_positions_rad_size(), 16);
  ASSERT_EQ(state.joint_velocities_rad_s_size(), 16);
  EXPECT_DOUBLE_EQ(state.joint_positions_rad(5), 0.7);               // RF_HFE
  EXPECT_NEAR(state.joint_velocities_rad_s(15), 3.0 / 0.085, 0.05);  // RH_WHEEL rolls at v0 / r
  const v1::JumpTask& task = request.task();
  EXPECT_GT(task.target_dx_m(), 0.0);
  EXPECT_EQ(task.event(), v1::TARGET_EVENT_TOUCHDOWN);
  EXPECT_EQ(task.takeoff_mode(), v1::TAKEOFF_MODE_TWO_STEP);
  ASSERT_TRUE(task.has_obstacle());
  EXPECT_DOUBLE_EQ(task.obstacle().height_m(), 0.25);
  EXPECT_LT(task.obstacle().x_min_m(), task.obstacle().x_max_m());
  EXPECT_EQ(request.budget().seed(), 11400714819323198485ULL);
  EXPECT_EQ(request.request_id(), "wj-7f3a-000172");
}

TEST(GoldenSemantics, PlanJumpResponseIsAVerifiedTwoStepPlan) {
  const auto response = parseGoldenBinary<v1::PlanJumpResponse>("plan_jump_response");
  const v1::Plan& plan = response.plan();
  ASSERT_EQ(plan.force_phases_size(), 2);
  EXPECT_DOUBLE_EQ(plan.force_phases(0).t_end_s(), plan.phase_times().t1_s());
  EXPECT_DOUBLE_EQ(plan.force_phases(1).t_end_s(), plan.phase_times().t2_s());
  EXPECT_TRUE(plan.force_phases(1).front().has_fz_n());
  EXPECT_EQ(plan.force_phases(1).front().fz_n().coefficients_size(), 0);
  ASSERT_GE(plan.centroidal_trajectory_size(), 2);
  EXPECT_DOUBLE_EQ(plan.centroidal_trajectory().rbegin()->t_s(), plan.phase_times().t3_s());
  const v1::JointTrajectory& joints = plan.joints();
  ASSERT_EQ(joints.joint_names_size(), 16);
  EXPECT_EQ(joints.joint_names(5), "RF_HFE");
  EXPECT_EQ(joints.num_samples(), 3U);
  EXPECT_EQ(joints.positions_rad_size(), 48);
  EXPECT_EQ(joints.velocities_rad_s_size(), 48);
  EXPECT_EQ(joints.torques_nm_size(), 48);
  EXPECT_EQ(plan.decision_vector_size(), 12);
  EXPECT_TRUE(response.feasibility().feasible());
  std::set<int> classes;
  for (const v1::ConstraintMargin& margin : response.feasibility().margins()) {
    EXPECT_GE(margin.worst_margin(), 0.0) << v1::ConstraintClass_Name(margin.constraint());
    classes.insert(margin.constraint());
  }
  EXPECT_EQ(classes.size(), 10U);
  EXPECT_EQ(response.verification().status(), v1::VERIFICATION_STATUS_PASSED);
  EXPECT_EQ(response.verification().returned_candidate_rank(), 1U);
  EXPECT_EQ(response.source(), v1::PLAN_SOURCE_CACHE_MISS);
  EXPECT_EQ(response.stats().seed(), 11400714819323198485ULL);
  EXPECT_EQ(response.request_id(),
            parseGoldenBinary<v1::PlanJumpRequest>("plan_jump_request").request_id());
}

TEST(GoldenSemantics, GetStatsResponseCountsAddUp) {
  const auto stats = parseGoldenBinary<v1::GetStatsResponse>("get_stats_response");
  EXPECT_EQ(stats.requests(), stats.cache_hits() + stats.cache_misses() + stats.coalesced() +
                                  stats.rejected_invalid() + stats.rejected_queue_full());
  ASSERT_EQ(stats.latencies_size(), 4);
  EXPECT_EQ(stats.latencies(0).path(), "cache_hit");
  EXPECT_EQ(stats.latencies(0).count(), stats.cache_hits());
  EXPECT_DOUBLE_EQ(stats.uptime_s(), 86412.5);
}

TEST(GoldenSemantics, WarmCacheProgressIsPartWayThroughItsGrid) {
  const auto progress = parseGoldenBinary<v1::WarmCacheProgress>("warm_cache_progress");
  EXPECT_EQ(progress.done(), 17U);
  EXPECT_EQ(progress.total(), 41U);
  EXPECT_DOUBLE_EQ(progress.v0_m_s(), 1.6);
  EXPECT_TRUE(progress.feasible());
  EXPECT_EQ(progress.source(), v1::PLAN_SOURCE_WARM_START);
}

}  // namespace
}  // namespace wj::contract
