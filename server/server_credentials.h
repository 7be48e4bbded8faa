// The gRPC port's credentials from --tls-cert, --tls-key and --tls-client-ca:
// TLS when a certificate is given, mutual TLS (a client certificate signed by
// --tls-client-ca required) when a client CA is too, else plaintext.
#pragma once

#include <grpcpp/security/server_credentials.h>

#include <memory>

#include "core/status.h"
#include "server/server_options.h"

namespace vpr::service {

// NOT_FOUND names a file that cannot be read.
StatusOr<std::shared_ptr<grpc::ServerCredentials>> server_credentials(const ServerOptions& options);

}  // namespace vpr::service
