#include "proto_compat.h"

#include <algorithm>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace wj::contract {
namespace {

namespace pb = google::protobuf;

// Collects the errors of DescriptorPool::BuildFileCollectingErrors.
class ErrorList : public pb::DescriptorPool::ErrorCollector {
 public:
  void AddError(const std::string& filename, const std::string& element_name,
                const pb::Message* /*descriptor*/, ErrorLocation /*location*/,
                const std::string& message) override {
    text_ += filename + ": " + element_name + ": " + message + "\n";
  }
  const std::string& text() const { return text_; }

 private:
  std::string text_;
};

// "double", "enum pkg.Kind" or "message pkg.Msg": what a field holds.
std::string describeType(const pb::FieldDescriptor& field) {
  switch (field.type()) {
    case pb::FieldDescriptor::TYPE_MESSAGE:
    case pb::FieldDescriptor::TYPE_GROUP:
      return "message " + field.message_type()->full_name();
    case pb::FieldDescriptor::TYPE_ENUM:
      return "enum " + field.enum_type()->full_name();
    default:
      return pb::FieldDescriptor::TypeName(field.type());
  }
}

// "repeated", "required", "optional" (proto3 explicit presence) or "singular".
std::string describeLabel(const pb::FieldDescriptor& field) {
  if (field.is_repeated()) return "repeated";
  if (field.is_required()) return "required";
  if (field.has_optional_keyword()) return "optional";
  return "singular";
}

std::string describeOneof(const pb::FieldDescriptor& field) {
  const pb::OneofDescriptor* oneof = field.real_containing_oneof();
  return oneof == nullptr ? "no oneof" : "oneof " + oneof->name();
}

// True when the half-open number interval [start, end) lies inside the union of ranges.
bool isCovered(int start, int end, std::vector<std::pair<int, int>> ranges) {
  std::sort(ranges.begin(), ranges.end());
  long long covered_to = start;  // everything in [start, covered_to) is covered
  for (const auto& [range_start, range_end] : ranges) {
    if (range_start > covered_to) break;
    covered_to = std::max<long long>(covered_to, range_end);
  }
  return covered_to >= end;
}

// Compares one baseline file's elements with the current pool, appending to findings.
class BreakingChangeChecker {
 public:
  BreakingChangeChecker(const pb::DescriptorPool& current, std::vector<Finding>* findings)
      : current_(current), findings_(*findings) {}

  void checkFile(const pb::FileDescriptor& base) {
    const pb::FileDescriptor* cur = current_.FindFileByName(base.name());
    if (cur == nullptr) {
      add(Rule::kFileRemoved, base.name(), "file removed or renamed");
    } else if (cur->package() != base.package()) {
      add(Rule::kPackageChanged, base.name(),
          "package " + base.package() + " became " + cur->package());
    }
    for (int i = 0; i < base.message_type_count(); ++i) checkMessage(*base.message_type(i));
    for (int i = 0; i < base.enum_type_count(); ++i) checkEnum(*base.enum_type(i));
    for (int i = 0; i < base.service_count(); ++i) checkService(*base.service(i));
  }

 private:
  void add(Rule rule, std::string element, std::string detail) {
    findings_.push_back({rule, std::move(element), std::move(detail)});
  }

  void checkMessage(const pb::Descriptor& base) {
    const pb::Descriptor* cur = current_.FindMessageTypeByName(base.full_name());
    if (cur == nullptr) {
      add(Rule::kMessageRemoved, base.full_name(), "message removed or renamed");
      return;  // its fields and nested types went with it
    }
    for (int i = 0; i < base.field_count(); ++i) checkField(*base.field(i), *cur);
    checkMessageReservations(base, *cur);
    for (int i = 0; i < base.nested_type_count(); ++i) checkMessage(*base.nested_type(i));
    for (int i = 0; i < base.enum_type_count(); ++i) checkEnum(*base.enum_type(i));
  }

