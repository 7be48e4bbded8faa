// The queue between the RPCs and the workers. The RPC code (remesh_service)
// and the workers (worker_pool) see only this interface: EmbeddedQueue keeps
// everything in this process; RedisQueue (one stream of jobs per priority,
// one stream of events per job) implements the same calls for many hosts.
//
// A job's events are its history: every state change is an event, stored in
// order with sequence numbers 0, 1, 2, ..., so Watch replays them from 0 and
// then follows the live ones. The job's state follows from its events
// (queued, started, completed / failed / cancelled).
#pragma once

#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/status.h"
#include "server/job.h"
#include "server/status_mapping.h"

namespace vpr::service {

struct EventBatch {
  std::vector<v1::JobEvent> events;  // consecutive sequence numbers from the requested one
  bool ended = false;                // the job's last event is in `events` or before it
};

// One subscriber's listener, as both queues hold it: called on the
// publishing thread; close() returns only when no call is running and makes
// later calls no-ops, so unsubscribe can return while another thread
// publishes.
class ListenerSlot {
 public:
  explicit ListenerSlot(std::function<void()> fn) : fn_(std::move(fn)) {}
  void call() {
    std::lock_guard<std::recursive_mutex> lock(mu_);
    if (active_) fn_();
  }
  void close() {
    std::lock_guard<std::recursive_mutex> lock(mu_);  // waits for a call in progress
    active_ = false;
  }

 private:
  std::recursive_mutex mu_;  // recursive: a listener may unsubscribe itself
  bool active_ = true;
  std::function<void()> fn_;
};

class JobQueue {
 public:
  using Listener = std::function<void()>;
  virtual ~JobQueue() = default;

  // Stores the job, queues it by priority then submission order and records
  // its `queued` event. Returns the job id. RESOURCE_EXHAUSTED when the queue
  // or the client's share is full; UNAVAILABLE while draining. Every message
  // names the limit.
  virtual StatusOr<std::string> submit(JobSubmission job) = 0;

  // Blocks until a job is waiting (highest priority, then oldest) and marks
  // it running; nullopt once the queue is closed.
  virtual std::optional<ClaimedJob> claim(const std::string& worker) = 0;

  // Appends an event to the job's history (job_id and sequence are set here)
  // and wakes its subscribers. `started` marks the job running on
  // `started.worker`; completed / failed / cancelled end it.
  virtual void publish(const std::string& job_id, v1::JobEvent event) = 0;

  // Ends a running job whose process died on it (server/job_process.h):
  // its `failed` event with `why`, which names the signal and the stage. A
  // shared queue also records the job in its dead-letter stream with `why`
  // and does not deliver it again: the crash is the job's own, and the same
  // input would crash the next worker.
  virtual void fail_crashed(const std::string& job_id, const Status& why) {
    v1::JobEvent e;
    *e.mutable_failed() = to_failure(why);
    publish(job_id, std::move(e));
  }

  // Why a running job must stop (cancelled, deadline, shutdown), or nullopt.
  // The worker's PipelineOptions::keep_going asks this at stage boundaries.
  virtual std::optional<Status> cancellation(const std::string& job_id) = 0;

  // Cancels a queued job at once (its memory is freed and its `cancelled`
  // event recorded) or asks a running one to stop; a finished job is left
  // as it is. Returns the job's status after the request. NOT_FOUND names
  // the result retention time.
  virtual StatusOr<v1::JobStatus> cancel(const std::string& job_id, const Status& reason) = 0;

  virtual StatusOr<v1::JobStatus> status(const std::string& job_id) = 0;

  // OK when the job exists and belongs to `tenant` (the one that submitted
  // it; "" without authentication). Another tenant's job is NOT_FOUND with
  // the very message of an unknown id, so that a guessed id is not
  // confirmed.
  virtual Status check_owner(const std::string& job_id, const std::string& tenant) = 0;

  // Up to max_events events from sequence `from` on, without blocking.
  virtual StatusOr<EventBatch> events(const std::string& job_id, uint64_t from, size_t max_events) = 0;

  // Calls `listener` (on the publishing thread, with no queue lock held)
  // after every new event of the job. Returns a token for unsubscribe.
  virtual StatusOr<uint64_t> subscribe(const std::string& job_id, Listener listener) = 0;
  // After it returns, the listener is not running and will not be called.
  virtual void unsubscribe(const std::string& job_id, uint64_t token) = 0;

  // Draining: refuses new jobs from now on and fails every waiting one with
  // `reason` (recorded as its `failed` event). Returns how many it failed.
  virtual size_t drain(const Status& reason) = 0;
  // Makes claim() return nullopt, now and later.
  virtual void close() = 0;

  // Forgets finished jobs whose result retention time has passed; returns
  // how many.
  virtual size_t expire() = 0;

  virtual QueueStats stats() = 0;

  // Whether the queue's store can be reached (health checks). UNAVAILABLE
  // names the store and why.
  virtual Status health() { return Status::Ok(); }
};

}  // namespace vpr::service
