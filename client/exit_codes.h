// Exit codes of the vpremesh CLI, one per kind of failure, so scripts can tell
// a bad input from a machine problem.
#pragma once

#include "pipeline/status.h"

namespace vpr::cli {

enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,     // a bug or unexpected library failure
  kExitUsage = 2,        // bad command line
  kExitBadInput = 3,     // unreadable, corrupt or invalid mesh; impossible target
  kExitLimit = 4,        // a size limit was hit
  kExitUnavailable = 5,  // no renderer or device
  kExitCancelled = 6,
  kExitNotFound = 7,  // input file missing
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
    case StatusCode::kDeadlineExceeded:
      return kExitCancelled;
    case StatusCode::kInternal:
      return kExitInternal;
  }
  return kExitInternal;
}

}  // namespace vpr::cli
