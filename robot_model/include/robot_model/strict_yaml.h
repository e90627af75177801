#pragma once
/// @file A YAML map whose keys must all be read exactly once: unknown or missing keys are
/// errors that name the key and the file. Header-only; the including target links yaml-cpp.
///
///   wj::StrictYamlMap root(YAML::Load(text), "", "robot client config.yaml");
///   settings.period_s = root.map("loop").number("period_s");   // nested: "loop.period_s"
///   root.finish();  // throws on any key that was never read

#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace wj {

/// The whole text of a settings file, or nothing when it cannot be opened (the caller's error
/// names the file's role: "sim settings: cannot open ...").
inline std::optional<std::string> readSettingsText(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

class StrictYamlMap {
 public:
  /// `path` prefixes the keys in messages ("loop."), `origin` names the document
  /// ("robot client settings config/robot_client.yaml").
  StrictYamlMap(const YAML::Node& node, std::string path, std::string origin)
      : node_(node), path_(std::move(path)), origin_(std::move(origin)) {
    if (!node_.IsMap()) fail("expected a map" + (path_.empty() ? "" : " at '" + path_ + "'"));
  }

  double number(const std::string& key) { return as<double>(key); }
  bool flag(const std::string& key) { return as<bool>(key); }
  std::string text(const std::string& key) { return as<std::string>(key); }
  std::uint64_t unsignedInt(const std::string& key) { return as<std::uint64_t>(key); }
  int integer(const std::string& key) { return as<int>(key); }
  YAML::Node node(const std::string& key) { return get(key); }
  bool has(const std::string& key) const { return static_cast<bool>(node_[key]); }
  /// The keys of this map in document order (for maps whose keys are names, not fields).
  std::vector<std::string> keys() const {
    std::vector<std::string> out;
    for (const auto& kv : node_) out.push_back(kv.first.as<std::string>());
    return out;
  }
  /// The nested map `key`; finish() it separately.
  StrictYamlMap map(const std::string& key) {
    return StrictYamlMap(get(key), path_ + key + ".", origin_);
  }
  /// One of `values`, matched by toString(value).
  template <class Enum, std::size_t N>
  Enum choice(const std::string& key, const std::array<Enum, N>& values) {
    const std::string t = text(key);
    std::string allowed;
    for (const Enum v : values) {
      if (t == toString(v)) return v;
      allowed += (allowed.empty() ? "" : ", ") + std::string(toString(v));
    }
    fail("key '" + path_ + key + "': '" + t + "' is not one of " + allowed);
  }

  /// Fails if a key of the map was never read.
  void finish() const {
    for (const auto& kv : node_) {
      const auto key = kv.first.as<std::string>();
      if (!read_.count(key)) fail("unknown key '" + path_ + key + "'");
    }
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(origin_ + ": " + what);
  }

 private:
  template <class T>
  T as(const std::string& key) {
    const YAML::Node n = get(key);
    try {
      return n.as<T>();
    } catch (const YAML::Exception&) {
      fail("key '" + path_ + key + "' has the wrong type");
    }
  }
  YAML::Node get(const std::string& key) {
    const YAML::Node n = node_[key];
    if (!n) {
      std::string present;
      for (const auto& kv : node_)
        present += (present.empty() ? "" : ", ") + kv.first.as<std::string>();
      fail("missing key '" + path_ + key + "' (keys present: " + present + ")");
    }
    read_.insert(key);
    return n;
  }

  YAML::Node node_;
  std::string path_;
  std::string origin_;
  std::set<std::string> read_;
};

}  // namespace wj
