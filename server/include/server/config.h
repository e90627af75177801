#pragma once
/// @file Configuration of planner_server, read from YAML. Every key is required and unknown keys
/// are errors (no silent fallback on a misspelling, see STYLE.md); the sample with every key and
/// its meaning is config/planner_server.yaml, the reference docs/service.md. One exception, so
/// that configurations written before the shared cache stay valid: cache.backend may be left
/// out (sqlite), and cache.redis with it; with backend redis, cache.redis and all its keys are
/// required.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace wj::server {

/// Transport security of the listening port.
enum class TlsMode {
  Insecure,   ///< plaintext; only on a loopback address unless allow_insecure_non_loopback
  Tls,        ///< server certificate; clients are not authenticated
  MutualTls,  ///< server certificate, and clients must present one signed by client_ca_file
};
/// "insecure", "tls", "mutual_tls".
std::string_view toString(TlsMode mode);

/// Where the planner's settings come from and how much work one request may ask for.
struct PlannerConfig {
  std::string settings_file;  ///< planner settings YAML; "" = the planner's built-in defaults
  int de_threads = 2;         ///< OpenMP threads of one Differential Evolution run, >= 1
  std::int64_t max_evaluations_cap = 200000;  ///< upper bound applied to budget.max_evaluations
  double polish_min_budget_s = 0.5;  ///< run the Ipopt polish only if the DE got at least this
  double polish_reserve_s = 0.1;     ///< time kept back for the polish when it runs [s]
  /// Sample period of the returned joint and CoM trajectories [s], in [1e-4, 0.002] (500 Hz or
  /// faster, the contract's bound); replaces the planner settings' sampling.output_dt_s. 0 (or
  /// the key left out) keeps the planner settings' own (1 ms by default).
  double output_dt_s = 0.0;
};

/// The worker pools. Planning never runs on gRPC's threads.
struct ExecutorConfig {
  int plan_workers = 1;    ///< concurrent plan computations (each uses de_threads), >= 1
  int plan_queue = 8;      ///< plan computations waiting; beyond it RESOURCE_EXHAUSTED
  int hit_workers = 2;     ///< threads regenerating cached plans, >= 1
  int hit_queue = 256;     ///< cache hits waiting; beyond it RESOURCE_EXHAUSTED
  int verify_workers = 2;  ///< threads running multibody verifications, >= 1
};

/// How client deadlines become planning budgets.
struct DeadlineConfig {
  double default_s = 10.0;       ///< budget of a call that has no deadline [s]
  double max_s = 120.0;          ///< longer deadlines are cut to this [s]
  double reply_margin_s = 0.02;  ///< kept back to send the answer before the deadline [s]
  double min_budget_s = 0.01;    ///< below this the call fails with DEADLINE_EXCEEDED at once [s]
};

/// Multibody verification of the best candidates.
struct VerificationConfig {
  bool enabled = true;            ///< verify plans in simulation (requires the sim component)
  std::string sim_settings_file;  ///< sim settings YAML; "" = the simulator's defaults
  /// The robot client's jump executor (config/jump_executor.yaml), which the verifier flies the
  /// plans with; "" (or the key absent) = the executor's built-in defaults.
  std::string jump_executor_file;
  int default_candidates = 2;    ///< candidates verified when the request says 0, >= 1
  int max_candidates = 8;        ///< requests asking for more are capped to this, >= 1
  double budget_fraction = 0.4;  ///< share of the remaining time reserved for verification
  /// Verify symmetric plans on the sagittal model (sim::VerificationModel, docs/sim.md): the
  /// same verdicts at about 0.7 x the work; false: always the full 3-D model.
  bool sagittal_model = true;
  double max_apex_height_error_m = 0.05;        ///< acceptance: |simulated - predicted| apex
  double max_touchdown_dx_error_m = 0.15;       ///< acceptance: touchdown x error [m]
  double max_touchdown_pitch_error_rad = 0.35;  ///< acceptance: touchdown pitch error [rad]
  /// The lift-off correction (docs/planner.md, "The lift-off correction"): a miss plans again,
  /// up to this many times, from its chosen candidate with the flight started from the lift-off
  /// the verification measured, while its time lasts; never for a backflip (its flight model is
  /// not good enough yet). In [0, 10]; 0 = off. Optional key (absent: 0).
  int liftoff_correction_rounds = 0;
};

/// The second level of the cache, behind the in-memory LRU.
enum class CacheBackend {
  Sqlite,  ///< the embedded SQLite file of cache.path (the default; "" = memory only)
  Redis,   ///< a Redis shared by several replicas (cache.redis; docs/scaling.md)
};
/// "sqlite", "redis".
std::string_view toString(CacheBackend backend);

/// The shared Redis store (cache.backend: redis). docs/scaling.md.
struct RedisConfig {
  std::string host = "127.0.0.1";  ///< host name or address of the Redis server
  int port = 6379;                 ///< TCP port, in [1, 65535]
  int db = 0;                      ///< logical database (SELECT), in [0, 15]
  std::string key_prefix = "wj";   ///< keys are "<prefix>:plan:v<schema>:<key hex>"
  int connect_timeout_ms = 200;    ///< bound on one connection attempt, in [1, 10000]
  int command_timeout_ms = 100;    ///< bound on one command's reply, in [1, 10000]
  int ttl_s = 0;                   ///< expiry of written entries [s]; 0 = none
  int reconnect_min_ms = 100;      ///< first wait after a failure before reconnecting
  int reconnect_max_ms = 5000;     ///< the wait doubles up to this
  /// Entries read into memory at start (SCAN, at most cache.max_memory_entries); 0 = none.
  std::int64_t preload_entries = 10000;
};

