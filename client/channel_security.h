// How the service commands reach a server securely: TLS (--tls-ca, or
// $VPREMESH_TLS_CA; --tls-cert/--tls-key for mutual TLS) and the tenant's
// bearer token (--token-file, or $VPREMESH_TOKEN). A token is never a
// command-line argument: other users of the machine can read those in ps.
#pragma once

#include <grpcpp/grpcpp.h>

#include <CLI/CLI.hpp>
#include <memory>
#include <string>

namespace vpr::cli {

struct ChannelSecurity {
  // Flags as given.
  bool tls = false;        // --tls: TLS with the system's CA certificates
  std::string tls_ca;      // --tls-ca FILE: TLS, trusting the server certificate's CA in FILE
  std::string tls_cert;    // --tls-cert FILE: client certificate (mutual TLS)
  std::string tls_key;     // --tls-key FILE
  std::string token_file;  // --token-file FILE: the bearer token (first line)
  // Read from the files (and $VPREMESH_TOKEN) once the command line is parsed.
  std::string ca_pem, cert_pem, key_pem, token;

  bool uses_tls() const { return tls || !tls_ca.empty() || !tls_cert.empty(); }
};

// The settings of this process's command (one command per process).
ChannelSecurity& channel_security();

// Adds --tls, --tls-ca, --tls-cert, --tls-key and --token-file to `cmd`; after
// parsing it reads the files and $VPREMESH_TOKEN, and a file that cannot be
// read is a usage error naming the flag.
void add_channel_security_flags(CLI::App* cmd);

// A channel to `server` with channel_security()'s credentials, sending the
// token (if any) with every call.
std::shared_ptr<grpc::Channel> secure_channel(const std::string& server, const grpc::ChannelArguments& args);

}  // namespace vpr::cli