  // A field is identified by its name first (so that a renumbering is named as such), then by
  // its number (a rename).
  void checkField(const pb::FieldDescriptor& base, const pb::Descriptor& cur_message) {
    const std::string& element = base.full_name();
    if (const pb::FieldDescriptor* cur = cur_message.FindFieldByName(base.name())) {
      if (cur->number() != base.number()) {
        add(Rule::kFieldNumberChanged, element,
            "number " + std::to_string(base.number()) + " became " + std::to_string(cur->number()));
      }
      if (cur->json_name() != base.json_name()) {
        add(Rule::kFieldNameChanged, element,
            "JSON name \"" + base.json_name() + "\" became \"" + cur->json_name() + "\"");
      }
      checkFieldShape(base, *cur);
      return;
    }
    if (const pb::FieldDescriptor* cur = cur_message.FindFieldByNumber(base.number())) {
      add(Rule::kFieldNameChanged, element,
          "field " + std::to_string(base.number()) + " renamed to " + cur->name() +
              " (breaks JSON and generated code)");
      checkFieldShape(base, *cur);
      return;
    }
    std::vector<std::string> missing;
    if (!cur_message.IsReservedNumber(base.number())) {
      missing.push_back("number " + std::to_string(base.number()));
    }
    if (!cur_message.IsReservedName(base.name())) missing.push_back("name \"" + base.name() + "\"");
    if (!missing.empty()) {
      std::string detail = "field removed without reserving its";
      for (std::size_t i = 0; i < missing.size(); ++i) detail += (i ? " and " : " ") + missing[i];
      add(Rule::kFieldRemovedWithoutReservation, element, detail);
    }
  }

  void checkFieldShape(const pb::FieldDescriptor& base, const pb::FieldDescriptor& cur) {
    const std::string& element = base.full_name();
    if (describeType(base) != describeType(cur)) {
      add(Rule::kFieldTypeChanged, element,
          "type " + describeType(base) + " became " + describeType(cur));
    }
    if (describeLabel(base) != describeLabel(cur)) {
      add(Rule::kFieldLabelChanged, element,
          "label " + describeLabel(base) + " became " + describeLabel(cur));
    }
    if (describeOneof(base) != describeOneof(cur)) {
      add(Rule::kFieldOneofChanged, element, describeOneof(base) + " became " + describeOneof(cur));
    }
  }

  void checkMessageReservations(const pb::Descriptor& base, const pb::Descriptor& cur) {
    std::vector<std::pair<int, int>> cur_ranges;  // [start, end)
    for (int i = 0; i < cur.reserved_range_count(); ++i) {
      cur_ranges.emplace_back(cur.reserved_range(i)->start, cur.reserved_range(i)->end);
    }
    for (int i = 0; i < base.reserved_range_count(); ++i) {
      const pb::Descriptor::ReservedRange& range = *base.reserved_range(i);
      if (!isCovered(range.start, range.end, cur_ranges)) {
        add(Rule::kReservationRemoved, base.full_name(),
            "reserved numbers " + std::to_string(range.start) + " to " +
                std::to_string(range.end - 1) + " are no longer all reserved");
      }
    }
    for (int i = 0; i < base.reserved_name_count(); ++i) {
      if (!cur.IsReservedName(base.reserved_name(i))) {
        add(Rule::kReservationRemoved, base.full_name(),
            "reserved name \"" + base.reserved_name(i) + "\" is no longer reserved");
      }
    }
  }

  void checkEnum(const pb::EnumDescriptor& base) {
    const pb::EnumDescriptor* cur = current_.FindEnumTypeByName(base.full_name());
    if (cur == nullptr) {
      add(Rule::kEnumRemoved, base.full_name(), "enum removed or renamed");
      return;
    }
    for (int i = 0; i < base.value_count(); ++i) {
      const pb::EnumValueDescriptor& value = *base.value(i);
      const std::string element = base.full_name() + "." + value.name();
      if (const pb::EnumValueDescriptor* by_name = cur->FindValueByName(value.name())) {
        if (by_name->number() != value.number()) {
          add(Rule::kEnumValueNumberChanged, element,
              "number " + std::to_string(value.number()) + " became " +
                  std::to_string(by_name->number()));
        }
      } else if (const pb::EnumValueDescriptor* by_number =
                     cur->FindValueByNumber(value.number())) {
        add(Rule::kEnumValueNameChanged, element,
            "value " + std::to_string(value.number()) + " renamed to " + by_number->name() +
                " (JSON carries enum values by name)");
      } else if (!cur->IsReservedNumber(value.number()) || !cur->IsReservedName(value.name())) {
        add(Rule::kEnumValueRemovedWithoutReservation, element,
            "value " + std::to_string(value.number()) +
                " removed without reserving both its number and its name");
      }
    }
    std::vector<std::pair<int, int>> cur_ranges;  // [start, end): enum ranges are inclusive
    for (int i = 0; i < cur->reserved_range_count(); ++i) {
      cur_ranges.emplace_back(cur->reserved_range(i)->start, cur->reserved_range(i)->end + 1);
    }
    for (int i = 0; i < base.reserved_range_count(); ++i) {
      const pb::EnumDescriptor::ReservedRange& range = *base.reserved_range(i);
      if (!isCovered(range.start, range.end + 1, cur_ranges)) {
        add(Rule::kReservationRemoved, base.full_name(),
            "reserved values " + std::to_string(range.start) + " to " + std::to_string(range.end) +
                " are no longer all reserved");
      }
    }
    for (int i = 0; i < base.reserved_name_count(); ++i) {
      if (!cur->IsReservedName(base.reserved_name(i))) {
        add(Rule::kReservationRemoved, base.full_name(),
            "reserved name \"" + base.reserved_name(i) + "\" is no longer reserved");
      }
    }
  }

