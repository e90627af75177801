#include "planner_client/planner_client.h"

#include <grpcpp/alarm.h>
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "wheeljump/planner/v1/jump_planner.grpc.pb.h"

namespace wj::client {

namespace v1 = wheeljump::planner::v1;
using SystemClock = std::chrono::system_clock;

namespace {

std::string readFile(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("planner client: cannot read " + what + " " + path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

// One call in flight; the completion queue's tag. proceed() runs on the completion thread.
class CallBase {
 public:
  virtual ~CallBase() = default;
  virtual void proceed(bool ok) = 0;
  virtual void cancel() = 0;
};

struct PlannerClient::Impl {
  explicit Impl(ClientOptions o) : options(std::move(o)) {
    grpc::ChannelArguments args;
    args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, options.keepalive_time_ms);
    args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, options.keepalive_timeout_ms);
    args.SetInt(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS,
                options.keepalive_permit_without_calls ? 1 : 0);
    args.SetInt(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
    args.SetMaxReceiveMessageSize(options.max_receive_message_bytes);
    // This library retries UNAVAILABLE itself, within each call's deadline.
    args.SetInt(GRPC_ARG_ENABLE_RETRIES, 0);
    // Reconnect quickly after a server restart.
    args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
    args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 100);
    args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 1000);
    // The load-balancing policy comes from this service config only (not from DNS TXT records).
    args.SetServiceConfigJSON(options.load_balancing == LoadBalancing::RoundRobin
                                  ? R"({"loadBalancingConfig": [{"round_robin": {}}]})"
                                  : R"({"loadBalancingConfig": [{"pick_first": {}}]})");
    args.SetInt(GRPC_ARG_SERVICE_CONFIG_DISABLE_RESOLUTION, 1);
    std::shared_ptr<grpc::ChannelCredentials> creds;
    if (options.use_tls) {
      grpc::SslCredentialsOptions ssl;
      if (!options.tls.root_ca_file.empty())
        ssl.pem_root_certs = readFile(options.tls.root_ca_file, "root CA");
      if (!options.tls.cert_chain_file.empty()) {
        ssl.pem_cert_chain = readFile(options.tls.cert_chain_file, "client certificate");
        ssl.pem_private_key = readFile(options.tls.private_key_file, "client key");
      }
      if (!options.tls.target_name_override.empty())
        args.SetSslTargetNameOverride(options.tls.target_name_override);
      creds = grpc::SslCredentials(ssl);
    } else {
      creds = grpc::InsecureChannelCredentials();
    }
    channel = grpc::CreateCustomChannel(options.target, creds, args);
    stub = v1::JumpPlanner::NewStub(channel);
    thread = std::thread([this] {
      void* tag = nullptr;
      bool ok = false;
      while (cq.Next(&tag, &ok)) static_cast<CallBase*>(tag)->proceed(ok);
    });
  }

  ~Impl() {
    cancelAll();
    {
      std::unique_lock lock(mu);
      closing = true;
      idle.wait(lock, [&] { return active.empty(); });
    }
    cq.Shutdown();
    thread.join();
  }

  // Registers a call; false when the client is closing.
  bool add(CallBase* call) {
    std::lock_guard lock(mu);
    if (closing) return false;
    active.insert(call);
    return true;
  }
  void remove(CallBase* call) {
    std::lock_guard lock(mu);
    active.erase(call);
    if (active.empty()) idle.notify_all();
  }
  void cancelAll() {
    std::lock_guard lock(mu);
    for (CallBase* c : active) c->cancel();
  }
  SystemClock::time_point deadlineFor(std::optional<std::chrono::milliseconds> d) const {
    return SystemClock::now() + d.value_or(options.default_deadline);
  }
  std::chrono::milliseconds backoff(int attempt) const {
    double ms = static_cast<double>(options.initial_backoff.count());
    for (int i = 1; i < attempt; ++i) ms *= options.backoff_multiplier;
    return std::chrono::milliseconds(
        static_cast<std::int64_t>(std::min(ms, static_cast<double>(options.max_backoff.count()))));
  }

  ClientOptions options;
  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<v1::JumpPlanner::Stub> stub;
  grpc::CompletionQueue cq;
  std::thread thread;
  std::mutex mu;
  std::condition_variable idle;
  std::set<CallBase*> active;
  bool closing = false;
};

namespace {

// A unary call with retries on UNAVAILABLE. Deletes itself when done.
template <typename Request, typename Response>
class UnaryCall final : public CallBase {
 public:
  using Prepare = std::unique_ptr<grpc::ClientAsyncResponseReader<Response>> (
      v1::JumpPlanner::Stub::*)(grpc::ClientContext*, const Request&, grpc::CompletionQueue*);

