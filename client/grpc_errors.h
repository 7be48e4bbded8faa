// Failed service calls and failed jobs as one clear line on stderr and an exit
// code from exit_codes.h:
//   vpremesh: RESOURCE_EXHAUSTED: upload of 700 MiB exceeds the server's limit of 512 MiB
#pragma once

#include <grpcpp/support/status.h>

#include <string>

#include "vpremesh/v1/remesh.pb.h"

namespace vpr::cli {

// Messages from the server or the transport may span lines; the CLI prints one.
std::string one_line(std::string s);

// "RESOURCE_EXHAUSTED", "UNAVAILABLE", ...; "CODE_<n>" for a value outside the enum.
std::string grpc_code_name(grpc::StatusCode code);

// True when the call failed in the transport, not by the server's answer:
// nothing accepted the connection, or it broke before the server answered.
bool is_connection_failure(const grpc::Status& status);

// The line printed for a failed call to `server` (without "vpremesh: "). A
// transport failure (nothing listening, name not resolved) says which address
// could not be reached.
std::string describe_call_error(const grpc::Status& status, const std::string& server);

// Prints "vpremesh: CODE: message" and returns the exit code for the status.
int report_call_error(const grpc::Status& status, const std::string& server);

// The same for a job that ended in `failed` or `cancelled`.
int report_job_failure(const vpremesh::v1::Failure& failure, bool cancelled);

}  // namespace vpr::cli
