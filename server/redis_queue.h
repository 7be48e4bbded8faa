// JobQueue on Redis Streams, for many servers and many worker hosts
// (docs/scaling.md). Servers submit, cancel and watch; workers
// (vpremesh-worker) claim through a consumer group, publish events and finish
// jobs. The state changes are Lua scripts (server/redis_scripts.h).
//
// Delivery is at least once: a worker keeps its job's stream entry alive
// with heartbeats; when they stop (the worker died) another worker reclaims
// the entry after the visibility timeout (XAUTOCLAIM) and runs the job again.
// After max_deliveries runs the job fails to the dead-letter stream. A
// worker's result payloads are held in its memory and written with the
// `completed` event in one script, so a job never has two answers.
#pragma once

#include <atomic>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include "server/blob_store.h"
#include "server/job_queue.h"
#include "server/limits.h"
#include "server/redis_client.h"

namespace vpr::service {

struct RedisQueueOptions {
  RedisEndpoint endpoint;
  ServerLimits limits;                                               // max_queue, max_jobs_per_client
  std::chrono::milliseconds result_ttl{std::chrono::minutes(10)};    // a finished job's keys live this long
  std::chrono::milliseconds upload_ttl{std::chrono::hours(24)};      // an upload waits this long for a worker
  std::chrono::milliseconds visibility_timeout{std::chrono::seconds(60)};  // silent this long: reclaimed
  std::chrono::milliseconds heartbeat{std::chrono::seconds(10)};     // a running job's keep-alive period
  int max_deliveries = 3;                                            // then the dead-letter stream
  uint64_t max_result_bytes = uint64_t(256) << 20;                   // payload events of one job
  std::string prefix = "vpremesh:";
  // Where uploads go; null: Redis itself (RedisBlobStore).
  std::shared_ptr<BlobStore> blobs;
  // Called when a job this process ended changes state (metrics).
  std::function<void(const std::string& job_id, v1::JobState state)> on_state;
};

class RedisQueue final : public JobQueue {
 public:
  explicit RedisQueue(RedisQueueOptions options);
  ~RedisQueue() override;

  StatusOr<std::string> submit(JobSubmission job) override;
  std::optional<ClaimedJob> claim(const std::string& worker) override;
  void publish(const std::string& job_id, v1::JobEvent event) override;
  void fail_crashed(const std::string& job_id, const Status& why) override;
  std::optional<Status> cancellation(const std::string& job_id) override;
  StatusOr<v1::JobStatus> cancel(const std::string& job_id, const Status& reason) override;
  StatusOr<v1::JobStatus> status(const std::string& job_id) override;
  Status check_owner(const std::string& job_id, const std::string& tenant) override;
  StatusOr<EventBatch> events(const std::string& job_id, uint64_t from, size_t max_events) override;
  StatusOr<uint64_t> subscribe(const std::string& job_id, Listener listener) override;
  void unsubscribe(const std::string& job_id, uint64_t token) override;
  // Only this server stops accepting jobs: the queue is shared, so waiting
  // jobs stay for the other replicas' workers. Returns 0.
  size_t drain(const Status& reason) override;
  void close() override;
  size_t expire() override { return 0; }  // Redis expires finished jobs itself
  QueueStats stats() override;
  Status health() override;

  const std::string& dead_letter_stream() const { return dead_key_; }

 private:
  // A job this process runs.
  struct Held {
    std::string token, consumer;
    std::vector<std::string> payload;  // result events, written with `completed`
    uint64_t payload_bytes = 0;
    bool lost = false;  // another worker owns it now
  };
  using Slot = ListenerSlot;
  struct Watched {
    std::string last_id = "0-0";
    std::map<uint64_t, std::shared_ptr<Slot>> slots;
  };

  std::string key(const std::string& kind, const std::string& id) const { return options_.prefix + kind + id; }
  Status ensure_groups();
  Status not_found(const std::string& job_id) const;
  // Runs a script; recreates the consumer groups once if Redis lost them.
  StatusOr<RedisReply> run(const char* script, const std::vector<std::string>& keys,
                           const std::vector<std::string_view>& args);
  bool finish(const std::string& job_id, const std::string& token, v1::JobState state,
              const std::vector<std::string>& events, const std::string& dead_reason, const std::string& worker);
  void fail_dead(const std::string& job_id, const std::string& token, const std::string& deliveries,
                 const std::string& worker);
  void wait_for_work(const std::string& last_id);
  // Sleeps 100 ms doubling to 5 s; wakes early on close() when until_close.
  void backoff(const Status& why, int* attempt, bool until_close = true);
  void watch_loop();
  void heartbeat_loop();
  // Renews this process's consumers in the worker registry and removes
  // killed workers' consumers from the group (lua::kAlive). Called every
  // heartbeat, and when a consumer first claims or a job starts or ends, so
  // the busy count is current.
  void renew_registration();
  void start_heartbeats();

  RedisQueueOptions options_;
  RedisClient client_;
  std::vector<std::string> streams_;  // highest priority first
  std::string clients_key_, finished_key_, dead_key_, doorbell_key_, wake_key_, workers_key_, busy_key_;
  std::shared_ptr<BlobStore> blobs_;
  std::atomic<bool> groups_ready_{false}, draining_{false}, closed_{false}, stopping_{false};

  std::mutex held_mu_;
  std::map<std::string, Held> held_;
  std::set<std::string> consumers_;  // names this process claimed with
  // One registration at a time, snapshot and write together: the heartbeat
  // thread's write of an older snapshot (busy 0) could otherwise land after
  // a claim's (busy 1) and leave the fleet's busy count wrong until the next
  // heartbeat.
  std::mutex registration_mu_;

  std::mutex watch_mu_;
  std::condition_variable watch_cv_;
  std::map<std::string, Watched> watched_;
  uint64_t next_token_ = 1;
  std::thread watcher_, heartbeats_;
  std::condition_variable stop_cv_;
  std::mutex stop_mu_;
};

}  // namespace vpr::service
