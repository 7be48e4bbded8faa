// The one mapping from the pipeline's status codes to gRPC's (STYLE.md
// "Errors"; Triton's grpc_utils.cc does the same in one switch).
#pragma once

#include <grpcpp/support/status.h>

#include "core/status.h"
#include "vpremesh/v1/remesh.pb.h"

namespace vpr::service {

namespace v1 = ::vpremesh::v1;

inline grpc::StatusCode to_grpc_code(StatusCode code) {
  switch (code) {
    case StatusCode::kOk:
      return grpc::StatusCode::OK;
    case StatusCode::kInvalidArgument:
      return grpc::StatusCode::INVALID_ARGUMENT;
    case StatusCode::kNotFound:
      return grpc::StatusCode::NOT_FOUND;
    case StatusCode::kResourceExhausted:
      return grpc::StatusCode::RESOURCE_EXHAUSTED;
    case StatusCode::kUnavailable:
      return grpc::StatusCode::UNAVAILABLE;
    case StatusCode::kInternal:
      return grpc::StatusCode::INTERNAL;
    case StatusCode::kCancelled:
      return grpc::StatusCode::CANCELLED;
    case StatusCode::kDeadlineExceeded:
      return grpc::StatusCode::DEADLINE_EXCEEDED;
  }
  return grpc::StatusCode::INTERNAL;
}

inline grpc::Status to_grpc(const Status& s) {
  return s.ok() ? grpc::Status::OK : grpc::Status(to_grpc_code(s.code()), s.message());
}

inline v1::Failure to_failure(const Status& s) {
  v1::Failure f;
  f.set_code(int(to_grpc_code(s.code())));
  f.set_message(s.message());
  return f;
}

inline v1::Failure to_failure(grpc::StatusCode code, const std::string& message) {
  v1::Failure f;
  f.set_code(int(code));
  f.set_message(message);
  return f;
}

// The reverse of to_failure, for a failure stored by another process (the
// Redis queue's cancel requests). Codes without a pipeline twin are INTERNAL.
inline Status from_failure(const v1::Failure& f) {
  switch (grpc::StatusCode(f.code())) {
    case grpc::StatusCode::OK:
      return Status::Ok();
    case grpc::StatusCode::INVALID_ARGUMENT:
      return Status(StatusCode::kInvalidArgument, f.message());
    case grpc::StatusCode::NOT_FOUND:
      return Status(StatusCode::kNotFound, f.message());
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return Status(StatusCode::kResourceExhausted, f.message());
    case grpc::StatusCode::UNAVAILABLE:
      return Status(StatusCode::kUnavailable, f.message());
    case grpc::StatusCode::CANCELLED:
      return Status(StatusCode::kCancelled, f.message());
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return Status(StatusCode::kDeadlineExceeded, f.message());
    default:
      return Status(StatusCode::kInternal, f.message());
  }
}

inline grpc::Status to_grpc(const v1::Failure& f) {
  return grpc::Status(grpc::StatusCode(f.code()), f.message());
}

}  // namespace vpr::service
