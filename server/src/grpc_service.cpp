#include "server/grpc_service.h"

#include <spdlog/spdlog.h>

#include <grpcpp/support/proto_buffer_reader.h>
#include <grpcpp/support/proto_buffer_writer.h>

#include <deque>
#include <mutex>

#include "server/request_validation.h"
#include "server/response_conversion.h"
#include "server/status_mapping.h"

namespace wj::server {

namespace v1 = wheeljump::planner::v1;

namespace {

// Printable, bounded form of a client string for the logs.
std::string printable(const std::string& s) {
  std::string out;
  for (const char c : s.substr(0, 128)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
  return out;
}

grpc::Status tooManyCalls(int limit) {
  return toGrpcStatus(ServiceError(ErrorCode::ResourceExhausted,
                                   "too many calls in progress (limits.max_inflight_calls = " +
                                       std::to_string(limit) + "); retry later"));
}

}  // namespace

Clock::time_point toCoreDeadline(std::chrono::system_clock::time_point deadline,
                                 const DeadlineConfig& config) {
  const auto now = Clock::now();
  double seconds = config.default_s;
  if (deadline != std::chrono::system_clock::time_point::max()) {
    seconds = std::chrono::duration<double>(deadline - std::chrono::system_clock::now()).count();
    seconds = std::min(seconds, config.max_s);
  }
  return now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

//==============================================================================================
// PlanJump on the raw (ByteBuffer) callback method, so that a hot hit is answered with ready
// bytes instead of a message copied and serialized per call: the request is parsed, and the
// response serialized, here.
class PlanJumpReactor final : public grpc::ServerUnaryReactor {
 public:
  PlanJumpReactor(JumpPlannerService& service, grpc::CallbackServerContext* context,
                  const grpc::ByteBuffer* request_bytes, grpc::ByteBuffer* response_bytes)
      : service_(service), arena_(arenaOptions()) {
    auto& core = service_.core_;
    core.recordRequest();
    if (!service_.admit()) {
      admitted_ = false;
      core.recordBusy();
      Finish(tooManyCalls(service_.config_.limits.max_inflight_calls));
      return;
    }
    auto* request = google::protobuf::Arena::CreateMessage<v1::PlanJumpRequest>(&arena_);
    if (!parse(*request_bytes, request)) {
      core.recordInvalid();
      Finish(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                          "the request does not parse as a wheeljump.planner.v1.PlanJumpRequest"));
      return;
    }
    PlanRequest r;
    try {
      r = toPlanRequest(*request, core.robot());
    } catch (...) {
      core.recordInvalid();
      const ServiceError e = classifyException(std::current_exception());
      spdlog::debug("PlanJump {}: {}", printable(request->request_id()), e.what());
      Finish(toGrpcStatus(e));
      return;
    }
    const std::string request_id = r.request_id;
    const TrajectoryFormat format = r.trajectory;
    const auto& robot = core.robot();
    HotSlot hot;
    if (service_.hot_.enabled()) {
      hot = findHot(r, response_bytes);
      if (hot.served) return;
    }
    auto* response = google::protobuf::Arena::CreateMessage<v1::PlanJumpResponse>(&arena_);
    call_ = std::make_shared<PlanCall>(
        toCoreDeadline(context->deadline(), service_.config_.deadlines),
        [this, response, response_bytes, request_id, format, &robot,
         hot = std::move(hot)](PlanOutcome&& o) {
          // On a core worker thread: convert, serialize and finish there.
          if (o.error) {
            spdlog::debug("PlanJump {}: {}", printable(request_id), o.error->what());
            Finish(toGrpcStatus(*o.error));
            return;
          }
          toProto(o.answer, robot, request_id, format, response);
          bool own_buffer = false;
          const grpc::Status serialized =
              grpc::SerializationTraits<v1::PlanJumpResponse>::Serialize(*response, response_bytes,
                                                                         &own_buffer);
          // A regenerated hit becomes the ready response of its bin.
          if (serialized.ok() && !hot.key.empty() && o.answer.source == PlanSource::CacheHit)
            service_.hot_.put(hot.key, hot.generation, readyBytes(*response));
          Finish(serialized);
        });
    core.plan(std::move(r), call_);
  }

  void OnCancel() override {
    if (call_) call_->cancel();
  }
  void OnDone() override {
    if (admitted_) service_.release();
    delete this;
  }

 private:
  // The hot tier's slot of a request: its key and the cache entry it would be built from.
  struct HotSlot {
    std::string key;               ///< "" when the request is not a hit
    std::uint64_t generation = 0;  ///< the cache entry's (SolutionCache::find)
    bool served = false;
  };

  // Small first block (a request, or an error answer, needs little), growing to 64 KiB blocks
  // for the dense plan: about ten blocks for a 500 Hz response.
  static google::protobuf::ArenaOptions arenaOptions() {
    google::protobuf::ArenaOptions o;
    o.start_block_size = 4 * 1024;
    o.max_block_size = 64 * 1024;
    return o;
  }

  static bool parse(const grpc::ByteBuffer& bytes, v1::PlanJumpRequest* request) {
    grpc::ByteBuffer copy(bytes);  // shares the slices; Deserialize consumes its buffer
    return grpc::SerializationTraits<v1::PlanJumpRequest>::Deserialize(&copy, request).ok();
  }

  // Answers `r` from the hot tier if its bin has ready bytes built from the entry the cache
  // holds now (Finish is called and served is set); else the slot to fill after the hit.
  HotSlot findHot(const PlanRequest& r, grpc::ByteBuffer* response_bytes) {
    const auto received = Clock::now();
    auto& core = service_.core_;
    HotSlot slot;
    const CacheKey key = core.keyOf(r);
    if (!core.findHit(r, key, &slot.generation)) return slot;
    constexpr char kFormatTag[] = {'D', 'K', 'C'};  // per TrajectoryFormat
    slot.key = key.bytes() + kFormatTag[static_cast<int>(r.trajectory)];
    const auto ready = service_.hot_.find(slot.key, slot.generation);
    if (!ready) return slot;
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - received).count();
    const std::string suffix = readySuffix(r.request_id, ms);
    grpc::Slice parts[2] = {*ready, grpc::Slice(suffix)};
    grpc::ByteBuffer answer(parts, 2);
    response_bytes->Swap(&answer);
    core.recordHotHit(ms);
    slot.served = true;
    Finish(grpc::Status::OK);
    return slot;
  }

