// Tests of the breaking-change check and lint (proto_compat.h): the current contract against
// the committed baseline, then the checker's verdict on baselines modified in memory.
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>

#include "proto_compat.h"

namespace wj::contract {
namespace {

namespace pb = google::protobuf;

const std::filesystem::path kCurrentDescriptor = WJ_PROTO_DESCRIPTOR;
const std::filesystem::path kBaselineDescriptor = WJ_PROTO_BASELINE;
const std::filesystem::path kProtoSourceDir = WJ_PROTO_SOURCE_DIR;
constexpr const char* kContractFile = "wheeljump/planner/v1/jump_planner.proto";
constexpr const char* kPackage = "wheeljump.planner.v1";

// "RULE element" of each finding, sorted: what the assertions compare.
std::vector<std::string> verdict(const std::vector<Finding>& findings) {
  std::vector<std::string> lines;
  for (const Finding& finding : findings) {
    lines.push_back(std::string(ruleName(finding.rule)) + " " + finding.element);
  }
  std::sort(lines.begin(), lines.end());
  return lines;
}

std::string qualified(const std::string& name) {
  return std::string(kPackage) + "." + name;
}

pb::FileDescriptorProto& contractFile(pb::FileDescriptorSet& set) {
  for (pb::FileDescriptorProto& file : *set.mutable_file()) {
    if (file.name() == kContractFile) return file;
  }
  throw std::runtime_error(std::string("no ") + kContractFile + " in the descriptor set");
}

pb::DescriptorProto& messageNamed(pb::FileDescriptorSet& set, const std::string& name) {
  for (pb::DescriptorProto& message : *contractFile(set).mutable_message_type()) {
    if (message.name() == name) return message;
  }
  throw std::runtime_error("no message " + name);
}

pb::FieldDescriptorProto& fieldNamed(pb::DescriptorProto& message, const std::string& name) {
  for (pb::FieldDescriptorProto& field : *message.mutable_field()) {
    if (field.name() == name) return field;
  }
  throw std::runtime_error("no field " + name + " in " + message.name());
}

pb::EnumDescriptorProto& enumNamed(pb::FileDescriptorSet& set, const std::string& name) {
  for (pb::EnumDescriptorProto& enum_type : *contractFile(set).mutable_enum_type()) {
    if (enum_type.name() == name) return enum_type;
  }
  throw std::runtime_error("no enum " + name);
}

pb::MethodDescriptorProto& rpcNamed(pb::FileDescriptorSet& set, const std::string& name) {
  for (pb::MethodDescriptorProto& rpc : *contractFile(set).mutable_service(0)->mutable_method()) {
    if (rpc.name() == name) return rpc;
  }
  throw std::runtime_error("no rpc " + name);
}

// Removes the elements of a repeated field for which keep() is false.
template <typename Repeated, typename Predicate>
void eraseIf(Repeated* items, Predicate remove) {
  items->erase(std::remove_if(items->begin(), items->end(), remove), items->end());
}

void removeField(pb::DescriptorProto& message, const std::string& name) {
  eraseIf(message.mutable_field(),
          [&](const pb::FieldDescriptorProto& field) { return field.name() == name; });
}

// Renames a field as protoc would see it after an edit of the .proto (JSON name recomputed).
void renameField(pb::FieldDescriptorProto& field, const std::string& name) {
  field.set_name(name);
  field.clear_json_name();
}

void reserveNumber(pb::DescriptorProto& message, int number) {
  pb::DescriptorProto::ReservedRange& range = *message.add_reserved_range();
  range.set_start(number);
  range.set_end(number + 1);  // exclusive
}

class ProtoCompatTest : public ::testing::Test {
 protected:
  void SetUp() override { baseline_ = readDescriptorSet(kBaselineDescriptor); }

  // Findings of the checker from the unmodified baseline to `current`.
  std::vector<std::string> breakingChangesTo(const pb::FileDescriptorSet& current) const {
    return verdict(findBreakingChanges(baseline_, current));
  }

