#include "server/grpc_service.h"

#include <spdlog/spdlog.h>

#include <grpcpp/support/proto_buffer_reader.h>
#include <grpcpp/support/proto_buffer_writer.h>

#include <cstddef>
#include <deque>
#include <mutex>

#include "server/request_validation.h"
#include "server/response_conversion.h"
#include "server/stack_arena.h"
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
// bytes instead of a message copied and serialized per call. The service's handler
// (JumpPlannerService::PlanJump) parses and validates the request and answers what it can at
// once (errors, hot hits) with gRPC's default reactor; this reactor is for the calls that go to
// the core (misses and regenerated hits): it converts and serializes their answer on the core's
// worker thread.
class PlanJumpReactor final : public grpc::ServerUnaryReactor {
 public:
  // `admitted`: the call holds one of limits.max_inflight_calls (released in OnDone).
  PlanJumpReactor(JumpPlannerService& service, grpc::CallbackServerContext* context,
                  PlanRequest&& r, JumpPlannerService::HotSlot&& hot,
                  grpc::ByteBuffer* response_bytes)
      : service_(service), arena_(arenaOptions()) {
    auto& core = service_.core_;
    const std::string request_id = r.request_id;
    const TrajectoryFormat format = r.trajectory;
    const auto& robot = core.robot();
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
    service_.release();
    delete this;
  }

 private:
  // Small first block (an error answer needs little), growing to 64 KiB blocks for the dense
  // plan: about ten blocks for a 500 Hz response.
  static google::protobuf::ArenaOptions arenaOptions() {
    google::protobuf::ArenaOptions o;
    o.start_block_size = 4 * 1024;
    o.max_block_size = 64 * 1024;
    return o;
  }

  JumpPlannerService& service_;
  google::protobuf::Arena arena_;  ///< the call's response
  std::shared_ptr<PlanCall> call_;
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
                                                       const grpc::ByteBuffer* request_bytes,
                                                       grpc::ByteBuffer* response_bytes) {
  // What is answered here, at once, finishes on gRPC's default reactor, whose completion gRPC
  // runs inline; a reactor of our own would have its OnDone handed to gRPC's executor thread,
  // a thread wake-up per call (docs/service.md, "Where a hot hit's CPU goes").
  const auto answer_now = [context](const grpc::Status& status) {
    grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
    reactor->Finish(status);
    return reactor;
  };
  core_.recordRequest();
  if (!admit()) {
    core_.recordBusy();
    return answer_now(tooManyCalls(config_.limits.max_inflight_calls));
  }
  // The request is parsed on an arena whose first block is on this stack: no heap allocation
  // for a request of ordinary size (a few hundred bytes on the wire).
  StackArena<8192> arena;
  auto* request = google::protobuf::Arena::CreateMessage<v1::PlanJumpRequest>(arena.get());
  {
    grpc::ByteBuffer copy(*request_bytes);  // shares the slices; Deserialize consumes its buffer
    if (!grpc::SerializationTraits<v1::PlanJumpRequest>::Deserialize(&copy, request).ok()) {
      release();
      core_.recordInvalid();
      return answer_now(
          grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                       "the request does not parse as a wheeljump.planner.v1.PlanJumpRequest"));
    }
  }
  PlanRequest r;
  try {
    r = toPlanRequest(*request, core_.robot());
  } catch (...) {
    release();
    core_.recordInvalid();
    const ServiceError e = classifyException(std::current_exception());
    spdlog::debug("PlanJump {}: {}", printable(request->request_id()), e.what());
    return answer_now(toGrpcStatus(e));
  }
  HotSlot hot;
  if (hot_.enabled() && answerHot(r, response_bytes, &hot)) {
    release();
    return answer_now(grpc::Status::OK);
  }
  return new PlanJumpReactor(*this, context, std::move(r), std::move(hot), response_bytes);
}

bool JumpPlannerService::answerHot(const PlanRequest& r, grpc::ByteBuffer* response_bytes,
                                   HotSlot* slot) {
  const auto received = Clock::now();
  const CacheKey key = core_.keyOf(r);
  if (!core_.findHit(r, key, &slot->generation)) return false;
  constexpr char kFormatTag[] = {'D', 'K', 'C'};  // per TrajectoryFormat
  const CacheKey::Bytes bytes = key.byteArray();
  slot->key.reserve(bytes.size() + 1);  // one allocation for the 88 bytes
  slot->key.assign(bytes.data(), bytes.size());
  slot->key += kFormatTag[static_cast<int>(r.trajectory)];
  const auto ready = hot_.find(slot->key, slot->generation);
  if (!ready) return false;
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - received).count();
  grpc::Slice parts[2] = {*ready, readySuffix(r.request_id, ms)};
  grpc::ByteBuffer answer(parts, 2);
  response_bytes->Swap(&answer);
  core_.recordHotHit(ms);
  return true;
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
