// A job as it travels between the RPCs, the queue and the workers. Only the
// spec and the uploaded bytes: what a queue on another host (Redis Streams)
// can store as it is.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vpremesh/v1/remesh.pb.h"

namespace vpr::service {

namespace v1 = ::vpremesh::v1;

using Clock = std::chrono::steady_clock;

// What Remesh and Submit hand to JobQueue::submit, after validating the spec.
struct JobSubmission {
  v1::JobSpec spec;
  std::vector<uint8_t> mesh;  // the Draco file, whole
  // Who submitted it (server/authenticator.h): the owning tenant ("" without
  // --auth-tokens), the key --max-jobs-per-client counts under, and that
  // client's limit (0: --max-jobs-per-client).
  std::string tenant;
  std::string client;
  size_t max_jobs = 0;
};

// What JobQueue::claim hands to a worker. The queue gives up the mesh bytes
// with it, so a job's upload lives in exactly one place.
struct ClaimedJob {
  std::string id;
  v1::JobSpec spec;
  std::vector<uint8_t> mesh;
  double queue_ms = 0;  // submission to claim
};

// Jobs by state, for metrics and health.
struct QueueStats {
  size_t queued = 0, running = 0, succeeded = 0, failed = 0, cancelled = 0;  // jobs held now
  // Worker threads on every host that share the queue, and those running a
  // job; only a shared queue (Redis) knows them.
  std::optional<size_t> fleet_workers, fleet_busy;
};

inline bool is_terminal(const v1::JobEvent& e) {
  return e.has_completed() || e.has_failed() || e.has_cancelled();
}

inline const char* state_name(v1::JobState s) {
  switch (s) {
    case v1::JOB_STATE_QUEUED:
      return "queued";
    case v1::JOB_STATE_RUNNING:
      return "running";
    case v1::JOB_STATE_SUCCEEDED:
      return "succeeded";
    case v1::JOB_STATE_FAILED:
      return "failed";
    case v1::JOB_STATE_CANCELLED:
      return "cancelled";
    default:
      return "unspecified";
  }
}

}  // namespace vpr::service