/// Solution cache keyed by the initial velocity (docs/service.md, "Cache").
struct CacheConfig {
  CacheBackend backend = CacheBackend::Sqlite;  ///< the second level behind the memory LRU
  std::string path;  ///< SQLite file; "" = in memory only (nothing survives a restart)
  std::int64_t max_memory_entries = 100000;      ///< LRU bound in memory, >= 1
  std::int64_t max_persisted_entries = 1000000;  ///< oldest rows beyond this are pruned
  bool synchronous_full = true;  ///< fsync every commit (survives power loss, not only crashes)
  double v0_bin_m_s = 0.05;      ///< forward speed bin
  double target_bin_m = 0.005;   ///< target dx and height bin
  double target_bin_rad = 0.01;  ///< target pitch change bin
  double obstacle_bin_m = 0.01;  ///< obstacle faces and height bin
  double pitch_bin_rad = 0.02;   ///< initial pitch bin
  double pitch_rate_bin_rad_s = 0.1;         ///< initial pitch rate bin
  double posture_bin_rad = 0.02;             ///< bin of the non-wheel joint positions
  int warm_start_neighbors = 2;              ///< cached neighbours seeding a miss, >= 0
  double warm_start_max_distance_m_s = 0.5;  ///< how far in v0 a neighbour may be [m/s]
  /// Ready responses of bins kept for hits [MB], 0 = off (every hit regenerated at its caller's
  /// state): a hit after the first of its bin is the first one's response, marked
  /// ready_response (HotResponses; docs/service.md, "Hot tier"). May be left out (= 64).
  double hot_responses_mb = 64.0;
  RedisConfig redis;  ///< used when backend is Redis
};

/// WarmCache streams.
struct WarmCacheConfig {
  int max_streams = 1;          ///< concurrent WarmCache calls; beyond it RESOURCE_EXHAUSTED
  double point_budget_s = 5.0;  ///< planning budget of one grid point [s]
};

/// Bounds that keep every request's memory and the connection count finite.
struct LimitsConfig {
  int max_receive_message_bytes = 65536;          ///< requests are a few hundred bytes
  int max_send_message_bytes = 16777216;          ///< a plan with its dense trajectory is ~0.5 MB
  int max_concurrent_streams = 64;                ///< per HTTP/2 connection
  int max_inflight_calls = 512;                   ///< calls in the server at once, all connections
  std::int64_t resource_quota_bytes = 268435456;  ///< gRPC's memory quota for its buffers
};

/// HTTP/2 keepalive; the client library's defaults match these (docs/service.md).
struct KeepaliveConfig {
  int time_ms = 20000;               ///< ping an idle connection after this long
  int timeout_ms = 10000;            ///< close it if the ping is not answered within this
  bool permit_without_calls = true;  ///< pings allowed with no call in flight
  int min_ping_interval_ms = 10000;  ///< clients pinging more often get GOAWAY
};

/// TLS material. Files are PEM.
struct TlsConfig {
  TlsMode mode = TlsMode::Insecure;
  std::string server_cert_file;              ///< certificate chain (tls, mutual_tls)
  std::string server_key_file;               ///< private key (tls, mutual_tls)
  std::string client_ca_file;                ///< CA that signs client certificates (mutual_tls)
  bool allow_insecure_non_loopback = false;  ///< plaintext on a non-loopback address
};

struct ServerConfig {
  std::string listen = "127.0.0.1:50051";  ///< host:port; port 0 picks a free one
  std::string models_dir;  ///< folder with wheeljump.urdf and actuators.yaml; "" = default
  /// Actuator file of the robot planned for, relative to the models folder (or absolute), e.g.
  /// "actuators-57nm.yaml"; optional in the YAML (older configurations: actuators.yaml).
  std::string actuators_file = "actuators.yaml";
  std::string log_level = "info";  ///< trace, debug, info, warn, error
  double shutdown_grace_s = 5.0;   ///< SIGTERM: time in-flight calls get before cancellation
  PlannerConfig planner;
  ExecutorConfig executor;
  DeadlineConfig deadlines;
  VerificationConfig verification;
  CacheConfig cache;
  WarmCacheConfig warm_cache;
  LimitsConfig limits;
  KeepaliveConfig keepalive;
  TlsConfig tls;

  /// Throws std::invalid_argument naming the key and its allowed range.
  void validate() const;
  /// Reads a file. Throws std::runtime_error naming the file and the key: unknown or missing
  /// key, wrong type, value out of range.
  static ServerConfig fromYamlFile(const std::filesystem::path& path);
  /// The same from YAML text; `origin` names the source in messages.
  static ServerConfig fromYamlString(const std::string& text, const std::string& origin);
  /// The effective configuration as YAML with every key (what fromYamlString accepts).
  std::string toYaml() const;
};

/// True if the host of `listen` ("host:port", "[v6]:port") is a loopback address.
bool isLoopbackListenAddress(std::string_view listen);

}  // namespace wj::server
