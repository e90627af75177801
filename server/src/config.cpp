#include "server/config.h"

#include <yaml-cpp/yaml.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace wj::server {

std::string_view toString(TlsMode mode) {
  switch (mode) {
    case TlsMode::Insecure:
      return "insecure";
    case TlsMode::Tls:
      return "tls";
    case TlsMode::MutualTls:
      return "mutual_tls";
  }
  return "?";
}

std::string_view toString(CacheBackend backend) {
  switch (backend) {
    case CacheBackend::Sqlite:
      return "sqlite";
    case CacheBackend::Redis:
      return "redis";
  }
  return "?";
}

namespace {

// A strict reader of one YAML map: every key must be read exactly once (missing keys are
// errors) and finish() refuses keys nobody asked for (unknown keys are errors).
class MapReader {
 public:
  MapReader(const YAML::Node& node, std::string path, const std::string& origin)
      : node_(node), path_(std::move(path)), origin_(origin) {
    if (!node_.IsMap())
      fail(path_.empty() ? "the document must be a map" : "'" + path_ + "' must be a map");
  }

  template <typename T>
  void read(const std::string& key, T& target) {
    const YAML::Node value = child(key);
    try {
      if constexpr (std::is_same_v<T, bool>) {
        target = value.as<bool>();
      } else if constexpr (std::is_same_v<T, std::string>) {
        if (!value.IsScalar()) throw YAML::Exception(value.Mark(), "expected a string");
        target = value.as<std::string>();
      } else {
        target = value.as<T>();
      }
    } catch (const YAML::Exception& e) {
      fail("bad value for '" + name(key) + "': " + e.msg);
    }
  }

  void readTlsMode(const std::string& key, TlsMode& target) {
    std::string text;
    read(key, text);
    for (const TlsMode m : {TlsMode::Insecure, TlsMode::Tls, TlsMode::MutualTls}) {
      if (text == toString(m)) {
        target = m;
        return;
      }
    }
    fail("bad value for '" + name(key) + "': '" + text +
         "' is not one of insecure, tls, mutual_tls");
  }

  void readCacheBackend(const std::string& key, CacheBackend& target) {
    std::string text;
    read(key, text);
    for (const CacheBackend b : {CacheBackend::Sqlite, CacheBackend::Redis}) {
      if (text == toString(b)) {
        target = b;
        return;
      }
    }
    fail("bad value for '" + name(key) + "': '" + text + "' is not one of sqlite, redis");
  }

  /// Whether `key` is present (for the few optional keys; it still counts as known).
  bool has(const std::string& key) {
    seen_.insert(key);
    const YAML::Node value = node_[key];
    return value.IsDefined() && !value.IsNull();
  }

  void section(const std::string& key, const std::function<void(MapReader&)>& body) {
    MapReader sub(child(key), name(key), origin_);
    body(sub);
    sub.finish();
  }

  void finish() const {
    for (const auto& kv : node_) {
      const auto key = kv.first.as<std::string>();
      if (!seen_.count(key)) {
        std::string allowed;
        for (const auto& k : seen_) allowed += (allowed.empty() ? "" : ", ") + k;
        fail("unknown key '" + name(key) + "' (allowed: " + allowed + ")");
      }
    }
  }

 private:
  YAML::Node child(const std::string& key) {
    seen_.insert(key);
    const YAML::Node value = node_[key];
    if (!value.IsDefined() || value.IsNull()) fail("missing key '" + name(key) + "'");
    return value;
  }
  std::string name(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("server config " + origin_ + ": " + what);
  }

