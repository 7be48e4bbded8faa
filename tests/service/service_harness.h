// What the service tests share: the real vpremesh-server started on a free
// loopback port (and always stopped), the real vpremesh client run as a
// process, and uploads through the C++ stubs.
#pragma once

#include <grpcpp/grpcpp.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_runner.h"
#include "io/mesh_io.h"
#include "process_harness.h"
#include "vpremesh/v1/remesh.grpc.pb.h"

namespace vpr::testing {

namespace v1 = ::vpremesh::v1;

// Safety nets only: no test waits on a clock for its answer.
inline constexpr std::chrono::seconds kStartupLimit{120};
inline constexpr std::chrono::seconds kJobLimit{300};

// `vpremesh-server --listen 127.0.0.1:0 FLAGS...`; the address comes from the
// line "vpremesh-server listening on 127.0.0.1:PORT". The destructor kills
// the server if it still runs, so a failing test never leaves one behind.
class ServerProcess {
 public:
  explicit ServerProcess(const std::vector<std::string>& flags, const std::vector<std::string>& env = {})
      : process_(arguments(flags), env) {
    process_.wait_for_output([](const std::string& out) { return !find_address(out).empty(); }, kStartupLimit);
    address_ = find_address(process_.output());
  }

  bool started() const { return !address_.empty(); }
  std::string address() const { return address_; }
  pid_t pid() const { return process_.pid(); }
  // Everything the server printed so far (for failure messages).
  std::string log() const { return process_.output(); }
  // Sends a signal (SIGKILL: a replica that dies); no wait.
  void kill(int signal) { process_.kill(signal); }
  // Waits for the exit (after a kill); the exit code, or -signal.
  int wait() { return process_.wait(kJobLimit); }

  // Sends SIGTERM and waits for the exit; returns the exit code, or -signal
  // when a signal ended it (SIGKILL after the safety limit).
  int terminate() { return process_.terminate(kJobLimit); }

 private:
  static std::vector<std::string> arguments(const std::vector<std::string>& flags) {
    std::vector<std::string> args = {VPR_SERVER_PATH, "--listen", "127.0.0.1:0"};
    args.insert(args.end(), flags.begin(), flags.end());
    return args;
  }
  // "" until the line is complete.
  static std::string find_address(const std::string& log) {
    const std::string key = "listening on ";
    const size_t at = log.find(key);
    if (at == std::string::npos) return "";
    const size_t end = log.find_first_of(" \r\n", at + key.size());
    if (end == std::string::npos) return "";
    return log.substr(at + key.size(), end - at - key.size());
  }

  ChildProcess process_;
  std::string address_;
};

using vpr::testing::CliRun;
using vpr::testing::run_cli;

inline std::unique_ptr<v1::RemeshService::Stub> make_stub(const std::string& address) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(8 << 20);
  return v1::RemeshService::NewStub(grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args));
}

// A lossless, order-keeping Draco file (what `vpremesh submit` uploads).
inline std::vector<uint8_t> lossless_draco(const Mesh& mesh) {
  DracoOptions options;
  options.position_bits = 0;
  options.speed = 10;
  auto bytes = encode_draco(mesh, nullptr, options);
  return bytes.ok() ? std::move(*bytes) : std::vector<uint8_t>{};
}

inline void write_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

inline v1::JobSpec make_spec(uint32_t target, uint64_t size_bytes) {
  v1::JobSpec spec;
  spec.set_target_vertices(target);
  spec.set_mesh_size_bytes(size_bytes);
  spec.set_return_mesh(true);
  spec.set_return_saliency(true);
  return spec;
}

// The spec, then the file in chunks of at most 1 MiB; false when the server
// closed the stream early.
template <class Writer>
bool upload(Writer& writer, const v1::JobSpec& spec, const std::vector<uint8_t>& bytes) {
  v1::RemeshRequest request;
  *request.mutable_spec() = spec;
  if (!writer.Write(request)) return false;
  for (size_t offset = 0; offset < bytes.size(); offset += size_t(1) << 20) {
    request.set_mesh_chunk(bytes.data() + offset, std::min(size_t(1) << 20, bytes.size() - offset));
    if (!writer.Write(request)) return false;
  }
  return writer.WritesDone();
}

// One Remesh call, followed to its end.
struct RemeshOutcome {
  grpc::Status status;
  std::vector<v1::JobEvent> events;
  std::string job_id;
  std::string result;  // the output Draco file
  std::vector<float> saliency;
  const v1::JobEvent* last() const { return events.empty() ? nullptr : &events.back(); }
  bool completed() const { return last() && last()->has_completed(); }
};

// on_event (optional) sees every event as it arrives, e.g. to signal another thread.
template <class OnEvent>
RemeshOutcome remesh(v1::RemeshService::Stub& stub, const v1::JobSpec& spec, const std::vector<uint8_t>& bytes,
                     OnEvent on_event, grpc::ClientContext* context = nullptr) {
  grpc::ClientContext local;
  if (!context) context = &local;
  context->set_deadline(std::chrono::system_clock::now() + kJobLimit);
  RemeshOutcome out;
  auto stream = stub.Remesh(context);
  upload(*stream, spec, bytes);
  v1::JobEvent event;
  while (stream->Read(&event)) {
    if (out.job_id.empty()) out.job_id = event.job_id();
    if (event.has_result()) out.result += event.result().data();
    if (event.has_saliency())
      out.saliency.insert(out.saliency.end(), event.saliency().values().begin(), event.saliency().values().end());
    out.events.push_back(event);
    on_event(event);
  }
  out.status = stream->Finish();
  return out;
}

inline RemeshOutcome remesh(v1::RemeshService::Stub& stub, const v1::JobSpec& spec, const std::vector<uint8_t>& bytes) {
  return remesh(stub, spec, bytes, [](const v1::JobEvent&) {});
}

// GetJob; state UNSPECIFIED when the call fails.
inline v1::JobStatus get_job(v1::RemeshService::Stub& stub, const std::string& job_id) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  v1::JobRef ref;
  ref.set_job_id(job_id);
  v1::JobStatus status;
  if (!stub.GetJob(&context, ref, &status).ok()) status.set_state(v1::JOB_STATE_UNSPECIFIED);
  return status;
}

// Polls GetJob until `done(state)` holds (a state change, not a duration, is
// what the test waits for); false after the safety limit.
template <class Pred>
bool wait_for_state(v1::RemeshService::Stub& stub, const std::string& job_id, Pred done) {
  const auto give_up = std::chrono::steady_clock::now() + kJobLimit;
  while (std::chrono::steady_clock::now() < give_up) {
    if (done(get_job(stub, job_id).state())) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

inline bool is_terminal(v1::JobState s) {
  return s == v1::JOB_STATE_SUCCEEDED || s == v1::JOB_STATE_FAILED || s == v1::JOB_STATE_CANCELLED;
}

// Vertex positions sorted, so that two files of the same mesh compare equal
// whatever order their encoders chose.
inline std::vector<std::array<float, 3>> sorted_positions(const Mesh& mesh) {
  std::vector<std::array<float, 3>> p(mesh.vertex_count());
  for (size_t i = 0; i < p.size(); ++i)
    p[i] = {mesh.positions[3 * i], mesh.positions[3 * i + 1], mesh.positions[3 * i + 2]};
  std::sort(p.begin(), p.end());
  return p;
}

}  // namespace vpr::testing
