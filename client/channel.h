// Channels to a vpremesh-server, made in one place: every command's calls
// depend on the same arguments (message sizes, reconnect backoff) and on the
// same retry policy.
//
// Retries: gRPC re-sends a call that failed UNAVAILABLE only until the call
// is committed, which happens when the first response headers or message
// arrive (or when its sent messages pass the retry buffer, 256 KiB). The
// server sends its headers as soon as a Remesh or Submit stream opens, and
// upload() half-closes only after they arrived; the server accepts an upload
// only at the half-close, so an upload it may have accepted is never sent
// again. Only Remesh and Submit have the retry policy (channel.cpp says why).
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <string>

namespace vpr::cli {

enum class Connection {
  kShared,  // gRPC's global subchannel pool: channels to one address share a connection
  kOwn,     // a connection of this channel's own (bench: one per client)
};

// A channel to `server` (host:port; with TLS and the bearer token when the
// command has them: channel_security.h) whose messages may be as large as our chunks need, which
// reconnects within 2 s of a restarted server coming back, and whose calls
// are retried on UNAVAILABLE before they are committed (see above).
std::shared_ptr<grpc::Channel> make_channel(const std::string& server, Connection connection = Connection::kShared);

// How long the first call of a command with no --deadline waits for the
// server to accept a connection before it fails UNAVAILABLE.
inline constexpr std::chrono::seconds kConnectWaitWithoutDeadline{30};

// Sets the call to wait for the channel to be ready (through failed connection
// attempts, which gRPC repeats with backoff) instead of failing at once, for
// the first call of a command: a server that starts a moment after the client
// or a connection attempt that fails once must not fail the command. Bounded
// by the call's deadline; a call without one first waits here for the channel
// to connect, up to kConnectWaitWithoutDeadline, and only then waits for
// ready (without a deadline it would wait for ever). False when it did not
// connect within that wait: the call then fails at once with gRPC's reason.
bool wait_for_server(grpc::Channel& channel, grpc::ClientContext& context);

}  // namespace vpr::cli
