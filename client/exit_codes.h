// Exit codes of the vpremesh CLI, one per kind of failure, so scripts can tell
// a bad input from a machine problem. The same codes serve local runs
// (vpr::Status) and service calls (grpc::StatusCode, or a job's Failure code).
#pragma once

#include <grpcpp/support/status_code_enum.h>

#include "core/status.h"

namespace vpr::cli {

enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,     // a bug or unexpected library failure (INTERNAL, UNKNOWN, DATA_LOSS)
  kExitUsage = 2,        // bad command line
  kExitBadInput = 3,     // unreadable, corrupt or invalid mesh; impossible target
  kExitLimit = 4,        // a size limit was hit (RESOURCE_EXHAUSTED: upload size, full queue, memory)
  kExitUnavailable = 5,  // no renderer or device; server unreachable or shutting down
  kExitCancelled = 6,    // the job was cancelled
  kExitNotFound = 7,     // input file missing; unknown (or expired) job id
  kExitDeadline = 8,     // --deadline passed before the job ended
  kExitRefused = 9,      // the server cannot do this (FAILED_PRECONDITION, UNIMPLEMENTED, ...)
  kExitDenied = 10,      // UNAUTHENTICATED, PERMISSION_DENIED
};

inline int exit_code_for(const Status& s) {
  switch (s.code()) {
    case StatusCode::kOk:
      return kExitOk;
    case StatusCode::kInvalidArgument:
      return kExitBadInput;
    case StatusCode::kNotFound:
      return kExitNotFound;
    case StatusCode::kResourceExhausted:
      return kExitLimit;
    case StatusCode::kUnavailable:
      return kExitUnavailable;
    case StatusCode::kCancelled:
      return kExitCancelled;
    case StatusCode::kDeadlineExceeded:
      return kExitDeadline;
    case StatusCode::kInternal:
      return kExitInternal;
  }
  return kExitInternal;
}

// For a failed call, and for a job's Failure.code (a grpc::StatusCode value).
inline int exit_code_for(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK:
      return kExitOk;
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::OUT_OF_RANGE:
      return kExitBadInput;
    case grpc::StatusCode::NOT_FOUND:
      return kExitNotFound;
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return kExitLimit;
    case grpc::StatusCode::UNAVAILABLE:
      return kExitUnavailable;
    case grpc::StatusCode::CANCELLED:
      return kExitCancelled;
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return kExitDeadline;
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::ABORTED:
    case grpc::StatusCode::ALREADY_EXISTS:
    case grpc::StatusCode::UNIMPLEMENTED:
      return kExitRefused;
    case grpc::StatusCode::UNAUTHENTICATED:
    case grpc::StatusCode::PERMISSION_DENIED:
      return kExitDenied;
    case grpc::StatusCode::UNKNOWN:
    case grpc::StatusCode::INTERNAL:
    case grpc::StatusCode::DATA_LOSS:
    default:
      return kExitInternal;
  }
}

}  // namespace vpr::cli
