#pragma once
/// @file The service's domain errors. The planning core reports failures as a ServiceError; the
/// RPC layer maps them to grpc::Status in one function (status_mapping.h).

#include <exception>
#include <stdexcept>
#include <string>
#include <string_view>

namespace wj::server {

/// Why a call did not produce an answer.
enum class ErrorCode {
  InvalidArgument,    ///< a field is missing, not finite or out of its range
  ResourceExhausted,  ///< a work queue or an in-flight bound is full
  DeadlineExceeded,   ///< no verified plan within the call's deadline
  Cancelled,          ///< the caller cancelled (or its deadline passed on its side)
  Unavailable,        ///< the server is shutting down
  Internal,           ///< a bug or an unexpected failure (I/O, a solver exception)
};
/// "invalid_argument", "resource_exhausted", ...
std::string_view toString(ErrorCode code);

/// An error with its code and a message for the caller (naming the field and range if invalid).
class ServiceError : public std::runtime_error {
 public:
  ServiceError(ErrorCode code, const std::string& message)
      : std::runtime_error(message), code_(code) {}
  ErrorCode code() const { return code_; }

 private:
  ErrorCode code_;
};

/// The ServiceError for an exception thrown by the planner or the service: std::invalid_argument
/// is InvalidArgument, a ServiceError keeps its code, anything else is Internal.
ServiceError classifyException(const std::exception_ptr& error) noexcept;

}  // namespace wj::server
