#include "server/embedded_queue.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <random>

#include "server/status_mapping.h"

namespace vpr::service {

EmbeddedQueue::EmbeddedQueue(EmbeddedQueueOptions options) : options_(std::move(options)) {
  std::random_device rd;
  id_salt_ = (uint64_t(rd()) << 32) ^ rd();
}

EmbeddedQueue::~EmbeddedQueue() {
  close();
}

Clock::time_point EmbeddedQueue::now() const {
  return options_.now ? options_.now() : Clock::now();
}

std::string EmbeddedQueue::new_id() {
  // splitmix64 of a per-process salt and a counter: unique here, unguessable
  // enough that ids of other clients' jobs are not sequential.
  uint64_t z = id_salt_ + 0x9E3779B97F4A7C15ull * (next_order_ + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  char buf[24];
  std::snprintf(buf, sizeof buf, "j-%016llx", static_cast<unsigned long long>(z));
  return buf;
}

Status EmbeddedQueue::not_found(const std::string& job_id) const {
  const auto ttl = std::chrono::duration_cast<std::chrono::seconds>(options_.result_ttl).count();
  return vpr::not_found("job '" + job_id + "' not found: unknown, or finished more than " + std::to_string(ttl) +
                        " s ago (--result-ttl " + std::to_string(ttl) + ")");
}

uint32_t EmbeddedQueue::position_locked(const Record& r) const {
  auto it = waiting_.find(r.key);
  return it == waiting_.end() ? 0 : uint32_t(std::distance(waiting_.begin(), it));
}

v1::JobStatus EmbeddedQueue::status_locked(const Record& r) const {
  v1::JobStatus s;
  s.set_job_id(r.id);
  s.set_state(r.state);
  if (r.state == v1::JOB_STATE_QUEUED) s.set_queue_position(position_locked(r));
  s.set_worker(r.worker);
  if (r.state == v1::JOB_STATE_RUNNING) s.set_current_stage(r.current_stage);
  s.set_submitted_unix_ms(r.submitted_unix_ms);
  if (!r.events.empty()) {
    const v1::JobEvent& last = r.events.back();
    if (last.has_completed()) *s.mutable_summary() = last.completed();
    if (last.has_failed()) *s.mutable_failure() = last.failed();
    if (last.has_cancelled()) *s.mutable_failure() = last.cancelled();
  }
  return s;
}

std::vector<std::shared_ptr<EmbeddedQueue::Slot>> EmbeddedQueue::append_locked(Record& r, v1::JobEvent event,
                                                                               bool* state_changed) {
  *state_changed = false;
  if (r.state == v1::JOB_STATE_SUCCEEDED || r.state == v1::JOB_STATE_FAILED || r.state == v1::JOB_STATE_CANCELLED) {
    spdlog::warn("job {}: event after the job ended, dropped", r.id);
    return {};
  }
  event.set_job_id(r.id);
  event.set_sequence(r.events.size());
  if (event.has_started()) r.worker = event.started().worker();
  if (event.has_stage()) r.current_stage = event.stage().name();
  v1::JobState next = r.state;
  if (event.has_completed()) next = v1::JOB_STATE_SUCCEEDED;
  if (event.has_failed()) next = v1::JOB_STATE_FAILED;
  if (event.has_cancelled()) next = v1::JOB_STATE_CANCELLED;
  if (next != r.state) {
    if (r.state == v1::JOB_STATE_QUEUED) waiting_.erase(r.key);
    r.state = next;
    r.finished = now();
    r.mesh = {};
    r.mesh.shrink_to_fit();
    auto it = unfinished_by_client_.find(r.client);
    if (it != unfinished_by_client_.end() && --it->second == 0) unfinished_by_client_.erase(it);
    *state_changed = true;
  }
  r.events.push_back(std::move(event));
  std::vector<std::shared_ptr<Slot>> slots;
  for (auto& [token, slot] : r.listeners) slots.push_back(slot);
  return slots;
}

void EmbeddedQueue::notify(const std::string& job_id, v1::JobState state, bool state_changed,
                           const std::vector<std::shared_ptr<Slot>>& slots) {
  if (state_changed && options_.on_state) options_.on_state(job_id, state);
  for (const auto& slot : slots) {
    slot->call();
  }
}

StatusOr<std::string> EmbeddedQueue::submit(JobSubmission job) {
  std::string id;
  uint32_t position = 0;
  std::vector<std::shared_ptr<Slot>> slots;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (draining_ || closed_)
      return unavailable("the server is shutting down and accepts no new jobs; retry elsewhere");
    VPR_RETURN_IF_ERROR(check_queue_length(options_.limits, waiting_.size()));
    auto client = unfinished_by_client_.find(job.client);
    VPR_RETURN_IF_ERROR(check_client_jobs(client_job_limit(options_.limits, job.max_jobs), job.client,
                                          client == unfinished_by_client_.end() ? 0 : client->second));

    auto r = std::make_unique<Record>();
    id = new_id();
    r->id = id;
    r->tenant = job.tenant;
    r->client = job.client;
    r->label = job.spec.label();
    r->key = {-job.spec.priority(), next_order_++};
    r->spec = std::move(job.spec);
    r->mesh = std::move(job.mesh);
    r->submitted = now();
    r->submitted_unix_ms =
        std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
            .count();
    Record& rec = *r;
    jobs_.emplace(id, std::move(r));
    waiting_.emplace(rec.key, &rec);
    ++unfinished_by_client_[rec.client];
    position = position_locked(rec);
    v1::JobEvent queued;
    queued.mutable_queued()->set_position(position);
    bool changed = false;
    slots = append_locked(rec, std::move(queued), &changed);
    spdlog::info("job {} queued: label '{}', {} bytes, target {} vertices, priority {}, position {}, client {}", id,
                 rec.label, rec.mesh.size(), rec.spec.target_vertices(), rec.spec.priority(), position, rec.client);
  }
  claimable_.notify_one();
  notify(id, v1::JOB_STATE_QUEUED, true, slots);
  return id;
}

std::optional<ClaimedJob> EmbeddedQueue::claim(const std::string& worker) {
  std::unique_lock<std::mutex> lock(mu_);
  claimable_.wait(lock, [&] { return closed_ || !waiting_.empty(); });
  if (closed_) return std::nullopt;
  Record& r = *waiting_.begin()->second;
  waiting_.erase(waiting_.begin());
  r.state = v1::JOB_STATE_RUNNING;
  r.worker = worker;
  r.current_stage = "starting";
  ClaimedJob job;
  job.id = r.id;
  job.spec = r.spec;
  job.mesh = std::move(r.mesh);
  r.mesh = {};
  job.queue_ms = std::chrono::duration<double, std::milli>(now() - r.submitted).count();
  spdlog::info("job {} running on {} after {:.0f} ms in the queue", r.id, worker, job.queue_ms);
  lock.unlock();
  if (options_.on_state) options_.on_state(job.id, v1::JOB_STATE_RUNNING);
  return job;
}

void EmbeddedQueue::publish(const std::string& job_id, v1::JobEvent event) {
  std::vector<std::shared_ptr<Slot>> slots;
  bool changed = false;
  v1::JobState state{};
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = jobs_.find(job_id);
    if (it == jobs_.end()) return;
    Record& r = *it->second;
    const bool terminal = is_terminal(event);
    std::string why;
    if (event.has_failed()) why = event.failed().message();
    if (event.has_cancelled()) why = event.cancelled().message();
    slots = append_locked(r, std::move(event), &changed);
    state = r.state;
    if (changed && terminal) {
      const double total_ms = std::chrono::duration<double, std::milli>(r.finished - r.submitted).count();
      if (why.empty())
        spdlog::info("job {} {} after {:.0f} ms", job_id, state_name(state), total_ms);
      else
        spdlog::info("job {} {} after {:.0f} ms: {}", job_id, state_name(state), total_ms, why);
    }
  }
  notify(job_id, state, changed, slots);
}