  pb::FileDescriptorSet baseline_;
};

// --- The current contract -----------------------------------------------------------------

TEST(CurrentContract, HasNoBreakingChangeAgainstTheBaseline) {
  const auto findings = findBreakingChanges(readDescriptorSet(kBaselineDescriptor),
                                            readDescriptorSet(kCurrentDescriptor));
  EXPECT_TRUE(findings.empty()) << findings.size() << " breaking change(s) of " << kContractFile
                                << " against proto/baseline (bump the package version instead; see "
                                   "tests/contract/README.md):\n"
                                << formatFindings(findings);
}

TEST(CurrentContract, PassesTheLint) {
  const auto findings = findLintViolations(readDescriptorSet(kCurrentDescriptor));
  EXPECT_TRUE(findings.empty()) << formatFindings(findings);
}

// ctest does not rebuild: a descriptor older than its .proto would check a stale contract.
TEST(CurrentContract, DescriptorIsNotOlderThanTheProtoSources) {
  const pb::FileDescriptorSet current = readDescriptorSet(kCurrentDescriptor);
  ASSERT_GT(current.file_size(), 0);
  const auto built = std::filesystem::last_write_time(kCurrentDescriptor);
  for (const pb::FileDescriptorProto& file : current.file()) {
    const std::filesystem::path source = kProtoSourceDir / file.name();
    ASSERT_TRUE(std::filesystem::exists(source)) << source;
    EXPECT_LE(std::filesystem::last_write_time(source), built)
        << source << " changed after " << kCurrentDescriptor << " was built: rebuild first";
  }
}

TEST(CurrentContract, BaselineDescribesThePlannerService) {
  const DescriptorSetPool baseline(readDescriptorSet(kBaselineDescriptor));
  ASSERT_EQ(baseline.files().size(), 1U);
  EXPECT_EQ(baseline.files().front()->package(), kPackage);
  const pb::ServiceDescriptor* service =
      baseline.pool().FindServiceByName(qualified("JumpPlanner"));
  ASSERT_NE(service, nullptr);
  EXPECT_EQ(service->method_count(), 3);
}

// --- Verdicts on modified contracts ---------------------------------------------------------

TEST_F(ProtoCompatTest, UnchangedContractIsCompatible) {
  EXPECT_EQ(breakingChangesTo(baseline_), std::vector<std::string>{});
}

TEST_F(ProtoCompatTest, ChangedFieldNumberIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  fieldNamed(messageNamed(current, "PlanJumpRequest"), "request_id").set_number(14);
  EXPECT_EQ(
      breakingChangesTo(current),
      std::vector<std::string>{"FIELD_NUMBER_CHANGED " + qualified("PlanJumpRequest.request_id")});
}

TEST_F(ProtoCompatTest, SwappedFieldNumbersAreBothReported) {
  pb::FileDescriptorSet current = baseline_;
  pb::DescriptorProto& vector3 = messageNamed(current, "Vector3");
  fieldNamed(vector3, "x").set_number(2);
  fieldNamed(vector3, "y").set_number(1);
  EXPECT_EQ(breakingChangesTo(current),
            (std::vector<std::string>{"FIELD_NUMBER_CHANGED " + qualified("Vector3.x"),
                                      "FIELD_NUMBER_CHANGED " + qualified("Vector3.y")}));
}

TEST_F(ProtoCompatTest, ChangedScalarTypeIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  fieldNamed(messageNamed(current, "Vector3"), "z").set_type(pb::FieldDescriptorProto::TYPE_FLOAT);
  // Wire-compatible widenings break JSON and generated code all the same.
  fieldNamed(messageNamed(current, "ComputeBudget"), "max_evaluations")
      .set_type(pb::FieldDescriptorProto::TYPE_UINT64);
  EXPECT_EQ(
      breakingChangesTo(current),
      (std::vector<std::string>{"FIELD_TYPE_CHANGED " + qualified("ComputeBudget.max_evaluations"),
                                "FIELD_TYPE_CHANGED " + qualified("Vector3.z")}));
}

TEST_F(ProtoCompatTest, ChangedMessageTypeIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  fieldNamed(messageNamed(current, "PlanJumpRequest"), "budget")
      .set_type_name("." + qualified("JumpTask"));
  EXPECT_EQ(breakingChangesTo(current),
            std::vector<std::string>{"FIELD_TYPE_CHANGED " + qualified("PlanJumpRequest.budget")});
}

TEST_F(ProtoCompatTest, RepeatedBecomingSingularIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  fieldNamed(messageNamed(current, "RobotState"), "joint_positions_rad")
      .set_label(pb::FieldDescriptorProto::LABEL_OPTIONAL);
  EXPECT_EQ(breakingChangesTo(current),
            std::vector<std::string>{"FIELD_LABEL_CHANGED " +
                                     qualified("RobotState.joint_positions_rad")});
}

TEST_F(ProtoCompatTest, AddedOptionalKeywordIsALabelChange) {
  pb::FileDescriptorSet current = baseline_;
  pb::DescriptorProto& state = messageNamed(current, "RobotState");
  // protoc's encoding of `optional double stamp_s = 7;`: a synthetic oneof around the field.
  state.add_oneof_decl()->set_name("_stamp_s");
  pb::FieldDescriptorProto& stamp = fieldNamed(state, "stamp_s");
  stamp.set_proto3_optional(true);
  stamp.set_oneof_index(state.oneof_decl_size() - 1);
  EXPECT_EQ(breakingChangesTo(current),
            std::vector<std::string>{"FIELD_LABEL_CHANGED " + qualified("RobotState.stamp_s")});
}

TEST_F(ProtoCompatTest, MovingFieldsIntoAOneofIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  pb::DescriptorProto& task = messageNamed(current, "JumpTask");
  task.add_oneof_decl()->set_name("target");
  fieldNamed(task, "target_dx_m").set_oneof_index(0);
  fieldNamed(task, "target_height_m").set_oneof_index(0);
  EXPECT_EQ(
      breakingChangesTo(current),
      (std::vector<std::string>{"FIELD_ONEOF_CHANGED " + qualified("JumpTask.target_dx_m"),
                                "FIELD_ONEOF_CHANGED " + qualified("JumpTask.target_height_m")}));
}

TEST_F(ProtoCompatTest, RenamedFieldIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  renameField(fieldNamed(messageNamed(current, "PlanJumpRequest"), "request_id"), "request_key");
  EXPECT_EQ(
      breakingChangesTo(current),
      std::vector<std::string>{"FIELD_NAME_CHANGED " + qualified("PlanJumpRequest.request_id")});
}

TEST_F(ProtoCompatTest, ChangedJsonNameIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  fieldNamed(messageNamed(current, "PlanJumpRequest"), "request_id").set_json_name("rid");
  EXPECT_EQ(
      breakingChangesTo(current),
      std::vector<std::string>{"FIELD_NAME_CHANGED " + qualified("PlanJumpRequest.request_id")});
}

TEST_F(ProtoCompatTest, RemovedFieldWithoutReservationIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  removeField(messageNamed(current, "PlanJumpRequest"), "request_id");
  EXPECT_EQ(breakingChangesTo(current),
            std::vector<std::string>{"FIELD_REMOVED_WITHOUT_RESERVATION " +
                                     qualified("PlanJumpRequest.request_id")});
}

TEST_F(ProtoCompatTest, RemovedFieldNeedsBothNumberAndNameReserved) {
  pb::FileDescriptorSet number_only = baseline_;
  removeField(messageNamed(number_only, "PlanJumpRequest"), "request_id");
  reserveNumber(messageNamed(number_only, "PlanJumpRequest"), 4);
  EXPECT_EQ(breakingChangesTo(number_only).size(), 1U);

  pb::FileDescriptorSet name_only = baseline_;
  removeField(messageNamed(name_only, "PlanJumpRequest"), "request_id");
  messageNamed(name_only, "PlanJumpRequest").add_reserved_name("request_id");
  EXPECT_EQ(breakingChangesTo(name_only).size(), 1U);
}

TEST_F(ProtoCompatTest, RemovedFieldWithReservationIsAllowed) {
  pb::FileDescriptorSet current = baseline_;
  pb::DescriptorProto& request = messageNamed(current, "PlanJumpRequest");
  removeField(request, "request_id");
  reserveNumber(request, 4);
  request.add_reserved_name("request_id");
  EXPECT_EQ(breakingChangesTo(current), std::vector<std::string>{});
}

TEST_F(ProtoCompatTest, DroppedReservationIsBreaking) {
  pb::FileDescriptorSet reserved = baseline_;
  pb::DescriptorProto& request = messageNamed(reserved, "PlanJumpRequest");
  removeField(request, "request_id");
  reserveNumber(request, 4);
  request.add_reserved_name("request_id");
  // The next version reuses number 4 for another field, dropping the reservation.
  pb::FileDescriptorSet reused = reserved;
  pb::DescriptorProto& next = messageNamed(reused, "PlanJumpRequest");
  next.clear_reserved_range();
  next.clear_reserved_name();
  pb::FieldDescriptorProto& trace = *next.add_field();
  trace.set_name("trace_id");
  trace.set_number(4);
  trace.set_label(pb::FieldDescriptorProto::LABEL_OPTIONAL);
  trace.set_type(pb::FieldDescriptorProto::TYPE_UINT64);
  EXPECT_EQ(verdict(findBreakingChanges(reserved, reused)),
            (std::vector<std::string>{"RESERVATION_REMOVED " + qualified("PlanJumpRequest"),
                                      "RESERVATION_REMOVED " + qualified("PlanJumpRequest")}));
}

TEST_F(ProtoCompatTest, AdditionsAreAllowed) {
  pb::FileDescriptorSet current = baseline_;
  pb::FieldDescriptorProto& priority = *messageNamed(current, "PlanJumpRequest").add_field();
  priority.set_name("priority");
  priority.set_number(6);
  priority.set_label(pb::FieldDescriptorProto::LABEL_OPTIONAL);
  priority.set_type(pb::FieldDescriptorProto::TYPE_UINT32);
  pb::EnumValueDescriptorProto& land = *enumNamed(current, "TargetEvent").add_value();
  land.set_name("TARGET_EVENT_LANDED");
  land.set_number(3);
  contractFile(current).add_message_type()->set_name("CancelRequest");
  pb::MethodDescriptorProto& cancel = *contractFile(current).mutable_service(0)->add_method();
  cancel.set_name("Cancel");
  cancel.set_input_type("." + qualified("CancelRequest"));
  cancel.set_output_type("." + qualified("GetStatsResponse"));
  EXPECT_EQ(breakingChangesTo(current), std::vector<std::string>{});
}

TEST_F(ProtoCompatTest, EnumValueChanges) {
  pb::FileDescriptorSet removed = baseline_;
  eraseIf(enumNamed(removed, "TargetEvent").mutable_value(),
          [](const pb::EnumValueDescriptorProto& v) { return v.name() == "TARGET_EVENT_APEX"; });
  EXPECT_EQ(breakingChangesTo(removed),
            std::vector<std::string>{"ENUM_VALUE_REMOVED_WITHOUT_RESERVATION " +
                                     qualified("TargetEvent.TARGET_EVENT_APEX")});

  pb::FileDescriptorSet reserved = removed;
  pb::EnumDescriptorProto::EnumReservedRange& range =
      *enumNamed(reserved, "TargetEvent").add_reserved_range();
  range.set_start(1);
  range.set_end(1);  // inclusive
  enumNamed(reserved, "TargetEvent").add_reserved_name("TARGET_EVENT_APEX");
  EXPECT_EQ(breakingChangesTo(reserved), std::vector<std::string>{});

  pb::FileDescriptorSet renumbered = baseline_;
  for (auto& value : *enumNamed(renumbered, "TakeoffMode").mutable_value()) {
    if (value.name() == "TAKEOFF_MODE_TWO_STEP") value.set_number(3);
  }
  EXPECT_EQ(breakingChangesTo(renumbered),
            std::vector<std::string>{"ENUM_VALUE_NUMBER_CHANGED " +
                                     qualified("TakeoffMode.TAKEOFF_MODE_TWO_STEP")});

  pb::FileDescriptorSet renamed = baseline_;
  for (auto& value : *enumNamed(renamed, "PlanSource").mutable_value()) {
    if (value.name() == "PLAN_SOURCE_CACHE_HIT") value.set_name("PLAN_SOURCE_CACHED");
  }
  EXPECT_EQ(breakingChangesTo(renamed),
            std::vector<std::string>{"ENUM_VALUE_NAME_CHANGED " +
                                     qualified("PlanSource.PLAN_SOURCE_CACHE_HIT")});
}

TEST_F(ProtoCompatTest, RemovedEnumIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  eraseIf(contractFile(current).mutable_enum_type(),
          [](const pb::EnumDescriptorProto& e) { return e.name() == "TargetEvent"; });
  pb::DescriptorProto& task = messageNamed(current, "JumpTask");
  removeField(task, "event");
  reserveNumber(task, 4);
  task.add_reserved_name("event");
  EXPECT_EQ(breakingChangesTo(current),
            std::vector<std::string>{"ENUM_REMOVED " + qualified("TargetEvent")});
}

TEST_F(ProtoCompatTest, RemovedRpcAndMessagesAreBreaking) {
  pb::FileDescriptorSet current = baseline_;
  eraseIf(contractFile(current).mutable_service(0)->mutable_method(),
          [](const pb::MethodDescriptorProto& rpc) { return rpc.name() == "WarmCache"; });
  eraseIf(contractFile(current).mutable_message_type(), [](const pb::DescriptorProto& m) {
    return m.name() == "WarmCacheRequest" || m.name() == "WarmCacheProgress";
  });
  EXPECT_EQ(breakingChangesTo(current),
            (std::vector<std::string>{"MESSAGE_REMOVED " + qualified("WarmCacheProgress"),
                                      "MESSAGE_REMOVED " + qualified("WarmCacheRequest"),
                                      "RPC_REMOVED " + qualified("JumpPlanner.WarmCache")}));
}

TEST_F(ProtoCompatTest, RemovedServiceIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  contractFile(current).clear_service();
  EXPECT_EQ(breakingChangesTo(current),
            std::vector<std::string>{"SERVICE_REMOVED " + qualified("JumpPlanner")});
}

TEST_F(ProtoCompatTest, ChangedRpcSignatureIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  rpcNamed(current, "PlanJump").set_input_type("." + qualified("GetStatsRequest"));
  rpcNamed(current, "GetStats").set_output_type("." + qualified("WarmCacheProgress"));
  rpcNamed(current, "WarmCache").set_server_streaming(false);
  EXPECT_EQ(breakingChangesTo(current),
            (std::vector<std::string>{"RPC_STREAMING_CHANGED " + qualified("JumpPlanner.WarmCache"),
                                      "RPC_TYPE_CHANGED " + qualified("JumpPlanner.GetStats"),
                                      "RPC_TYPE_CHANGED " + qualified("JumpPlanner.PlanJump")}));
}

TEST_F(ProtoCompatTest, ChangedPackageIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  pb::FileDescriptorProto& file = contractFile(current);
  const std::string old_prefix = std::string(".") + kPackage + ".";
  const std::string new_prefix = ".wheeljump.planner.v2.";
  const auto repackage = [&](std::string* type_name) {
    if (type_name->rfind(old_prefix, 0) == 0) type_name->replace(0, old_prefix.size(), new_prefix);
  };
  file.set_package("wheeljump.planner.v2");
  for (pb::DescriptorProto& message : *file.mutable_message_type()) {
    for (pb::FieldDescriptorProto& field : *message.mutable_field()) {
      if (field.has_type_name()) repackage(field.mutable_type_name());
    }
  }
  for (pb::MethodDescriptorProto& rpc : *file.mutable_service(0)->mutable_method()) {
    repackage(rpc.mutable_input_type());
    repackage(rpc.mutable_output_type());
  }
  const auto findings = breakingChangesTo(current);
  EXPECT_NE(
      std::find(findings.begin(), findings.end(), std::string("PACKAGE_CHANGED ") + kContractFile),
      findings.end());
  // ... and every type of v1 is gone from the current contract.
  EXPECT_NE(
      std::find(findings.begin(), findings.end(), "SERVICE_REMOVED " + qualified("JumpPlanner")),
      findings.end());
  EXPECT_EQ(std::count_if(findings.begin(), findings.end(),
                          [](const std::string& f) { return f.rfind("MESSAGE_REMOVED ", 0) == 0; }),
            contractFile(baseline_).message_type_size());
}

TEST_F(ProtoCompatTest, MovedFileIsBreaking) {
  pb::FileDescriptorSet current = baseline_;
  contractFile(current).set_name("wheeljump/planner/v1/planner.proto");
  EXPECT_EQ(breakingChangesTo(current),
            std::vector<std::string>{std::string("FILE_REMOVED ") + kContractFile});
}

TEST_F(ProtoCompatTest, EveryViolationIsListed) {
  pb::FileDescriptorSet current = baseline_;
  fieldNamed(messageNamed(current, "PlanJumpRequest"), "request_id").set_number(14);
  removeField(messageNamed(current, "JumpTask"), "obstacle");
  fieldNamed(messageNamed(current, "Vector3"), "z").set_type(pb::FieldDescriptorProto::TYPE_FLOAT);
  rpcNamed(current, "WarmCache").set_server_streaming(false);
  const auto findings = findBreakingChanges(baseline_, current);
  EXPECT_EQ(verdict(findings),
            (std::vector<std::string>{
                "FIELD_NUMBER_CHANGED " + qualified("PlanJumpRequest.request_id"),
                "FIELD_REMOVED_WITHOUT_RESERVATION " + qualified("JumpTask.obstacle"),
                "FIELD_TYPE_CHANGED " + qualified("Vector3.z"),
                "RPC_STREAMING_CHANGED " + qualified("JumpPlanner.WarmCache")}));
  const std::string report = formatFindings(findings);
  EXPECT_NE(report.find("number 4 became 14"), std::string::npos) << report;
  EXPECT_NE(report.find("type double became float"), std::string::npos) << report;
}

// --- Loading --------------------------------------------------------------------------------

TEST_F(ProtoCompatTest, WellKnownImportsAreResolvedFromLibprotobuf) {
  pb::FileDescriptorSet current = baseline_;
  contractFile(current).add_dependency("google/protobuf/timestamp.proto");
  pb::FieldDescriptorProto& stamp = *messageNamed(current, "RobotState").add_field();
  stamp.set_name("measured_at");
  stamp.set_number(8);
  stamp.set_label(pb::FieldDescriptorProto::LABEL_OPTIONAL);
  stamp.set_type(pb::FieldDescriptorProto::TYPE_MESSAGE);
  stamp.set_type_name(".google.protobuf.Timestamp");
  const DescriptorSetPool pool(current);
  EXPECT_EQ(pool.files().size(), 1U);  // the import is not one of the set's own files
  EXPECT_EQ(breakingChangesTo(current), std::vector<std::string>{});
}

TEST_F(ProtoCompatTest, BrokenDescriptorSetIsRejected) {
  pb::FileDescriptorSet broken = baseline_;
  fieldNamed(messageNamed(broken, "PlanJumpRequest"), "budget")
      .set_type_name("." + qualified("NoSuchMessage"));
  EXPECT_THROW(DescriptorSetPool{broken}, std::runtime_error);
  EXPECT_THROW(readDescriptorSet(kProtoSourceDir / "no_such_file.binpb"), std::runtime_error);
}

// --- Lint -----------------------------------------------------------------------------------

std::vector<std::string> lintOf(const pb::FileDescriptorSet& set) {
  return verdict(findLintViolations(set));
}

TEST_F(ProtoCompatTest, LintAcceptsTheBaseline) {
  EXPECT_EQ(lintOf(baseline_), std::vector<std::string>{});
}

TEST_F(ProtoCompatTest, LintRequiresAnUnspecifiedZeroValue) {
  pb::FileDescriptorSet current = baseline_;
  enumNamed(current, "TargetEvent").mutable_value(0)->set_name("TARGET_EVENT_NONE");
  EXPECT_EQ(lintOf(current), std::vector<std::string>{"LINT_ENUM_ZERO_UNSPECIFIED " +
                                                      qualified("TargetEvent.TARGET_EVENT_NONE")});
}

TEST_F(ProtoCompatTest, LintRequiresPrefixedUpperSnakeEnumValues) {
  pb::FileDescriptorSet current = baseline_;
  enumNamed(current, "TargetEvent").mutable_value(1)->set_name("APEX");
  EXPECT_EQ(lintOf(current), std::vector<std::string>{"LINT_ENUM_VALUE_UPPER_SNAKE " +
                                                      qualified("TargetEvent.APEX")});
}

TEST_F(ProtoCompatTest, LintRequiresLowerSnakeFieldNames) {
  pb::FileDescriptorSet current = baseline_;
  renameField(fieldNamed(messageNamed(current, "PlanJumpRequest"), "request_id"), "requestId");
  renameField(fieldNamed(messageNamed(current, "Vector3"), "x"), "X");
  EXPECT_EQ(lintOf(current),
            (std::vector<std::string>{
                "LINT_FIELD_NAME_LOWER_SNAKE " + qualified("PlanJumpRequest.requestId"),
                "LINT_FIELD_NAME_LOWER_SNAKE " + qualified("Vector3.X")}));
}

TEST_F(ProtoCompatTest, LintRequiresUpperCamelTypeNames) {
  pb::FileDescriptorSet current = baseline_;
  contractFile(current).add_message_type()->set_name("cancel_request");
  pb::EnumDescriptorProto& kind = *contractFile(current).add_enum_type();
  kind.set_name("jump_kind");
  kind.add_value()->set_name("JUMP_KIND_UNSPECIFIED");
  contractFile(current).mutable_service(0)->mutable_method(0)->set_name("planJump");
  EXPECT_EQ(lintOf(current),
            (std::vector<std::string>{
                "LINT_ENUM_NAME_UPPER_CAMEL " + qualified("jump_kind"),
                "LINT_MESSAGE_NAME_UPPER_CAMEL " + qualified("cancel_request"),
                "LINT_SERVICE_NAME_UPPER_CAMEL " + qualified("JumpPlanner.planJump")}));
}

}  // namespace
}  // namespace wj::contract
