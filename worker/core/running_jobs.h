// How many pipeline jobs run at once on this host. Loops whose processor
// time grows with the number of ways they are split (core/vertex_ranges.h:
// each range rereads the whole loop) split in proportion to their job's share
// of the threads, so that eight jobs on sixteen cores do not each pay for
// eight rereads. Jobs in this process count themselves (RunningJob); a job
// process of the service also reads its server's count of busy job
// processes (count_host_jobs, server/host_job_count.h), since those share
// the host's cores as jobs in one process do. Only how work is split depends
// on it, never a result.
#pragma once

#include <algorithm>
#include <atomic>

namespace vpr {

inline std::atomic<int>& running_jobs_counter() {
  static std::atomic<int> count{0};
  return count;
}

// The count of jobs running in all of the host's job processes, where this
// process is one of them (null otherwise).
inline std::atomic<const std::atomic<int>*>& host_jobs_counter() {
  static std::atomic<const std::atomic<int>*> host{nullptr};
  return host;
}

// From now on, running_jobs() also reads `host` (which must outlive the
// process's loops; null stops reading it).
inline void count_host_jobs(const std::atomic<int>* host) {
  host_jobs_counter().store(host, std::memory_order_release);
}

// Jobs running now, at least one (a loop outside any job counts as one).
inline int running_jobs() {
  int jobs = running_jobs_counter().load(std::memory_order_relaxed);
  if (const std::atomic<int>* host = host_jobs_counter().load(std::memory_order_acquire))
    jobs = std::max(jobs, host->load(std::memory_order_relaxed));
  return std::max(1, jobs);
}

// Counts one job for as long as it lives.
class RunningJob {
 public:
  RunningJob() { running_jobs_counter().fetch_add(1, std::memory_order_relaxed); }
  ~RunningJob() { running_jobs_counter().fetch_sub(1, std::memory_order_relaxed); }
  RunningJob(const RunningJob&) = delete;
  RunningJob& operator=(const RunningJob&) = delete;
};

}  // namespace vpr