std::optional<Status> EmbeddedQueue::cancellation(const std::string& job_id) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = jobs_.find(job_id);
  if (it == jobs_.end()) return Status(StatusCode::kCancelled, "job " + job_id + " was forgotten");
  return it->second->cancel_reason;
}

StatusOr<v1::JobStatus> EmbeddedQueue::cancel(const std::string& job_id, const Status& reason) {
  std::vector<std::shared_ptr<Slot>> slots;
  bool changed = false;
  v1::JobStatus result;
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = jobs_.find(job_id);
    if (it == jobs_.end()) return not_found(job_id);
    Record& r = *it->second;
    if (r.state == v1::JOB_STATE_QUEUED) {
      v1::JobEvent e;
      *e.mutable_cancelled() = to_failure(reason);
      slots = append_locked(r, std::move(e), &changed);
      spdlog::info("job {} cancelled while queued: {}", job_id, reason.message());
    } else if (r.state == v1::JOB_STATE_RUNNING && !r.cancel_reason) {
      r.cancel_reason = reason;
      spdlog::info("job {} cancel requested while running ({}): {}", job_id, r.current_stage, reason.message());
    }
    result = status_locked(r);
  }
  notify(job_id, v1::JOB_STATE_CANCELLED, changed, slots);
  return result;
}

