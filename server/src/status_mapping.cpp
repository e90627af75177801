#include "server/status_mapping.h"

namespace wj::server {

std::string_view toString(ErrorCode code) {
  switch (code) {
    case ErrorCode::InvalidArgument:
      return "invalid_argument";
    case ErrorCode::ResourceExhausted:
      return "resource_exhausted";
    case ErrorCode::DeadlineExceeded:
      return "deadline_exceeded";
    case ErrorCode::Cancelled:
      return "cancelled";
    case ErrorCode::Unavailable:
      return "unavailable";
    case ErrorCode::Internal:
      return "internal";
  }
  return "?";
}

ServiceError classifyException(const std::exception_ptr& error) noexcept {
  try {
    std::rethrow_exception(error);
  } catch (const ServiceError& e) {
    return e;
  } catch (const std::invalid_argument& e) {
    return ServiceError(ErrorCode::InvalidArgument, e.what());
  } catch (const std::exception& e) {
    return ServiceError(ErrorCode::Internal, std::string("internal error: ") + e.what());
  } catch (...) {
    return ServiceError(ErrorCode::Internal, "internal error: unknown exception");
  }
}

grpc::Status toGrpcStatus(const ServiceError& error) {
  grpc::StatusCode code = grpc::StatusCode::INTERNAL;
  switch (error.code()) {
    case ErrorCode::InvalidArgument:
      code = grpc::StatusCode::INVALID_ARGUMENT;
      break;
    case ErrorCode::ResourceExhausted:
      code = grpc::StatusCode::RESOURCE_EXHAUSTED;
      break;
    case ErrorCode::DeadlineExceeded:
      code = grpc::StatusCode::DEADLINE_EXCEEDED;
      break;
    case ErrorCode::Cancelled:
      code = grpc::StatusCode::CANCELLED;
      break;
    case ErrorCode::Unavailable:
      code = grpc::StatusCode::UNAVAILABLE;
      break;
    case ErrorCode::Internal:
      code = grpc::StatusCode::INTERNAL;
      break;
  }
  return grpc::Status(code, error.what());
}

}  // namespace wj::server