  UnaryCall(PlannerClient::Impl& impl, Prepare prepare, Request request,
            SystemClock::time_point deadline, std::function<void(CallResult<Response>)> done)
      : impl_(impl),
        prepare_(prepare),
        request_(std::move(request)),
        deadline_(deadline),
        done_(std::move(done)) {}

  void start() {
    if (!impl_.add(this)) {
      CallResult<Response> r;
      r.status = grpc::Status(grpc::StatusCode::CANCELLED, "the planner client is closing");
      done_(std::move(r));
      delete this;
      return;
    }
    std::lock_guard lock(mu_);
    startAttemptLocked();
  }

  void proceed(bool ok) override {
    bool finished = false;
    {
      std::lock_guard lock(mu_);
      if (waiting_) {
        waiting_ = false;
        if (!ok || cancelled_) {
          status_ = grpc::Status(grpc::StatusCode::CANCELLED, "cancelled while waiting to retry");
          finished = true;
        } else {
          startAttemptLocked();
        }
      } else if (status_.error_code() == grpc::StatusCode::UNAVAILABLE && !cancelled_ &&
                 attempt_ < impl_.options.max_attempts) {
        const auto wake = SystemClock::now() + impl_.backoff(attempt_);
        if (wake < deadline_) {
          waiting_ = true;
          alarm_.Set(&impl_.cq, wake, this);
        } else {
          finished = true;
        }
      } else {
        finished = true;
      }
    }
    if (finished) finish();
  }

  void cancel() override {
    std::lock_guard lock(mu_);
    cancelled_ = true;
    if (waiting_) {
      alarm_.Cancel();
    } else if (context_) {
      context_->TryCancel();
    }
  }

 private:
  void startAttemptLocked() {
    ++attempt_;
    context_ = std::make_unique<grpc::ClientContext>();
    context_->set_deadline(deadline_);
    response_.Clear();
    reader_ = (impl_.stub.get()->*prepare_)(context_.get(), request_, &impl_.cq);
    reader_->StartCall();
    reader_->Finish(&response_, &status_, this);
  }
  void finish() {
    CallResult<Response> r;
    r.status = status_;
    r.response = std::move(response_);
    r.attempts = attempt_;
    impl_.remove(this);
    done_(std::move(r));
    delete this;
  }

  PlannerClient::Impl& impl_;
  Prepare prepare_;
  Request request_;
  SystemClock::time_point deadline_;
  std::function<void(CallResult<Response>)> done_;
  std::mutex mu_;
  std::unique_ptr<grpc::ClientContext> context_;
  std::unique_ptr<grpc::ClientAsyncResponseReader<Response>> reader_;
  Response response_;
  grpc::Status status_;
  grpc::Alarm alarm_;
  int attempt_ = 0;
  bool waiting_ = false;
  bool cancelled_ = false;
};

// A WarmCache stream; retried on UNAVAILABLE only while no progress has arrived.
class WarmCall final : public CallBase {
 public:
  WarmCall(PlannerClient::Impl& impl, v1::WarmCacheRequest request,
           SystemClock::time_point deadline,
           std::function<void(const v1::WarmCacheProgress&)> progress,
           std::function<void(WarmResult)> done)
      : impl_(impl),
        request_(std::move(request)),
        deadline_(deadline),
        progress_(std::move(progress)),
        done_(std::move(done)) {}

  void start() {
    if (!impl_.add(this)) {
      WarmResult r;
      r.status = grpc::Status(grpc::StatusCode::CANCELLED, "the planner client is closing");
      done_(std::move(r));
      delete this;
      return;
    }
    std::lock_guard lock(mu_);
    startAttemptLocked();
  }

  void proceed(bool ok) override {
    bool finished = false;
    bool deliver = false;
    {
      std::lock_guard lock(mu_);
      switch (state_) {
        case State::Starting:
        case State::Reading:
          if (state_ == State::Reading && ok) {
            deliver = true;  // a message arrived; read the next after delivering it
            break;
          }
          if (!ok) {
            state_ = State::Finishing;
            reader_->Finish(&status_, this);
          } else {
            state_ = State::Reading;
            reader_->Read(&message_, this);
          }
          break;
        case State::Finishing:
          if (status_.error_code() == grpc::StatusCode::UNAVAILABLE && received_ == 0 &&
              !cancelled_ && attempt_ < impl_.options.max_attempts) {
            const auto wake = SystemClock::now() + impl_.backoff(attempt_);
            if (wake < deadline_) {
              state_ = State::Waiting;
              alarm_.Set(&impl_.cq, wake, this);
              break;
            }
          }
          finished = true;
          break;
        case State::Waiting:
          if (!ok || cancelled_) {
            status_ = grpc::Status(grpc::StatusCode::CANCELLED, "cancelled while waiting to retry");
            finished = true;
          } else {
            startAttemptLocked();
          }
          break;
      }
    }
    if (deliver) {
      ++received_;
      last_ = message_;
      progress_(message_);
      std::lock_guard lock(mu_);
      reader_->Read(&message_, this);
    }
    if (finished) {
      WarmResult r;
      r.status = status_;
      r.response = last_;
      r.attempts = attempt_;
      impl_.remove(this);
      done_(std::move(r));
      delete this;
    }
  }