  void checkService(const pb::ServiceDescriptor& base) {
    const pb::ServiceDescriptor* cur = current_.FindServiceByName(base.full_name());
    if (cur == nullptr) {
      add(Rule::kServiceRemoved, base.full_name(), "service removed or renamed");
      return;
    }
    for (int i = 0; i < base.method_count(); ++i) {
      const pb::MethodDescriptor& rpc = *base.method(i);
      const pb::MethodDescriptor* cur_rpc = cur->FindMethodByName(rpc.name());
      if (cur_rpc == nullptr) {
        add(Rule::kRpcRemoved, rpc.full_name(), "rpc removed or renamed");
        continue;
      }
      if (cur_rpc->input_type()->full_name() != rpc.input_type()->full_name()) {
        add(Rule::kRpcTypeChanged, rpc.full_name(),
            "request " + rpc.input_type()->full_name() + " became " +
                cur_rpc->input_type()->full_name());
      }
      if (cur_rpc->output_type()->full_name() != rpc.output_type()->full_name()) {
        add(Rule::kRpcTypeChanged, rpc.full_name(),
            "response " + rpc.output_type()->full_name() + " became " +
                cur_rpc->output_type()->full_name());
      }
      if (cur_rpc->client_streaming() != rpc.client_streaming() ||
          cur_rpc->server_streaming() != rpc.server_streaming()) {
        const auto streaming = [](const pb::MethodDescriptor& m) {
          return std::string(m.client_streaming() ? "stream " : "") + "request, " +
                 (m.server_streaming() ? "stream " : "") + "response";
        };
        add(Rule::kRpcStreamingChanged, rpc.full_name(),
            streaming(rpc) + " became " + streaming(*cur_rpc));
      }
    }
  }

