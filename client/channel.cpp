#include "channel.h"

#include "channel_security.h"

#include <grpc/support/time.h>

namespace vpr::cli {
namespace {

// The uploads only: the server answers them with headers at once, so what
// gRPC retries is a transport failure before the server could accept the
// upload. GetJob, CancelJob and Watch are not retried here: an UNAVAILABLE
// from them moves on to the next replica (job_commands.cpp, job_follower.cpp).
// maxAttempts counts the first; the backoff grows from 0.1 s to at most 1 s.
constexpr const char* kServiceConfig = R"({
  "methodConfig": [{
    "name": [{"service": "vpremesh.v1.RemeshService", "method": "Remesh"},
             {"service": "vpremesh.v1.RemeshService", "method": "Submit"}],
    "retryPolicy": {
      "maxAttempts": 5,
      "initialBackoff": "0.1s",
      "maxBackoff": "1s",
      "backoffMultiplier": 2,
      "retryableStatusCodes": ["UNAVAILABLE"]
    }
  }]
})";

}  // namespace

std::shared_ptr<grpc::Channel> make_channel(const std::string& server, Connection connection) {
  grpc::ChannelArguments args;
  // Chunks are at most 1 MiB of payload; leave room for the envelope.
  args.SetMaxReceiveMessageSize(8 << 20);
  args.SetMaxSendMessageSize(8 << 20);
  // gRPC's default reconnect backoff starts at 1 s and grows to 120 s: a
  // connection attempt that fails once would hold every call for a second,
  // and a single replica that restarts would stay unreachable long after it
  // is back, while --reattach-timeout waits for it.
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 2000);
  args.SetInt(GRPC_ARG_ENABLE_RETRIES, 1);
  args.SetServiceConfigJSON(kServiceConfig);
  if (connection == Connection::kOwn) args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  return secure_channel(server, args);  // TLS and the tenant's token, when the command was given them
}

bool wait_for_server(grpc::Channel& channel, grpc::ClientContext& context) {
  const bool has_deadline = context.raw_deadline().tv_sec != gpr_inf_future(GPR_CLOCK_REALTIME).tv_sec;
  if (!has_deadline && !channel.WaitForConnected(std::chrono::system_clock::now() + kConnectWaitWithoutDeadline))
    return false;  // the call fails at once, with gRPC's reason
  context.set_wait_for_ready(true);
  return true;
}

}  // namespace vpr::cli