  YAML::Node node_;
  std::string path_;
  const std::string& origin_;
  std::set<std::string> seen_;
};

void require(bool ok, const std::string& key, const std::string& range, double value) {
  if (!ok || !std::isfinite(value)) {
    std::ostringstream ss;
    ss << "server config: " << key << " must be " << range << ", got " << value;
    throw std::invalid_argument(ss.str());
  }
}

std::string formatDouble(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, r.ptr);
  // Keep it a float in YAML's eyes (1 -> 1.0) so that a reader sees the type.
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string quote(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

void ServerConfig::validate() const {
  require(!listen.empty() && listen.find(':') != std::string::npos, "listen",
          "host:port (e.g. 127.0.0.1:50051)", 0.0);
  require(log_level == "trace" || log_level == "debug" || log_level == "info" ||
              log_level == "warn" || log_level == "error",
          "log_level", "one of trace, debug, info, warn, error", 0.0);
  require(!actuators_file.empty() && actuators_file.find('\n') == std::string::npos,
          "actuators_file", "a file name in the models folder (e.g. actuators.yaml)", 0.0);
  require(shutdown_grace_s >= 0 && shutdown_grace_s <= 600, "shutdown_grace_s", "in [0, 600] s",
          shutdown_grace_s);
  require(planner.de_threads >= 1 && planner.de_threads <= 64, "planner.de_threads", "in [1, 64]",
          planner.de_threads);
  require(planner.max_evaluations_cap >= 100 && planner.max_evaluations_cap <= 10'000'000,
          "planner.max_evaluations_cap", "in [100, 10^7]",
          static_cast<double>(planner.max_evaluations_cap));
  require(planner.polish_min_budget_s >= 0, "planner.polish_min_budget_s", ">= 0",
          planner.polish_min_budget_s);
  require(planner.polish_reserve_s >= 0, "planner.polish_reserve_s", ">= 0",
          planner.polish_reserve_s);
  require(
      planner.output_dt_s == 0.0 || (planner.output_dt_s >= 1e-4 && planner.output_dt_s <= 0.002),
      "planner.output_dt_s", "0 (the planner settings' own) or in [1e-4, 0.002] s",
      planner.output_dt_s);
  require(executor.plan_workers >= 1 && executor.plan_workers <= 64, "executor.plan_workers",
          "in [1, 64]", executor.plan_workers);
  require(executor.plan_queue >= 0 && executor.plan_queue <= 100000, "executor.plan_queue",
          "in [0, 100000]", executor.plan_queue);
  require(executor.hit_workers >= 1 && executor.hit_workers <= 64, "executor.hit_workers",
          "in [1, 64]", executor.hit_workers);
  require(executor.hit_queue >= 0 && executor.hit_queue <= 100000, "executor.hit_queue",
          "in [0, 100000]", executor.hit_queue);
  require(executor.verify_workers >= 1 && executor.verify_workers <= 64, "executor.verify_workers",
          "in [1, 64]", executor.verify_workers);
  require(deadlines.default_s > 0 && deadlines.default_s <= deadlines.max_s, "deadlines.default_s",
          "in (0, deadlines.max_s]", deadlines.default_s);
  require(deadlines.max_s > 0 && deadlines.max_s <= 3600, "deadlines.max_s", "in (0, 3600] s",
          deadlines.max_s);
  require(deadlines.reply_margin_s >= 0 && deadlines.reply_margin_s < 1, "deadlines.reply_margin_s",
          "in [0, 1) s", deadlines.reply_margin_s);
  require(deadlines.min_budget_s >= 0 && deadlines.min_budget_s < deadlines.default_s,
          "deadlines.min_budget_s", "in [0, deadlines.default_s)", deadlines.min_budget_s);
  require(verification.default_candidates >= 1 &&
              verification.default_candidates <= verification.max_candidates,
          "verification.default_candidates", "in [1, verification.max_candidates]",
          verification.default_candidates);
  require(verification.max_candidates >= 1 && verification.max_candidates <= 64,
          "verification.max_candidates", "in [1, 64]", verification.max_candidates);
  require(verification.budget_fraction > 0 && verification.budget_fraction < 1,
          "verification.budget_fraction", "in (0, 1)", verification.budget_fraction);
  require(verification.max_apex_height_error_m > 0, "verification.max_apex_height_error_m", "> 0",
          verification.max_apex_height_error_m);
  require(verification.max_touchdown_dx_error_m > 0, "verification.max_touchdown_dx_error_m", "> 0",
          verification.max_touchdown_dx_error_m);
  require(verification.max_touchdown_pitch_error_rad > 0,
          "verification.max_touchdown_pitch_error_rad", "> 0",
          verification.max_touchdown_pitch_error_rad);
  require(
      verification.liftoff_correction_rounds >= 0 && verification.liftoff_correction_rounds <= 10,
      "verification.liftoff_correction_rounds", "in [0, 10]",
      verification.liftoff_correction_rounds);
  require(cache.max_memory_entries >= 1 && cache.max_memory_entries <= 10'000'000,
          "cache.max_memory_entries", "in [1, 10^7]",
          static_cast<double>(cache.max_memory_entries));
  require(cache.max_persisted_entries >= cache.max_memory_entries &&
              cache.max_persisted_entries <= 100'000'000,
          "cache.max_persisted_entries", "in [cache.max_memory_entries, 10^8]",
          static_cast<double>(cache.max_persisted_entries));
  for (const auto& [value, key] : {std::pair{cache.v0_bin_m_s, "cache.v0_bin_m_s"},
                                   {cache.target_bin_m, "cache.target_bin_m"},
                                   {cache.target_bin_rad, "cache.target_bin_rad"},
                                   {cache.obstacle_bin_m, "cache.obstacle_bin_m"},
                                   {cache.pitch_bin_rad, "cache.pitch_bin_rad"},
                                   {cache.pitch_rate_bin_rad_s, "cache.pitch_rate_bin_rad_s"},
                                   {cache.posture_bin_rad, "cache.posture_bin_rad"}})
    require(value >= 1e-4 && value <= 1.0, key, "in [1e-4, 1]", value);
  require(cache.warm_start_neighbors >= 0 && cache.warm_start_neighbors <= 16,
          "cache.warm_start_neighbors", "in [0, 16]", cache.warm_start_neighbors);
  require(cache.warm_start_max_distance_m_s >= 0 && cache.warm_start_max_distance_m_s <= 5,
          "cache.warm_start_max_distance_m_s", "in [0, 5] m/s", cache.warm_start_max_distance_m_s);
  require(cache.hot_responses_mb >= 0 && cache.hot_responses_mb <= 4096, "cache.hot_responses_mb",
          "in [0, 4096] MB (0 = off)", cache.hot_responses_mb);
  if (cache.backend == CacheBackend::Redis) {
    const auto& r = cache.redis;
    require(cache.path.empty(), "cache.path",
            "\"\" with cache.backend redis (Redis replaces SQLite)", 0.0);
    require(!r.host.empty(), "cache.redis.host", "a host name or address", 0.0);
  }
  {
    const auto& r = cache.redis;
    require(r.port >= 1 && r.port <= 65535, "cache.redis.port", "in [1, 65535]", r.port);
    require(r.db >= 0 && r.db <= 15, "cache.redis.db", "in [0, 15]", r.db);
    require(!r.key_prefix.empty() && r.key_prefix.size() <= 64 &&
                r.key_prefix.find_first_of(" \t\r\n") == std::string::npos,
            "cache.redis.key_prefix", "1 to 64 characters without white space",
            static_cast<double>(r.key_prefix.size()));
    require(r.connect_timeout_ms >= 1 && r.connect_timeout_ms <= 10000,
            "cache.redis.connect_timeout_ms", "in [1, 10000] ms", r.connect_timeout_ms);
    require(r.command_timeout_ms >= 1 && r.command_timeout_ms <= 10000,
            "cache.redis.command_timeout_ms", "in [1, 10000] ms", r.command_timeout_ms);
    require(r.ttl_s >= 0 && r.ttl_s <= 365 * 24 * 3600, "cache.redis.ttl_s",
            "in [0, 31536000] s (0 = no expiry)", r.ttl_s);
    require(r.reconnect_min_ms >= 1 && r.reconnect_min_ms <= 60000, "cache.redis.reconnect_min_ms",
            "in [1, 60000] ms", r.reconnect_min_ms);
    require(r.reconnect_max_ms >= r.reconnect_min_ms && r.reconnect_max_ms <= 600000,
            "cache.redis.reconnect_max_ms", "in [cache.redis.reconnect_min_ms, 600000] ms",
            r.reconnect_max_ms);
    require(r.preload_entries >= 0 && r.preload_entries <= 10'000'000,
            "cache.redis.preload_entries", "in [0, 10^7]", static_cast<double>(r.preload_entries));
  }
  require(warm_cache.max_streams >= 0 && warm_cache.max_streams <= 16, "warm_cache.max_streams",
          "in [0, 16]", warm_cache.max_streams);
  require(warm_cache.point_budget_s > 0 && warm_cache.point_budget_s <= 600,
          "warm_cache.point_budget_s", "in (0, 600] s", warm_cache.point_budget_s);
  require(limits.max_receive_message_bytes >= 1024 &&
              limits.max_receive_message_bytes <= 4 * 1024 * 1024,
          "limits.max_receive_message_bytes", "in [1024, 4 MiB]", limits.max_receive_message_bytes);
  require(
      limits.max_send_message_bytes >= 65536 && limits.max_send_message_bytes <= 256 * 1024 * 1024,
      "limits.max_send_message_bytes", "in [64 KiB, 256 MiB]", limits.max_send_message_bytes);
  require(limits.max_concurrent_streams >= 1 && limits.max_concurrent_streams <= 10000,
          "limits.max_concurrent_streams", "in [1, 10000]", limits.max_concurrent_streams);
  require(limits.max_inflight_calls >= 1 && limits.max_inflight_calls <= 100000,
          "limits.max_inflight_calls", "in [1, 100000]", limits.max_inflight_calls);
  require(limits.resource_quota_bytes >= (1 << 20), "limits.resource_quota_bytes", ">= 1 MiB",
          static_cast<double>(limits.resource_quota_bytes));
  require(keepalive.time_ms >= 1000, "keepalive.time_ms", ">= 1000", keepalive.time_ms);
  require(keepalive.timeout_ms >= 100, "keepalive.timeout_ms", ">= 100", keepalive.timeout_ms);
  require(
      keepalive.min_ping_interval_ms >= 0 && keepalive.min_ping_interval_ms <= keepalive.time_ms,
      "keepalive.min_ping_interval_ms", "in [0, keepalive.time_ms]",
      keepalive.min_ping_interval_ms);
  if (tls.mode != TlsMode::Insecure) {
    require(!tls.server_cert_file.empty(), "tls.server_cert_file", "a PEM file for tls modes", 0);
    require(!tls.server_key_file.empty(), "tls.server_key_file", "a PEM file for tls modes", 0);
  }
  if (tls.mode == TlsMode::MutualTls)
    require(!tls.client_ca_file.empty(), "tls.client_ca_file", "a PEM file for mutual_tls", 0);
  if (tls.mode == TlsMode::Insecure && !tls.allow_insecure_non_loopback &&
      !isLoopbackListenAddress(listen))
    throw std::invalid_argument(
        "server config: listen '" + listen +
        "' is not a loopback address: plaintext is refused there; configure tls.mode tls or "
        "mutual_tls, or set tls.allow_insecure_non_loopback: true");
}

ServerConfig ServerConfig::fromYamlString(const std::string& text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("server config " + origin + ": cannot parse YAML: " + e.what());
  }
  ServerConfig c;
  MapReader top(root, "", origin);
  top.read("listen", c.listen);
  top.read("models_dir", c.models_dir);
  // Optional, so that configurations written before it stay valid.
  if (top.has("actuators_file")) top.read("actuators_file", c.actuators_file);
  top.read("log_level", c.log_level);
  top.read("shutdown_grace_s", c.shutdown_grace_s);
  top.section("planner", [&](MapReader& r) {
    r.read("settings_file", c.planner.settings_file);
    r.read("de_threads", c.planner.de_threads);
    r.read("max_evaluations_cap", c.planner.max_evaluations_cap);
    r.read("polish_min_budget_s", c.planner.polish_min_budget_s);
    r.read("polish_reserve_s", c.planner.polish_reserve_s);
    // Optional, so that configurations written before it stay valid (0: the planner's own).
    if (r.has("output_dt_s")) r.read("output_dt_s", c.planner.output_dt_s);
  });
  top.section("executor", [&](MapReader& r) {
    r.read("plan_workers", c.executor.plan_workers);
    r.read("plan_queue", c.executor.plan_queue);
    r.read("hit_workers", c.executor.hit_workers);
    r.read("hit_queue", c.executor.hit_queue);
    r.read("verify_workers", c.executor.verify_workers);
  });
  top.section("deadlines", [&](MapReader& r) {
    r.read("default_s", c.deadlines.default_s);
    r.read("max_s", c.deadlines.max_s);
    r.read("reply_margin_s", c.deadlines.reply_margin_s);
    r.read("min_budget_s", c.deadlines.min_budget_s);
  });
  top.section("verification", [&](MapReader& r) {
    auto& v = c.verification;
    r.read("enabled", v.enabled);
    r.read("sim_settings_file", v.sim_settings_file);
    // Optional, so that the configurations written before it stay valid (absent: "").
    if (r.has("jump_executor_file")) r.read("jump_executor_file", v.jump_executor_file);
    r.read("default_candidates", v.default_candidates);
    r.read("max_candidates", v.max_candidates);
    r.read("budget_fraction", v.budget_fraction);
    r.read("sagittal_model", v.sagittal_model);
    r.read("max_apex_height_error_m", v.max_apex_height_error_m);
    r.read("max_touchdown_dx_error_m", v.max_touchdown_dx_error_m);
    r.read("max_touchdown_pitch_error_rad", v.max_touchdown_pitch_error_rad);
    if (r.has("liftoff_correction_rounds"))
      r.read("liftoff_correction_rounds", v.liftoff_correction_rounds);
  });
  top.section("cache", [&](MapReader& r) {
    auto& k = c.cache;
    // The backend is opt-in: without the key the cache is SQLite (or memory only), so that the
    // configurations written before the shared cache stay valid. The redis section is required
    // with backend redis, and read strictly (every key) whenever it is present.
    if (r.has("backend")) r.readCacheBackend("backend", k.backend);
    r.read("path", k.path);
    r.read("max_memory_entries", k.max_memory_entries);
    r.read("max_persisted_entries", k.max_persisted_entries);
    r.read("synchronous_full", k.synchronous_full);
    r.read("v0_bin_m_s", k.v0_bin_m_s);
    r.read("target_bin_m", k.target_bin_m);
    r.read("target_bin_rad", k.target_bin_rad);
    r.read("obstacle_bin_m", k.obstacle_bin_m);
    r.read("pitch_bin_rad", k.pitch_bin_rad);
    r.read("pitch_rate_bin_rad_s", k.pitch_rate_bin_rad_s);
    r.read("posture_bin_rad", k.posture_bin_rad);
    r.read("warm_start_neighbors", k.warm_start_neighbors);
    r.read("warm_start_max_distance_m_s", k.warm_start_max_distance_m_s);
    // May be left out (configurations written before it): the built-in default, on (64 MB).
    if (r.has("hot_responses_mb")) r.read("hot_responses_mb", k.hot_responses_mb);
    if (k.backend == CacheBackend::Redis && !r.has("redis"))
      throw std::runtime_error("server config " + origin +
                               ": missing key 'cache.redis' (required with cache.backend redis)");
    if (r.has("redis"))
      r.section("redis", [&](MapReader& rr) {
        auto& x = k.redis;
        rr.read("host", x.host);
        rr.read("port", x.port);
        rr.read("db", x.db);
        rr.read("key_prefix", x.key_prefix);
        rr.read("connect_timeout_ms", x.connect_timeout_ms);
        rr.read("command_timeout_ms", x.command_timeout_ms);
        rr.read("ttl_s", x.ttl_s);
        rr.read("reconnect_min_ms", x.reconnect_min_ms);
        rr.read("reconnect_max_ms", x.reconnect_max_ms);
        rr.read("preload_entries", x.preload_entries);
      });
  });
  top.section("warm_cache", [&](MapReader& r) {
    r.read("max_streams", c.warm_cache.max_streams);
    r.read("point_budget_s", c.warm_cache.point_budget_s);
  });
  top.section("limits", [&](MapReader& r) {
    r.read("max_receive_message_bytes", c.limits.max_receive_message_bytes);
    r.read("max_send_message_bytes", c.limits.max_send_message_bytes);
    r.read("max_concurrent_streams", c.limits.max_concurrent_streams);
    r.read("max_inflight_calls", c.limits.max_inflight_calls);
    r.read("resource_quota_bytes", c.limits.resource_quota_bytes);
  });
  top.section("keepalive", [&](MapReader& r) {
    r.read("time_ms", c.keepalive.time_ms);
    r.read("timeout_ms", c.keepalive.timeout_ms);
    r.read("permit_without_calls", c.keepalive.permit_without_calls);
    r.read("min_ping_interval_ms", c.keepalive.min_ping_interval_ms);
  });
  top.section("tls", [&](MapReader& r) {
    r.readTlsMode("mode", c.tls.mode);
    r.read("server_cert_file", c.tls.server_cert_file);
    r.read("server_key_file", c.tls.server_key_file);
    r.read("client_ca_file", c.tls.client_ca_file);
    r.read("allow_insecure_non_loopback", c.tls.allow_insecure_non_loopback);
  });
  top.finish();
  try {
    c.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(std::string(e.what()) + " (in " + origin + ")");
  }
  return c;
}

ServerConfig ServerConfig::fromYamlFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("server config: cannot open " + path.string());
  std::stringstream ss;
  ss << in.rdbuf();
  ServerConfig c = fromYamlString(ss.str(), path.string());
  // A relative settings file is beside the configuration (a profile's folder), not in the
  // working directory of whoever starts the service.
  for (std::string* file : {&c.planner.settings_file, &c.verification.sim_settings_file,
                            &c.verification.jump_executor_file})
    if (!file->empty() && std::filesystem::path(*file).is_relative())
      *file = (path.parent_path() / *file).lexically_normal().string();
  return c;
}

