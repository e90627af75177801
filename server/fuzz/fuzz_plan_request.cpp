// libFuzzer target: arbitrary bytes through the proto parser and the request validation of
// PlanJump and WarmCache. Fails (aborts) when validation lets an exception other than an
// INVALID_ARGUMENT ServiceError escape, gives an error without a message, or accepts a request
// whose domain form breaks the planner's own checks or the service's bounds.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "server/request_validation.h"

namespace {

const wj::model::RobotModel* robot = nullptr;

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "fuzz_plan_request: invariant broken: %s\n", what);
  std::abort();
}

void checkError(const wj::server::ServiceError& e) {
  if (e.code() != wj::server::ErrorCode::InvalidArgument) fail("error is not INVALID_ARGUMENT");
  if (std::strlen(e.what()) == 0) fail("error without a message");
}

wj::planner::InitialState nominal() {
  wj::planner::InitialState s;
  for (int leg = 0; leg < 4; ++leg) {
    s.q[leg * 4 + 1] = 1.0;
    s.q[leg * 4 + 2] = -2.0;
  }
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  robot = new wj::model::RobotModel(wj::model::RobotModel::loadDefault());
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace wj::server;
  if (size > 1 << 16) return 0;  // the server refuses bigger messages before parsing
  {
    v1::PlanJumpRequest request;
    if (request.ParseFromArray(data, static_cast<int>(size))) {
      try {
        const PlanRequest r = toPlanRequest(request, *robot);
        // Accepted: the domain request must pass the planner's checks and the service's bounds.
        r.task.validate();
        r.initial.validate(*robot);
        if (r.request_id.size() > RequestBounds::kMaxRequestIdBytes) fail("request_id too long");
        if (r.max_verified_candidates < 0 ||
            r.max_verified_candidates > static_cast<int>(RequestBounds::kMaxVerifiedCandidates))
          fail("candidates out of range");
        if (r.max_evaluations &&
            (*r.max_evaluations < 1 || *r.max_evaluations > RequestBounds::kMaxEvaluations))
          fail("evaluations out of range");
        if (!std::isfinite(r.initial.v0) || !std::isfinite(r.initial.pitch_rate))
          fail("non-finite state accepted");
        const double stamp = request.state().stamp_s();
        if (!std::isfinite(stamp) || stamp < 0.0 || stamp > RequestBounds::kMaxStampS)
          fail("state.stamp_s outside [0, kMaxStampS] accepted");
        for (const char c : r.request_id)
          if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
            fail("control character in request_id accepted");
        if (!r.initial.q.allFinite() || !std::isfinite(r.initial.pitch))
          fail("non-finite posture accepted");
      } catch (const ServiceError& e) {
        checkError(e);
      }
    }
  }
  {
    v1::WarmCacheRequest request;
    if (request.ParseFromArray(data, static_cast<int>(size))) {
      try {
        const WarmRequest w = toWarmRequest(request, *robot, nominal());
        w.task.validate();
        if (w.v0_grid.empty() ||
            w.v0_grid.size() > static_cast<std::size_t>(RequestBounds::kMaxWarmGridPoints))
          fail("grid size out of range");
        for (const double v : w.v0_grid)
          if (!std::isfinite(v) || v < -1.0 || v > 4.0) fail("grid point out of range");
        if (!(request.v0_step_m_s() > 0.0 && request.v0_step_m_s() <= 5.0))
          fail("v0_step_m_s outside (0, 5] accepted");
      } catch (const ServiceError& e) {
        checkError(e);
      }
    }
  }
  return 0;
}