StatusOr<v1::JobStatus> EmbeddedQueue::status(const std::string& job_id) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = jobs_.find(job_id);
  if (it == jobs_.end()) return not_found(job_id);
  return status_locked(*it->second);
}

Status EmbeddedQueue::check_owner(const std::string& job_id, const std::string& tenant) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = jobs_.find(job_id);
  if (it == jobs_.end() || it->second->tenant != tenant) return not_found(job_id);
  return Status::Ok();
}

StatusOr<EventBatch> EmbeddedQueue::events(const std::string& job_id, uint64_t from, size_t max_events) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = jobs_.find(job_id);
  if (it == jobs_.end()) return not_found(job_id);
  const Record& r = *it->second;
  EventBatch batch;
  for (uint64_t i = from; i < r.events.size() && batch.events.size() < max_events; ++i)
    batch.events.push_back(r.events[i]);
  batch.ended = !r.events.empty() && is_terminal(r.events.back()) && from + batch.events.size() >= r.events.size();
  return batch;
}

StatusOr<uint64_t> EmbeddedQueue::subscribe(const std::string& job_id, Listener listener) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = jobs_.find(job_id);
  if (it == jobs_.end()) return not_found(job_id);
  auto slot = std::make_shared<Slot>(std::move(listener));
  const uint64_t token = next_token_++;
  it->second->listeners.emplace(token, std::move(slot));
  return token;
}

void EmbeddedQueue::unsubscribe(const std::string& job_id, uint64_t token) {
  std::shared_ptr<Slot> slot;
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = jobs_.find(job_id);
    if (it == jobs_.end()) return;
    auto s = it->second->listeners.find(token);
    if (s == it->second->listeners.end()) return;
    slot = std::move(s->second);
    it->second->listeners.erase(s);
  }
  slot->close();  // waits for a call in progress
}

size_t EmbeddedQueue::drain(const Status& reason) {
  std::vector<std::pair<std::string, std::vector<std::shared_ptr<Slot>>>> notices;
  {
    std::lock_guard<std::mutex> lock(mu_);
    draining_ = true;
    while (!waiting_.empty()) {
      Record& r = *waiting_.begin()->second;
      v1::JobEvent e;
      *e.mutable_failed() = to_failure(reason);
      bool changed = false;
      notices.emplace_back(r.id, append_locked(r, std::move(e), &changed));  // erases it from waiting_
      spdlog::info("job {} failed while queued: {}", r.id, reason.message());
    }
  }
  for (const auto& [id, slots] : notices) notify(id, v1::JOB_STATE_FAILED, true, slots);
  return notices.size();
}

void EmbeddedQueue::close() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    closed_ = true;
  }
  claimable_.notify_all();
}

size_t EmbeddedQueue::expire() {
  std::lock_guard<std::mutex> lock(mu_);
  const Clock::time_point t = now();
  size_t removed = 0;
  for (auto it = jobs_.begin(); it != jobs_.end();) {
    const Record& r = *it->second;
    const bool finished =
        r.state == v1::JOB_STATE_SUCCEEDED || r.state == v1::JOB_STATE_FAILED || r.state == v1::JOB_STATE_CANCELLED;
    if (finished && t - r.finished >= options_.result_ttl) {
      spdlog::debug("job {} forgotten (result retention time passed)", r.id);
      it = jobs_.erase(it);
      ++removed;
    } else {
      ++it;
    }
  }
  return removed;
}

QueueStats EmbeddedQueue::stats() {
  std::lock_guard<std::mutex> lock(mu_);
  QueueStats s;
  for (const auto& [id, r] : jobs_) {
    switch (r->state) {
      case v1::JOB_STATE_QUEUED:
        ++s.queued;
        break;
      case v1::JOB_STATE_RUNNING:
        ++s.running;
        break;
      case v1::JOB_STATE_SUCCEEDED:
        ++s.succeeded;
        break;
      case v1::JOB_STATE_FAILED:
        ++s.failed;
        break;
      case v1::JOB_STATE_CANCELLED:
        ++s.cancelled;
        break;
      default:
        break;
    }
  }
  return s;
}

}  // namespace vpr::service
