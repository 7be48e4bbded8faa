#include "replicas.h"

#include <algorithm>
#include <cstdio>

#include "channel.h"

namespace vpr::cli {
namespace {

// Long enough for any live server to accept a connection, short enough that
// a replica whose host is gone does not hold the upload for long.
constexpr std::chrono::seconds kConnectWait{5};

// True when the channel reaches READY before `until`; false as soon as it
// fails to connect.
bool connects(grpc::Channel& channel, Replicas::Clock::time_point until) {
  grpc_connectivity_state state = channel.GetState(/*try_to_connect=*/true);
  while (state != GRPC_CHANNEL_READY) {
    if (state == GRPC_CHANNEL_TRANSIENT_FAILURE || state == GRPC_CHANNEL_SHUTDOWN) return false;
    if (!channel.WaitForStateChange(state, until)) return false;
    state = channel.GetState(true);
  }
  return true;
}

}  // namespace

Replicas::Replicas(std::vector<std::string> addresses, double deadline_s)
    : addresses_(std::move(addresses)), channels_(addresses_.size()), stubs_(addresses_.size()) {
  if (deadline_s > 0) {
    has_deadline_ = true;
    deadline_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(deadline_s));
  }
}

vpremesh::v1::RemeshService::Stub& Replicas::stub(size_t i) {
  i %= size();
  if (!stubs_[i]) {
    channels_[i] = make_channel(addresses_[i]);
    stubs_[i] = vpremesh::v1::RemeshService::NewStub(channels_[i]);
  }
  return *stubs_[i];
}

void Replicas::set_deadline(grpc::ClientContext& context) const {
  if (has_deadline_) context.set_deadline(deadline_);
}

void Replicas::wait_for_single_server(size_t i, grpc::ClientContext& context) {
  if (size() != 1) return;
  stub(i);  // makes the channel
  wait_for_server(*channels_[i % size()], context);
}

size_t Replicas::first_reachable() {
  if (size() == 1) return 0;
  for (size_t i = 0; i < size(); ++i) {
    stub(i);  // makes the channel
    auto until = Clock::now() + kConnectWait;
    if (has_deadline_) until = std::min(until, deadline_);
    if (connects(*channels_[i], until)) return i;
    if (i + 1 < size())
      std::fprintf(stderr, "vpremesh: %s does not accept connections; trying %s\n", addresses_[i].c_str(),
                   addresses_[i + 1].c_str());
  }
  return 0;
}

}  // namespace vpr::cli
