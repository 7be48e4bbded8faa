#include "channel_security.h"

#include <grpcpp/support/client_interceptor.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace vpr::cli {
namespace {

std::string read_file(const std::string& flag, const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CLI::ValidationError(flag, "cannot read " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Drops surrounding white space (the newline an editor or `echo` leaves).
std::string trimmed(const std::string& s) {
  const size_t begin = s.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  return s.substr(begin, s.find_last_not_of(" \t\r\n") - begin + 1);
}

// Adds `authorization: Bearer TOKEN` to every call's initial metadata. An
// interceptor rather than call credentials: gRPC sends call credentials only
// over TLS, and a loopback server without TLS may still ask for tokens.
class BearerToken final : public grpc::experimental::Interceptor {
 public:
  explicit BearerToken(const std::string* header) : header_(header) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(grpc::experimental::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA))
      methods->GetSendInitialMetadata()->insert({"authorization", *header_});
    methods->Proceed();
  }

 private:
  const std::string* header_;
};

class BearerTokenFactory final : public grpc::experimental::ClientInterceptorFactoryInterface {
 public:
  explicit BearerTokenFactory(std::string token) : header_("Bearer " + token) {}
  grpc::experimental::Interceptor* CreateClientInterceptor(grpc::experimental::ClientRpcInfo*) override {
    return new BearerToken(&header_);
  }

 private:
  const std::string header_;  // lives as long as the channel that owns the factory
};

}  // namespace

ChannelSecurity& channel_security() {
  static ChannelSecurity settings;
  return settings;
}

void add_channel_security_flags(CLI::App* cmd) {
  ChannelSecurity& s = channel_security();
  cmd->add_flag("--tls", s.tls, "Connect over TLS, trusting the system's CA certificates");
  cmd->add_option("--tls-ca", s.tls_ca, "Connect over TLS, trusting the CA certificates in this PEM file")
      ->envname("VPREMESH_TLS_CA");
  cmd->add_option("--tls-cert", s.tls_cert, "PEM client certificate, for a server that requires one (mutual TLS)");
  cmd->add_option("--tls-key", s.tls_key, "PEM private key of --tls-cert");
  cmd->add_option("--token-file", s.token_file,
                  "File holding this tenant's bearer token (or set $VPREMESH_TOKEN; never pass a token itself on the "
                  "command line)");
  cmd->parse_complete_callback([] {
    ChannelSecurity& s = channel_security();
    if (s.tls_cert.empty() != s.tls_key.empty())
      throw CLI::ValidationError("--tls-cert", "--tls-cert and --tls-key go together");
    if (!s.tls_ca.empty()) s.ca_pem = read_file("--tls-ca", s.tls_ca);
    if (!s.tls_cert.empty()) {
      s.cert_pem = read_file("--tls-cert", s.tls_cert);
      s.key_pem = read_file("--tls-key", s.tls_key);
    }
    if (!s.token_file.empty()) {
      s.token = trimmed(read_file("--token-file", s.token_file));
      if (s.token.empty()) throw CLI::ValidationError("--token-file", s.token_file + " holds no token");
    } else if (const char* env = std::getenv("VPREMESH_TOKEN"); env && *env) {
      s.token = trimmed(env);
    }
  });
}

std::shared_ptr<grpc::Channel> secure_channel(const std::string& server, const grpc::ChannelArguments& args) {
  const ChannelSecurity& s = channel_security();
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (s.uses_tls()) {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = s.ca_pem;  // empty: the system's
    ssl.pem_private_key = s.key_pem;
    ssl.pem_cert_chain = s.cert_pem;
    credentials = grpc::SslCredentials(ssl);
  }
  if (s.token.empty()) return grpc::CreateCustomChannel(server, credentials, args);
  std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(std::make_unique<BearerTokenFactory>(s.token));
  return grpc::experimental::CreateCustomChannelWithInterceptors(server, credentials, args, std::move(interceptors));
}

}  // namespace vpr::cli
