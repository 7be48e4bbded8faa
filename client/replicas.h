// The servers a command may use (--server, one or more replicas that serve
// the same jobs) and the command's deadline, which every call to any of them
// shares: a command that moves to another replica does not get more time.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "vpremesh/v1/remesh.grpc.pb.h"

namespace vpr::cli {

class Replicas {
 public:
  using Clock = std::chrono::system_clock;  // gRPC deadlines are on this clock

  // deadline_s: from now, for the whole command (0 or less: none).
  Replicas(std::vector<std::string> addresses, double deadline_s);

  size_t size() const { return addresses_.size(); }
  // Indices wrap around, so that `i + 1` is the next replica, round robin.
  const std::string& address(size_t i) const { return addresses_[i % size()]; }
  // One channel per address, made when first used and kept: gRPC reconnects
  // it (soon: make_channel caps its reconnect backoff) when the server is back.
  vpremesh::v1::RemeshService::Stub& stub(size_t i);

  void set_deadline(grpc::ClientContext& context) const;
  // For the first call of a command, to replica i: with one server the call
  // waits for it to accept a connection (wait_for_server in channel.h), so a
  // server that comes up a moment late, or a connection attempt that fails
  // once, does not fail the command. With several, an unreachable one is
  // passed over instead (first_reachable, the re-attach round robin).
  void wait_for_single_server(size_t i, grpc::ClientContext& context);
  bool has_deadline() const { return has_deadline_; }
  Clock::time_point deadline() const { return deadline_; }
  bool past_deadline() const { return has_deadline_ && Clock::now() >= deadline_; }

  // Where an upload goes: the first replica in list order that accepts a
  // connection within a few seconds, so that one that is down is passed over
  // before any byte is sent (an upload that started is never sent again: it
  // could run the job twice). With one address, or when none connects, 0:
  // the call then reports its own error, as with a single server. Prints a
  // line on stderr for each replica passed over.
  size_t first_reachable();

 private:
  std::vector<std::string> addresses_;
  std::vector<std::shared_ptr<grpc::Channel>> channels_;
  std::vector<std::unique_ptr<vpremesh::v1::RemeshService::Stub>> stubs_;
  bool has_deadline_ = false;
  Clock::time_point deadline_;
};

}  // namespace vpr::cli