  void cancel() override {
    std::lock_guard lock(mu_);
    cancelled_ = true;
    if (state_ == State::Waiting) {
      alarm_.Cancel();
    } else if (context_) {
      context_->TryCancel();
    }
  }

 private:
  enum class State { Starting, Reading, Finishing, Waiting };
  void startAttemptLocked() {
    ++attempt_;
    context_ = std::make_unique<grpc::ClientContext>();
    context_->set_deadline(deadline_);
    reader_ = impl_.stub->PrepareAsyncWarmCache(context_.get(), request_, &impl_.cq);
    state_ = State::Starting;
    reader_->StartCall(this);
  }

  PlannerClient::Impl& impl_;
  v1::WarmCacheRequest request_;
  SystemClock::time_point deadline_;
  std::function<void(const v1::WarmCacheProgress&)> progress_;
  std::function<void(WarmResult)> done_;
  std::mutex mu_;
  std::unique_ptr<grpc::ClientContext> context_;
  std::unique_ptr<grpc::ClientAsyncReader<v1::WarmCacheProgress>> reader_;
  v1::WarmCacheProgress message_, last_;
  grpc::Status status_;
  grpc::Alarm alarm_;
  State state_ = State::Starting;
  int attempt_ = 0;
  int received_ = 0;
  bool cancelled_ = false;
};

template <typename Result>
std::function<void(Result)> fulfil(std::shared_ptr<std::promise<Result>> promise) {
  return [promise](Result r) { promise->set_value(std::move(r)); };
}

}  // namespace

PlannerClient::PlannerClient(ClientOptions options)
    : impl_(std::make_unique<Impl>(std::move(options))) {}

PlannerClient::~PlannerClient() = default;

void PlannerClient::planJump(v1::PlanJumpRequest request, std::function<void(PlanResult)> done,
                             std::optional<std::chrono::milliseconds> deadline) {
  auto* call = new UnaryCall<v1::PlanJumpRequest, v1::PlanJumpResponse>(
      *impl_, &v1::JumpPlanner::Stub::PrepareAsyncPlanJump, std::move(request),
      impl_->deadlineFor(deadline), std::move(done));
  call->start();
}

std::future<PlanResult> PlannerClient::planJump(v1::PlanJumpRequest request,
                                                std::optional<std::chrono::milliseconds> deadline) {
  auto promise = std::make_shared<std::promise<PlanResult>>();
  auto future = promise->get_future();
  planJump(std::move(request), fulfil(promise), deadline);
  return future;
}

void PlannerClient::getStats(std::function<void(StatsResult)> done,
                             std::optional<std::chrono::milliseconds> deadline) {
  auto* call = new UnaryCall<v1::GetStatsRequest, v1::GetStatsResponse>(
      *impl_, &v1::JumpPlanner::Stub::PrepareAsyncGetStats, v1::GetStatsRequest{},
      impl_->deadlineFor(deadline), std::move(done));
  call->start();
}

std::future<StatsResult> PlannerClient::getStats(
    std::optional<std::chrono::milliseconds> deadline) {
  auto promise = std::make_shared<std::promise<StatsResult>>();
  auto future = promise->get_future();
  getStats(fulfil(promise), deadline);
  return future;
}

void PlannerClient::warmCache(v1::WarmCacheRequest request,
                              std::function<void(const v1::WarmCacheProgress&)> progress,
                              std::function<void(WarmResult)> done,
                              std::optional<std::chrono::milliseconds> deadline) {
  auto* call = new WarmCall(*impl_, std::move(request), impl_->deadlineFor(deadline),
                            std::move(progress), std::move(done));
  call->start();
}

void PlannerClient::cancelAll() {
  impl_->cancelAll();
}

int PlannerClient::inflight() const {
  std::lock_guard lock(impl_->mu);
  return static_cast<int>(impl_->active.size());
}

}  // namespace wj::client
