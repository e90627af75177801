// Breaking-change check and lint of a protobuf contract, on compiled descriptor sets
// (protoc --descriptor_set_out). Compares a committed baseline with the current build so that
// a change that breaks existing clients (wire, JSON or generated code) fails the tests.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>

namespace wj::contract {

/// A rule of the breaking-change check (baseline -> current) or of the lint (current only).
enum class Rule {
  // Breaking changes.
  kFileRemoved,                         ///< a file of the baseline is missing
  kPackageChanged,                      ///< a file's package changed
  kMessageRemoved,                      ///< a message (top-level or nested) is missing
  kFieldNumberChanged,                  ///< a field kept its name but not its number
  kFieldNameChanged,                    ///< a field kept its number but not its name or JSON name
  kFieldTypeChanged,                    ///< scalar type, message type or enum type changed
  kFieldLabelChanged,                   ///< repeated <-> singular, or proto3 `optional` toggled
  kFieldOneofChanged,                   ///< a field moved into, out of or between oneofs
  kFieldRemovedWithoutReservation,      ///< a field is gone but its number or name is not reserved
  kReservationRemoved,                  ///< a reserved number range or name is no longer reserved
  kEnumRemoved,                         ///< an enum (top-level or nested) is missing
  kEnumValueNumberChanged,              ///< an enum value kept its name but not its number
  kEnumValueNameChanged,                ///< an enum value kept its number but not its name
  kEnumValueRemovedWithoutReservation,  ///< a value is gone, its number or name not reserved
  kServiceRemoved,                      ///< a service is missing
  kRpcRemoved,                          ///< an rpc of a kept service is missing
  kRpcTypeChanged,                      ///< an rpc's request or response message changed
  kRpcStreamingChanged,                 ///< an rpc's client or server streaming changed
  // Lint.
  kMessageNameNotUpperCamel,  ///< message names are UpperCamelCase
  kEnumNameNotUpperCamel,     ///< enum names are UpperCamelCase
  kServiceNameNotUpperCamel,  ///< service and rpc names are UpperCamelCase
  kFieldNameNotLowerSnake,    ///< field names are lower_snake_case
  kEnumValueNotUpperSnake,    ///< values are UPPER_SNAKE_CASE, prefixed by the enum's name
  kEnumZeroNotUnspecified,    ///< the zero value exists and is named <PREFIX>_UNSPECIFIED
};

/// The rule's stable name, e.g. "FIELD_NUMBER_CHANGED".
std::string_view ruleName(Rule rule);

/// One violation of a rule.
struct Finding {
  Rule rule;            ///< the rule violated
  std::string element;  ///< full name of the element concerned, e.g. "pkg.Msg.field"
  std::string detail;   ///< what changed or what is wrong, one sentence
};

/// "RULE_NAME element: detail".
std::string formatFinding(const Finding& finding);

/// One formatted finding per line.
std::string formatFindings(const std::vector<Finding>& findings);

/// Reads a serialized FileDescriptorSet. Throws std::runtime_error if unreadable.
google::protobuf::FileDescriptorSet readDescriptorSet(const std::filesystem::path& path);

/// The files of a FileDescriptorSet, linked in a DescriptorPool of their own. Imports missing
/// from the set (protoc without --include_imports) are taken from the descriptors compiled into
/// libprotobuf (the well-known types) when they are there.
class DescriptorSetPool {
 public:
  /// Builds every file of the set. Throws std::runtime_error listing the build errors.
  explicit DescriptorSetPool(const google::protobuf::FileDescriptorSet& set);
  DescriptorSetPool(const DescriptorSetPool&) = delete;
  DescriptorSetPool& operator=(const DescriptorSetPool&) = delete;

  /// The pool holding the set's files and their imports.
  const google::protobuf::DescriptorPool& pool() const { return *pool_; }
  /// The set's own files (not the imports added from libprotobuf), in the set's order.
  const std::vector<const google::protobuf::FileDescriptor*>& files() const { return files_; }

 private:
  std::unique_ptr<google::protobuf::DescriptorPool> pool_;  // owns the built descriptors
  std::vector<const google::protobuf::FileDescriptor*> files_;
};

/// Every change from baseline to current that breaks an existing client: for each file,
/// message, field, enum, enum value, service and rpc of the baseline. Empty when compatible.
/// Additions (files, messages, fields, values, rpcs) are compatible.
std::vector<Finding> findBreakingChanges(const DescriptorSetPool& baseline,
                                         const DescriptorSetPool& current);

/// As above, building both pools from descriptor sets.
std::vector<Finding> findBreakingChanges(const google::protobuf::FileDescriptorSet& baseline,
                                         const google::protobuf::FileDescriptorSet& current);

/// Naming lint of the set's own files (not their imports). Empty when clean.
std::vector<Finding> findLintViolations(const DescriptorSetPool& contract);

/// As above, building the pool from a descriptor set.
std::vector<Finding> findLintViolations(const google::protobuf::FileDescriptorSet& contract);

}  // namespace wj::contract