  JumpPlannerService& service_;
  google::protobuf::Arena arena_;  ///< the call's request and response
  std::shared_ptr<PlanCall> call_;
  bool admitted_ = true;
};

//==============================================================================================
class WarmCacheReactor final : public grpc::ServerWriteReactor<v1::WarmCacheProgress> {
 public:
  WarmCacheReactor(JumpPlannerService& service, grpc::CallbackServerContext* context,
                   const v1::WarmCacheRequest* request)
      : service_(service) {
    auto& core = service_.core_;
    if (!service_.admit()) {
      admitted_ = false;
      core.recordBusy();
      Finish(tooManyCalls(service_.config_.limits.max_inflight_calls));
      return;
    }
    WarmRequest w;
    try {
      w = toWarmRequest(*request, core.robot(), core.nominalState(0.0));
    } catch (...) {
      core.recordInvalid();
      Finish(toGrpcStatus(classifyException(std::current_exception())));
      return;
    }
    call_ = std::make_shared<WarmCall>(
        toCoreDeadline(context->deadline(), service_.config_.deadlines),
        [this](const WarmProgress& p) { onProgress(p); },
        [this](std::optional<ServiceError> e) { onDone(e); });
    core.warm(std::move(w), call_);
  }

  void OnWriteDone(bool ok) override {
    std::optional<grpc::Status> finish;
    {
      std::lock_guard lock(mu_);
      queue_.pop_front();
      if (!ok) broken_ = true;  // the client is gone; the cancellation follows
      if (!broken_ && !queue_.empty()) {
        StartWrite(&queue_.front());
        return;
      }
      writing_ = false;
      finish = final_status_;
    }
    // Outside the lock: OnDone (which deletes this) may run as soon as Finish is called.
    if (finish) Finish(*finish);
  }
  void OnCancel() override {
    if (call_) call_->cancel();
  }
  void OnDone() override {
    if (admitted_) service_.release();
    delete this;
  }

 private:
  void onProgress(const WarmProgress& p) {
    std::lock_guard lock(mu_);
    if (broken_) return;
    queue_.emplace_back();
    toProto(p, &queue_.back());
    if (!writing_) {
      writing_ = true;
      StartWrite(&queue_.front());
    }
  }
  void onDone(const std::optional<ServiceError>& e) {
    const grpc::Status status = e ? toGrpcStatus(*e) : grpc::Status::OK;
    {
      std::lock_guard lock(mu_);
      if (writing_) {
        final_status_ = status;  // finished by OnWriteDone once the queue is written
        return;
      }
    }
    Finish(status);
  }

  JumpPlannerService& service_;
  std::shared_ptr<WarmCall> call_;
  bool admitted_ = true;
  std::mutex mu_;
  std::deque<v1::WarmCacheProgress> queue_;  ///< front: being written
  bool writing_ = false;
  bool broken_ = false;
  std::optional<grpc::Status> final_status_;
};

//==============================================================================================
JumpPlannerService::JumpPlannerService(PlanningCore& core, const ServerConfig& config)
    : core_(core),
      config_(config),
      hot_(static_cast<std::size_t>(config.cache.hot_responses_mb * 1024.0 * 1024.0)) {}

bool JumpPlannerService::admit() {
  if (inflight_.fetch_add(1) >= config_.limits.max_inflight_calls) {
    inflight_.fetch_sub(1);
    return false;
  }
  return true;
}

grpc::ServerUnaryReactor* JumpPlannerService::PlanJump(grpc::CallbackServerContext* context,
                                                       const grpc::ByteBuffer* request,
                                                       grpc::ByteBuffer* response) {
  return new PlanJumpReactor(*this, context, request, response);
}

grpc::ServerUnaryReactor* JumpPlannerService::GetStats(grpc::CallbackServerContext* context,
                                                       const v1::GetStatsRequest* /*request*/,
                                                       v1::GetStatsResponse* response) {
  // Reading counters is cheap and non-blocking: answered inline.
  toProto(core_.stats(), response);
  auto* reactor = context->DefaultReactor();
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

grpc::ServerWriteReactor<v1::WarmCacheProgress>* JumpPlannerService::WarmCache(
    grpc::CallbackServerContext* context, const v1::WarmCacheRequest* request) {
  return new WarmCacheReactor(*this, context, request);
}

}  // namespace wj::server
