#pragma once
/// @file The one place where domain errors become gRPC status codes (see docs/service.md for what
/// each code means to a client).

#include <grpcpp/support/status.h>

#include "server/service_error.h"

namespace wj::server {

/// The gRPC status of a domain error: its code and its message, unchanged.
grpc::Status toGrpcStatus(const ServiceError& error);

}  // namespace wj::server
