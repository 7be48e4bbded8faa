// JobQueue in this process: a priority queue of waiting jobs, each job's
// event history in memory, finished jobs kept for the result retention time.
#pragma once

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <tuple>

#include "server/job_queue.h"
#include "server/limits.h"

namespace vpr::service {

struct EmbeddedQueueOptions {
  ServerLimits limits;                                             // max_queue and max_jobs_per_client apply here
  std::chrono::milliseconds result_ttl{std::chrono::minutes(10)};  // --result-ttl
  std::function<Clock::time_point()> now;                          // null: Clock::now (tests pass a fake)
  // Called on every state change (on the changing thread, no lock held):
  // metrics count jobs by state here.
  std::function<void(const std::string& job_id, v1::JobState state)> on_state;
};

class EmbeddedQueue final : public JobQueue {
 public:
  explicit EmbeddedQueue(EmbeddedQueueOptions options);
  ~EmbeddedQueue() override;

  StatusOr<std::string> submit(JobSubmission job) override;
  std::optional<ClaimedJob> claim(const std::string& worker) override;
  void publish(const std::string& job_id, v1::JobEvent event) override;
  std::optional<Status> cancellation(const std::string& job_id) override;
  StatusOr<v1::JobStatus> cancel(const std::string& job_id, const Status& reason) override;
  StatusOr<v1::JobStatus> status(const std::string& job_id) override;
  Status check_owner(const std::string& job_id, const std::string& tenant) override;
  StatusOr<EventBatch> events(const std::string& job_id, uint64_t from, size_t max_events) override;
  StatusOr<uint64_t> subscribe(const std::string& job_id, Listener listener) override;
  void unsubscribe(const std::string& job_id, uint64_t token) override;
  size_t drain(const Status& reason) override;
  void close() override;
  size_t expire() override;
  QueueStats stats() override;

 private:
  using Slot = ListenerSlot;
  // (-priority, submission order): the set's first entry runs next.
  using Key = std::tuple<int, uint64_t>;
  struct Record {
    std::string id, tenant, client, label;
    v1::JobSpec spec;
    std::vector<uint8_t> mesh;  // until claimed or cancelled
    Key key{};
    v1::JobState state = v1::JOB_STATE_QUEUED;
    std::vector<v1::JobEvent> events;
    std::map<uint64_t, std::shared_ptr<Slot>> listeners;
    std::string worker, current_stage;
    std::optional<Status> cancel_reason;
    Clock::time_point submitted, finished;
    int64_t submitted_unix_ms = 0;
  };

  Clock::time_point now() const;
  std::string new_id();
  Status not_found(const std::string& job_id) const;
  uint32_t position_locked(const Record& r) const;
  v1::JobStatus status_locked(const Record& r) const;
  // Appends under mu_; returns the listeners to call and the state change.
  std::vector<std::shared_ptr<Slot>> append_locked(Record& r, v1::JobEvent event, bool* state_changed);
  void notify(const std::string& job_id, v1::JobState state, bool state_changed,
              const std::vector<std::shared_ptr<Slot>>& slots);

  EmbeddedQueueOptions options_;
  std::mutex mu_;
  std::condition_variable claimable_;
  std::map<std::string, std::unique_ptr<Record>> jobs_;
  std::map<Key, Record*> waiting_;
  std::map<std::string, size_t> unfinished_by_client_;
  uint64_t next_order_ = 0, next_token_ = 1;
  bool draining_ = false, closed_ = false;
  uint64_t id_salt_ = 0;
};

}  // namespace vpr::service