  const pb::DescriptorPool& current_;
  std::vector<Finding>& findings_;
};

bool isUpperCamel(const std::string& name) {
  static const std::regex pattern("[A-Z][A-Za-z0-9]*");
  return std::regex_match(name, pattern);
}

bool isLowerSnake(const std::string& name) {
  static const std::regex pattern("[a-z][a-z0-9]*(_[a-z0-9]+)*");
  return std::regex_match(name, pattern);
}

bool isUpperSnake(const std::string& name) {
  static const std::regex pattern("[A-Z][A-Z0-9]*(_[A-Z0-9]+)*");
  return std::regex_match(name, pattern);
}

// "TargetEvent" -> "TARGET_EVENT", "HTTPStatus" -> "HTTP_STATUS", "Vector3D" -> "VECTOR3_D".
std::string toUpperSnake(const std::string& camel) {
  const auto is_upper = [](char c) { return c >= 'A' && c <= 'Z'; };
  const auto is_lower_or_digit = [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
  };
  std::string out;
  for (std::size_t i = 0; i < camel.size(); ++i) {
    const char c = camel[i];
    if (i > 0 && is_upper(c) &&
        (is_lower_or_digit(camel[i - 1]) || (is_upper(camel[i - 1]) && i + 1 < camel.size() &&
                                             !is_upper(camel[i + 1]) && camel[i + 1] != '_'))) {
      out += '_';
    }
    out += (c >= 'a' && c <= 'z') ? static_cast<char>(c - 'a' + 'A') : c;
  }
  return out;
}

bool endsWith(const std::string& text, std::string_view suffix) {
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

class Linter {
 public:
  explicit Linter(std::vector<Finding>* findings) : findings_(*findings) {}

  void lintFile(const pb::FileDescriptor& file) {
    for (int i = 0; i < file.message_type_count(); ++i) lintMessage(*file.message_type(i));
    for (int i = 0; i < file.enum_type_count(); ++i) lintEnum(*file.enum_type(i));
    for (int i = 0; i < file.service_count(); ++i) {
      const pb::ServiceDescriptor& service = *file.service(i);
      if (!isUpperCamel(service.name())) {
        add(Rule::kServiceNameNotUpperCamel, service.full_name(), "service name not UpperCamel");
      }
      for (int j = 0; j < service.method_count(); ++j) {
        if (!isUpperCamel(service.method(j)->name())) {
          add(Rule::kServiceNameNotUpperCamel, service.method(j)->full_name(),
              "rpc name not UpperCamel");
        }
      }
    }
  }

 private:
  void add(Rule rule, std::string element, std::string detail) {
    findings_.push_back({rule, std::move(element), std::move(detail)});
  }

  void lintMessage(const pb::Descriptor& message) {
    if (message.options().map_entry()) return;  // generated by protoc for map<,> fields
    if (!isUpperCamel(message.name())) {
      add(Rule::kMessageNameNotUpperCamel, message.full_name(), "message name not UpperCamel");
    }
    for (int i = 0; i < message.field_count(); ++i) {
      if (!isLowerSnake(message.field(i)->name())) {
        add(Rule::kFieldNameNotLowerSnake, message.field(i)->full_name(),
            "field name not lower_snake_case");
      }
    }
    for (int i = 0; i < message.nested_type_count(); ++i) lintMessage(*message.nested_type(i));
    for (int i = 0; i < message.enum_type_count(); ++i) lintEnum(*message.enum_type(i));
  }

  void lintEnum(const pb::EnumDescriptor& enum_type) {
    if (!isUpperCamel(enum_type.name())) {
      add(Rule::kEnumNameNotUpperCamel, enum_type.full_name(), "enum name not UpperCamel");
    }
    const std::string prefix = toUpperSnake(enum_type.name()) + "_";
    for (int i = 0; i < enum_type.value_count(); ++i) {
      const std::string& name = enum_type.value(i)->name();
      if (!isUpperSnake(name) || name.rfind(prefix, 0) != 0) {
        add(Rule::kEnumValueNotUpperSnake, enum_type.full_name() + "." + name,
            "value not UPPER_SNAKE_CASE with prefix " + prefix);
      }
    }
    const pb::EnumValueDescriptor* zero = enum_type.FindValueByNumber(0);
    if (zero == nullptr) {
      add(Rule::kEnumZeroNotUnspecified, enum_type.full_name(),
          "no zero value; add " + prefix + "UNSPECIFIED = 0");
    } else if (!endsWith(zero->name(), "_UNSPECIFIED")) {
      add(Rule::kEnumZeroNotUnspecified, enum_type.full_name() + "." + zero->name(),
          "zero value (the default of every unset field) must be named " + prefix + "UNSPECIFIED");
    }
  }

  std::vector<Finding>& findings_;
};

}  // namespace

std::string_view ruleName(Rule rule) {
  switch (rule) {
    case Rule::kFileRemoved:
      return "FILE_REMOVED";
    case Rule::kPackageChanged:
      return "PACKAGE_CHANGED";
    case Rule::kMessageRemoved:
      return "MESSAGE_REMOVED";
    case Rule::kFieldNumberChanged:
      return "FIELD_NUMBER_CHANGED";
    case Rule::kFieldNameChanged:
      return "FIELD_NAME_CHANGED";
    case Rule::kFieldTypeChanged:
      return "FIELD_TYPE_CHANGED";
    case Rule::kFieldLabelChanged:
      return "FIELD_LABEL_CHANGED";
    case Rule::kFieldOneofChanged:
      return "FIELD_ONEOF_CHANGED";
    case Rule::kFieldRemovedWithoutReservation:
      return "FIELD_REMOVED_WITHOUT_RESERVATION";
    case Rule::kReservationRemoved:
      return "RESERVATION_REMOVED";
    case Rule::kEnumRemoved:
      return "ENUM_REMOVED";
    case Rule::kEnumValueNumberChanged:
      return "ENUM_VALUE_NUMBER_CHANGED";
    case Rule::kEnumValueNameChanged:
      return "ENUM_VALUE_NAME_CHANGED";
    case Rule::kEnumValueRemovedWithoutReservation:
      return "ENUM_VALUE_REMOVED_WITHOUT_RESERVATION";
    case Rule::kServiceRemoved:
      return "SERVICE_REMOVED";
    case Rule::kRpcRemoved:
      return "RPC_REMOVED";
    case Rule::kRpcTypeChanged:
      return "RPC_TYPE_CHANGED";
    case Rule::kRpcStreamingChanged:
      return "RPC_STREAMING_CHANGED";
    case Rule::kMessageNameNotUpperCamel:
      return "LINT_MESSAGE_NAME_UPPER_CAMEL";
    case Rule::kEnumNameNotUpperCamel:
      return "LINT_ENUM_NAME_UPPER_CAMEL";
    case Rule::kServiceNameNotUpperCamel:
      return "LINT_SERVICE_NAME_UPPER_CAMEL";
    case Rule::kFieldNameNotLowerSnake:
      return "LINT_FIELD_NAME_LOWER_SNAKE";
    case Rule::kEnumValueNotUpperSnake:
      return "LINT_ENUM_VALUE_UPPER_SNAKE";
    case Rule::kEnumZeroNotUnspecified:
      return "LINT_ENUM_ZERO_UNSPECIFIED";
  }
  return "UNKNOWN_RULE";
}

std::string formatFinding(const Finding& finding) {
  return std::string(ruleName(finding.rule)) + " " + finding.element + ": " + finding.detail;
}

std::string formatFindings(const std::vector<Finding>& findings) {
  std::string text;
  for (const Finding& finding : findings) text += formatFinding(finding) + "\n";
  return text;
}

pb::FileDescriptorSet readDescriptorSet(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open descriptor set " + path.string());
  pb::FileDescriptorSet set;
  if (!set.ParseFromIstream(&in)) {
    throw std::runtime_error(path.string() + " is not a serialized FileDescriptorSet");
  }
  return set;
}

DescriptorSetPool::DescriptorSetPool(const pb::FileDescriptorSet& set)
    : pool_(std::make_unique<pb::DescriptorPool>()) {
  std::map<std::string, const pb::FileDescriptorProto*> in_set;
  for (const pb::FileDescriptorProto& file : set.file()) in_set.emplace(file.name(), &file);

  ErrorList errors;
  std::set<std::string> in_progress;  // guards against import cycles in a malformed set
  // Builds a file after its imports; nullptr (with errors recorded) on failure.
  std::function<const pb::FileDescriptor*(const std::string&)> build =
      [&](const std::string& name) -> const pb::FileDescriptor* {
    if (const pb::FileDescriptor* built = pool_->FindFileByName(name)) return built;
    if (!in_progress.insert(name).second) {
      errors.AddError(name, name, nullptr, ErrorList::OTHER, "import cycle");
      return nullptr;
    }
    pb::FileDescriptorProto proto;
    if (const auto it = in_set.find(name); it != in_set.end()) {
      proto = *it->second;
    } else if (const pb::FileDescriptor* known =
                   pb::DescriptorPool::generated_pool()->FindFileByName(name)) {
      known->CopyTo(&proto);
    } else {
      errors.AddError(name, name, nullptr, ErrorList::IMPORT,
                      "import not in the descriptor set (use protoc --include_imports)");
      return nullptr;
    }
    for (const std::string& dependency : proto.dependency()) {
      if (build(dependency) == nullptr) return nullptr;
    }
    return pool_->BuildFileCollectingErrors(proto, &errors);
  };

  for (const pb::FileDescriptorProto& file : set.file()) {
    if (const pb::FileDescriptor* built = build(file.name())) files_.push_back(built);
  }
  if (!errors.text().empty() || files_.size() != static_cast<std::size_t>(set.file_size())) {
    throw std::runtime_error("descriptor set does not build:\n" + errors.text());
  }
}

std::vector<Finding> findBreakingChanges(const DescriptorSetPool& baseline,
                                         const DescriptorSetPool& current) {
  std::vector<Finding> findings;
  BreakingChangeChecker checker(current.pool(), &findings);
  for (const pb::FileDescriptor* file : baseline.files()) checker.checkFile(*file);
  return findings;
}

std::vector<Finding> findBreakingChanges(const pb::FileDescriptorSet& baseline,
                                         const pb::FileDescriptorSet& current) {
  return findBreakingChanges(DescriptorSetPool(baseline), DescriptorSetPool(current));
}

std::vector<Finding> findLintViolations(const DescriptorSetPool& contract) {
  std::vector<Finding> findings;
  Linter linter(&findings);
  for (const pb::FileDescriptor* file : contract.files()) linter.lintFile(*file);
  return findings;
}

std::vector<Finding> findLintViolations(const pb::FileDescriptorSet& contract) {
  return findLintViolations(DescriptorSetPool(contract));
}

}  // namespace wj::contract