std::string ServerConfig::toYaml() const {
  std::ostringstream o;
  const auto num = [](double v) { return formatDouble(v); };
  const auto flag = [](bool v) { return v ? "true" : "false"; };
  o << "listen: " << quote(listen) << "\n";
  o << "models_dir: " << quote(models_dir) << "\n";
  o << "actuators_file: " << quote(actuators_file) << "\n";
  o << "log_level: " << log_level << "\n";
  o << "shutdown_grace_s: " << num(shutdown_grace_s) << "\n";
  o << "planner:\n"
    << "  settings_file: " << quote(planner.settings_file) << "\n"
    << "  de_threads: " << planner.de_threads << "\n"
    << "  max_evaluations_cap: " << planner.max_evaluations_cap << "\n"
    << "  polish_min_budget_s: " << num(planner.polish_min_budget_s) << "\n"
    << "  polish_reserve_s: " << num(planner.polish_reserve_s) << "\n"
    << "  output_dt_s: " << num(planner.output_dt_s) << "\n";
  o << "executor:\n"
    << "  plan_workers: " << executor.plan_workers << "\n"
    << "  plan_queue: " << executor.plan_queue << "\n"
    << "  hit_workers: " << executor.hit_workers << "\n"
    << "  hit_queue: " << executor.hit_queue << "\n"
    << "  verify_workers: " << executor.verify_workers << "\n";
  o << "deadlines:\n"
    << "  default_s: " << num(deadlines.default_s) << "\n"
    << "  max_s: " << num(deadlines.max_s) << "\n"
    << "  reply_margin_s: " << num(deadlines.reply_margin_s) << "\n"
    << "  min_budget_s: " << num(deadlines.min_budget_s) << "\n";
  o << "verification:\n"
    << "  enabled: " << flag(verification.enabled) << "\n"
    << "  sim_settings_file: " << quote(verification.sim_settings_file) << "\n"
    << "  jump_executor_file: " << quote(verification.jump_executor_file) << "\n"
    << "  default_candidates: " << verification.default_candidates << "\n"
    << "  max_candidates: " << verification.max_candidates << "\n"
    << "  budget_fraction: " << num(verification.budget_fraction) << "\n"
    << "  sagittal_model: " << flag(verification.sagittal_model) << "\n"
    << "  max_apex_height_error_m: " << num(verification.max_apex_height_error_m) << "\n"
    << "  max_touchdown_dx_error_m: " << num(verification.max_touchdown_dx_error_m) << "\n"
    << "  max_touchdown_pitch_error_rad: " << num(verification.max_touchdown_pitch_error_rad)
    << "\n"
    << "  liftoff_correction_rounds: " << verification.liftoff_correction_rounds << "\n";
  o << "cache:\n"
    << "  backend: " << toString(cache.backend) << "\n"
    << "  path: " << quote(cache.path) << "\n"
    << "  max_memory_entries: " << cache.max_memory_entries << "\n"
    << "  max_persisted_entries: " << cache.max_persisted_entries << "\n"
    << "  synchronous_full: " << flag(cache.synchronous_full) << "\n"
    << "  v0_bin_m_s: " << num(cache.v0_bin_m_s) << "\n"
    << "  target_bin_m: " << num(cache.target_bin_m) << "\n"
    << "  target_bin_rad: " << num(cache.target_bin_rad) << "\n"
    << "  obstacle_bin_m: " << num(cache.obstacle_bin_m) << "\n"
    << "  pitch_bin_rad: " << num(cache.pitch_bin_rad) << "\n"
    << "  pitch_rate_bin_rad_s: " << num(cache.pitch_rate_bin_rad_s) << "\n"
    << "  posture_bin_rad: " << num(cache.posture_bin_rad) << "\n"
    << "  warm_start_neighbors: " << cache.warm_start_neighbors << "\n"
    << "  warm_start_max_distance_m_s: " << num(cache.warm_start_max_distance_m_s) << "\n"
    << "  hot_responses_mb: " << num(cache.hot_responses_mb) << "\n"
    << "  redis:\n"
    << "    host: " << quote(cache.redis.host) << "\n"
    << "    port: " << cache.redis.port << "\n"
    << "    db: " << cache.redis.db << "\n"
    << "    key_prefix: " << quote(cache.redis.key_prefix) << "\n"
    << "    connect_timeout_ms: " << cache.redis.connect_timeout_ms << "\n"
    << "    command_timeout_ms: " << cache.redis.command_timeout_ms << "\n"
    << "    ttl_s: " << cache.redis.ttl_s << "\n"
    << "    reconnect_min_ms: " << cache.redis.reconnect_min_ms << "\n"
    << "    reconnect_max_ms: " << cache.redis.reconnect_max_ms << "\n"
    << "    preload_entries: " << cache.redis.preload_entries << "\n";
  o << "warm_cache:\n"
    << "  max_streams: " << warm_cache.max_streams << "\n"
    << "  point_budget_s: " << num(warm_cache.point_budget_s) << "\n";
  o << "limits:\n"
    << "  max_receive_message_bytes: " << limits.max_receive_message_bytes << "\n"
    << "  max_send_message_bytes: " << limits.max_send_message_bytes << "\n"
    << "  max_concurrent_streams: " << limits.max_concurrent_streams << "\n"
    << "  max_inflight_calls: " << limits.max_inflight_calls << "\n"
    << "  resource_quota_bytes: " << limits.resource_quota_bytes << "\n";
  o << "keepalive:\n"
    << "  time_ms: " << keepalive.time_ms << "\n"
    << "  timeout_ms: " << keepalive.timeout_ms << "\n"
    << "  permit_without_calls: " << flag(keepalive.permit_without_calls) << "\n"
    << "  min_ping_interval_ms: " << keepalive.min_ping_interval_ms << "\n";
  o << "tls:\n"
    << "  mode: " << toString(tls.mode) << "\n"
    << "  server_cert_file: " << quote(tls.server_cert_file) << "\n"
    << "  server_key_file: " << quote(tls.server_key_file) << "\n"
    << "  client_ca_file: " << quote(tls.client_ca_file) << "\n"
    << "  allow_insecure_non_loopback: " << flag(tls.allow_insecure_non_loopback) << "\n";
  return o.str();
}

bool isLoopbackListenAddress(std::string_view listen) {
  std::string_view host = listen;
  if (!host.empty() && host.front() == '[') {
    const auto close = host.find(']');
    if (close == std::string_view::npos) return false;
    host = host.substr(1, close - 1);
  } else {
    const auto colon = host.rfind(':');
    if (colon != std::string_view::npos) host = host.substr(0, colon);
  }
  if (host == "localhost" || host == "::1") return true;
  // 127.0.0.0/8: four decimal octets with the first one 127.
  if (host.substr(0, 4) != "127.") return false;
  int dots = 0;
  for (const char ch : host) {
    if (ch == '.') {
      ++dots;
    } else if (ch < '0' || ch > '9') {
      return false;
    }
  }
  return dots == 3;
}

}  // namespace wj::server
