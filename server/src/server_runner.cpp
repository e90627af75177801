#include "server/server_runner.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/resource_quota.h>
#include <grpcpp/security/server_credentials.h>
#include <spdlog/spdlog.h>

#include <fstream>
#include <sstream>

#include "server/plan_verifier.h"
#include "server/redis_store.h"
#include "server/solution_store.h"

namespace wj::server {

namespace {

std::string readPem(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("server config: " + key + ": cannot read " + path);
  std::stringstream ss;
  ss << in.rdbuf();
  if (ss.str().find("-----BEGIN") == std::string::npos)
    throw std::runtime_error("server config: " + key + ": " + path + " is not a PEM file");
  return ss.str();
}

std::shared_ptr<grpc::ServerCredentials> credentialsFor(const TlsConfig& tls) {
  if (tls.mode == TlsMode::Insecure) return grpc::InsecureServerCredentials();
  grpc::SslServerCredentialsOptions options(
      tls.mode == TlsMode::MutualTls ? GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY
                                     : GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  options.pem_key_cert_pairs.push_back({readPem(tls.server_key_file, "tls.server_key_file"),
                                        readPem(tls.server_cert_file, "tls.server_cert_file")});
  if (tls.mode == TlsMode::MutualTls)
    options.pem_root_certs = readPem(tls.client_ca_file, "tls.client_ca_file");
  return grpc::SslServerCredentials(options);
}

std::string hostOf(const std::string& listen) {
  const auto colon = listen.rfind(':');
  return colon == std::string::npos ? listen : listen.substr(0, colon);
}

}  // namespace

PlannerServer::PlannerServer(const ServerConfig& config) : config_(config) {
  config_.validate();
  if (!config_.models_dir.empty()) ::setenv("WJ_MODELS_DIR", config_.models_dir.c_str(), 1);
  model::RobotModel robot = model::RobotModel::loadDefault(config_.actuators_file);
  planner::PlannerSettings settings =
      config_.planner.settings_file.empty()
          ? planner::PlannerSettings{}
          : planner::PlannerSettings::fromYaml(config_.planner.settings_file);
  if (config_.planner.output_dt_s > 0.0) {
    settings.output_dt_s = config_.planner.output_dt_s;
    settings.validate();
  }
  std::unique_ptr<PlanVerifier> verifier;
  if (config_.verification.enabled) {
    verifier = makeSimVerifier(robot, config_.verification);
    if (!verifier)
      spdlog::warn(
          "verification.enabled is true but this build has no verifier (sim component not "
          "built): every plan is answered with verification NOT_RUN");
  }
  std::unique_ptr<SecondLevelStore> store;
  if (config_.cache.backend == CacheBackend::Redis) {
    store = std::make_unique<RedisStore>(config_.cache.redis);
  } else if (!config_.cache.path.empty()) {
    store = std::make_unique<SolutionStore>(config_.cache.path, config_.cache.synchronous_full,
                                            config_.cache.max_persisted_entries);
  }
  core_ = std::make_unique<PlanningCore>(config_, std::move(robot), std::move(settings),
                                         std::move(verifier), std::move(store));
  service_ = std::make_unique<JumpPlannerService>(*core_, config_);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  builder.AddListeningPort(config_.listen, credentialsFor(config_.tls), &port_);
  builder.RegisterService(service_.get());
  builder.SetMaxReceiveMessageSize(config_.limits.max_receive_message_bytes);
  builder.SetMaxSendMessageSize(config_.limits.max_send_message_bytes);
  builder.AddChannelArgument(GRPC_ARG_MAX_CONCURRENT_STREAMS,
                             config_.limits.max_concurrent_streams);
  builder.AddChannelArgument(GRPC_ARG_MAX_METADATA_SIZE, 16 * 1024);
  // Keepalive (docs/service.md): the server pings idle connections, and tolerates client pings
  // no more often than min_ping_interval_ms (the client library pings every time_ms).
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, config_.keepalive.time_ms);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, config_.keepalive.timeout_ms);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS,
                             config_.keepalive.permit_without_calls ? 1 : 0);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS,
                             config_.keepalive.min_ping_interval_ms);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PING_STRIKES, 2);
  grpc::ResourceQuota quota("planner_server");
  quota.Resize(static_cast<std::size_t>(config_.limits.resource_quota_bytes));
  builder.SetResourceQuota(quota);
  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0) {
    core_->shutdown();
    throw std::runtime_error("cannot listen on " + config_.listen +
                             " (address in use, or bad TLS material?)");
  }
  if (auto* health = server_->GetHealthCheckService()) health->SetServingStatus(true);
}

PlannerServer::~PlannerServer() {
  shutdown();
}

std::string PlannerServer::address() const {
  return hostOf(config_.listen) + ":" + std::to_string(port_);
}

std::string PlannerServer::describe() const {
  std::ostringstream ss;
  ss << "verifier: " << (core_->verifier() ? core_->verifier()->name() : "none (NOT_RUN)")
     << "; cache: "
     << (config_.cache.backend == CacheBackend::Redis
             ? "redis " + config_.cache.redis.host + ":" + std::to_string(config_.cache.redis.port)
         : config_.cache.path.empty() ? std::string("memory only")
                                      : config_.cache.path)
     << " (" << core_->stats().cache_entries
     << " entries loaded); tls: " << toString(config_.tls.mode);
  return ss.str();
}

void PlannerServer::shutdown() {
  if (stopped_) return;
  stopped_ = true;
  if (auto* health = server_->GetHealthCheckService()) health->SetServingStatus(false);
  const auto grace = std::chrono::system_clock::now() +
                     std::chrono::duration_cast<std::chrono::system_clock::duration>(
                         std::chrono::duration<double>(config_.shutdown_grace_s));
  // Refuses new calls, waits for the calls in flight until `grace`, then cancels them (our
  // reactors finish on cancellation), and returns once every reactor is done.
  server_->Shutdown(grace);
  core_->shutdown();
  server_->Wait();
}

}  // namespace wj::server
