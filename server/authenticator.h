// Who is calling: the tenant named by the call's bearer token (gRPC metadata
// `authorization: Bearer TOKEN`) when the server has --auth-tokens, else
// nobody in particular. Only RemeshService asks; health and reflection stay
// open (Kubernetes probes carry no token).
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <mutex>
#include <string>

#include "server/tenant_tokens.h"

namespace vpr::service {

struct Caller {
  std::string tenant;  // owns the jobs it submits; "" when authentication is off
  // What --max-jobs-per-client counts: the tenant, or without authentication
  // the source address without its port (a client that opens a connection
  // per job is still one client).
  std::string client;
  size_t max_jobs = 0;  // the tenant's max_jobs=, 0: --max-jobs-per-client
};

// "ipv4:10.1.2.3:5678" -> "ipv4:10.1.2.3", "ipv6:[::1]:80" -> "ipv6:[::1]";
// other forms (unix:PATH) are kept whole.
std::string address_without_port(const std::string& peer);

class Authenticator {
 public:
  // tokens_path "": authentication off, every call is let in.
  explicit Authenticator(std::string tokens_path = "") : path_(std::move(tokens_path)) {}

  bool enabled() const { return !path_.empty(); }
  // Reads the file again (at startup, on SIGHUP, and when changed_on_disk).
  // On an error the tenants known so far stay in force and the error is
  // returned.
  Status reload();
  // Whether the file's modification time or size differs from the last
  // reload's: a Kubernetes Secret volume is updated in place, and no one
  // sends the server a SIGHUP there.
  bool changed_on_disk() const;

  // OK and *caller filled, or UNAUTHENTICATED (the token is never echoed).
  grpc::Status identify(const grpc::ServerContextBase& context, Caller* caller) const;

 private:
  const std::string path_;
  mutable std::mutex mu_;
  std::shared_ptr<const TenantTokens> tokens_;
  struct FileStamp {
    int64_t mtime_ns = -1, size = -1;
    bool operator==(const FileStamp& o) const { return mtime_ns == o.mtime_ns && size == o.size; }
  };
  FileStamp stamp() const;
  FileStamp loaded_;  // of the last reload, successful or not
};

}  // namespace vpr::service
