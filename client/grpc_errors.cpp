#include "grpc_errors.h"

#include <cstdio>

#include "exit_codes.h"

namespace vpr::cli {

bool is_connection_failure(const grpc::Status& status) {
  if (status.error_code() != grpc::StatusCode::UNAVAILABLE) return false;
  const std::string& m = status.error_message();
  // The server's own answer when its Redis queue is down quotes Redis'
  // socket error ("Connection refused"): the server was reached.
  if (m.rfind("the job queue ", 0) == 0) return false;
  for (const char* needle : {"failed to connect", "Connection refused", "DNS resolution failed", "Socket closed",
                             "Connection reset", "Broken pipe", "No route to host"})
    if (m.find(needle) != std::string::npos) return true;
  return false;
}

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

std::string grpc_code_name(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK:
      return "OK";
    case grpc::StatusCode::CANCELLED:
      return "CANCELLED";
    case grpc::StatusCode::UNKNOWN:
      return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT:
      return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND:
      return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS:
      return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED:
      return "PERMISSION_DENIED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION:
      return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED:
      return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE:
      return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED:
      return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL:
      return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE:
      return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS:
      return "DATA_LOSS";
    case grpc::StatusCode::UNAUTHENTICATED:
      return "UNAUTHENTICATED";
    default:
      return "CODE_" + std::to_string(int(code));
  }
}

std::string describe_call_error(const grpc::Status& status, const std::string& server) {
  std::string message = one_line(status.error_message());
  if (is_connection_failure(status))
    message = "cannot reach the server at " + server + (message.empty() ? "" : " (" + message + ")");
  else if (status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED && message == "Deadline Exceeded")
    message = "the --deadline passed before the job ended";
  if (message.empty()) message = "no message from " + server;
  return grpc_code_name(status.error_code()) + ": " + message;
}

int report_call_error(const grpc::Status& status, const std::string& server) {
  std::fprintf(stderr, "vpremesh: %s\n", describe_call_error(status, server).c_str());
  return exit_code_for(status.error_code());
}

int report_job_failure(const vpremesh::v1::Failure& failure, bool cancelled) {
  grpc::StatusCode code = grpc::StatusCode(failure.code());
  if (cancelled && code == grpc::StatusCode::OK) code = grpc::StatusCode::CANCELLED;
  if (!cancelled && code == grpc::StatusCode::OK) code = grpc::StatusCode::UNKNOWN;
  std::string message = one_line(failure.message());
  if (message.empty()) message = cancelled ? "the job was cancelled" : "the job failed";
  std::fprintf(stderr, "vpremesh: %s: %s\n", grpc_code_name(code).c_str(), message.c_str());
  return exit_code_for(code);
}

}  // namespace vpr::cli
