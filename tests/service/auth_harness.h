// What the authentication and TLS tests share: tokens files, throw-away
// certificates made with the openssl command, and RemeshService calls that
// carry a tenant's bearer token.
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "service_harness.h"

namespace vpr::testing {

// Runs a shell command line; its exit code (-1 when it could not run).
inline int shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// SHA-256 of `text` in hex, as the tokens file wants it (sha256sum).
inline std::string sha256_hex(const std::string& text) {
  FILE* pipe = ::popen(("printf %s '" + text + "' | sha256sum").c_str(), "r");
  char buf[65] = {};
  if (!pipe || std::fread(buf, 1, 64, pipe) != 64) buf[0] = 0;
  if (pipe) ::pclose(pipe);
  return buf;
}

// tenant -> "TOKEN [max_jobs=N]": writes "TENANT SHA256 [max_jobs=N]" lines.
inline void write_tokens(const std::string& path, const std::map<std::string, std::string>& tenants) {
  std::ofstream out(path);
  out << "# test tenants\n";
  for (const auto& [tenant, token_and_more] : tenants) {
    const size_t space = token_and_more.find(' ');
    out << tenant << " " << sha256_hex(token_and_more.substr(0, space));
    if (space != std::string::npos) out << token_and_more.substr(space);
    out << "\n";
  }
}

// A CA (ca.pem), a server certificate for 127.0.0.1 and localhost signed by
// it (server.pem, server.key), a client certificate (client.pem,
// client.key) and an unrelated CA (other-ca.pem), in `dir`. False when
// openssl failed.
inline bool make_certificates(const std::string& dir) {
  const std::string d = "cd '" + dir + "' && ";
  const std::string quiet = " >/dev/null 2>&1";
  auto ca = [&](const std::string& name) {
    return shell(d + "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=" + name + " -keyout " + name +
                 ".key -out " + name + ".pem" + quiet) == 0;
  };
  auto leaf = [&](const std::string& name, const std::string& ext) {
    return shell(d + "openssl req -newkey rsa:2048 -nodes -subj /CN=" + name + " -keyout " + name + ".key -out " +
                 name + ".csr" + quiet) == 0 &&
           shell(d + "printf '" + ext + "' > " + name + ".ext && openssl x509 -req -in " + name +
                 ".csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 1 -extfile " + name + ".ext -out " + name +
                 ".pem" + quiet) == 0;
  };
  return ca("ca") && ca("other-ca") &&
         leaf("server", "subjectAltName=IP:127.0.0.1,DNS:localhost\\nextendedKeyUsage=serverAuth\\n") &&
         leaf("client", "extendedKeyUsage=clientAuth\\n");
}

inline void with_token(grpc::ClientContext& context, const std::string& token) {
  if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
}

inline grpc::Status get_job_as(v1::RemeshService::Stub& stub, const std::string& token, const std::string& job_id,
                               v1::JobStatus* status = nullptr) {
  grpc::ClientContext context;
  with_token(context, token);
  v1::JobRef ref;
  ref.set_job_id(job_id);
  v1::JobStatus ignored;
  return stub.GetJob(&context, ref, status ? status : &ignored);
}

inline grpc::Status cancel_as(v1::RemeshService::Stub& stub, const std::string& token, const std::string& job_id) {
  grpc::ClientContext context;
  with_token(context, token);
  v1::JobRef ref;
  ref.set_job_id(job_id);
  v1::JobStatus status;
  return stub.CancelJob(&context, ref, &status);
}

// Watch to the end; the result bytes in *result when given.
inline grpc::Status watch_as(v1::RemeshService::Stub& stub, const std::string& token, const std::string& job_id,
                             std::string* result = nullptr) {
  grpc::ClientContext context;
  with_token(context, token);
  context.set_deadline(std::chrono::system_clock::now() + kJobLimit);
  v1::JobRef ref;
  ref.set_job_id(job_id);
  auto reader = stub.Watch(&context, ref);
  v1::JobEvent event;
  while (reader->Read(&event))
    if (result && event.has_result()) *result += event.result().data();
  return reader->Finish();
}

inline grpc::Status submit_as(v1::RemeshService::Stub& stub, const std::string& token, const v1::JobSpec& spec,
                              const std::vector<uint8_t>& bytes, std::string* job_id) {
  grpc::ClientContext context;
  with_token(context, token);
  v1::JobRef ref;
  auto writer = stub.Submit(&context, &ref);
  upload(*writer, spec, bytes);
  grpc::Status status = writer->Finish();
  *job_id = ref.job_id();
  return status;
}

// A stub on a connection of its own (gRPC shares connections between
// channels with equal arguments unless each keeps its own subchannel pool):
// a client that opens a new connection for every call.
inline std::unique_ptr<v1::RemeshService::Stub> make_own_connection_stub(const std::string& address) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(8 << 20);
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  return v1::RemeshService::NewStub(grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args));
}

}  // namespace vpr::testing
