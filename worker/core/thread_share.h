// How many of the host's threads TBB may run for the jobs of this process,
// when several jobs share the host's cores. Each job's own thread (a worker
// thread of the service, a job process's main thread, a benchmark's thread)
// is busy too, so TBB's sixteen workers on top of eight jobs oversubscribe a
// 16-core host: the workers that find no work spin and take the cores the
// jobs' threads want (eight horse jobs at once on an H200 host: 5-8% more
// jobs a second with 8 or 12 threads than with 16; docs/performance.md,
// session 24). Only how work is shared out depends on it, never a result.
#pragma once

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstddef>
#include <optional>

namespace vpr {

// The host's cores as TBB sees them (its affinity mask and cgroup included).
inline size_t host_threads() {
  return size_t(std::max(1, tbb::this_task_arena::max_concurrency()));
}

// TBB's threads for a process that runs one job while `jobs` run on the host
// (a job process of the service, this one's included): its share, at least 1.
inline size_t one_job_process_threads(size_t cores, int jobs) {
  return std::max<size_t>(1, cores / size_t(std::max(1, jobs)));
}

// max_allowed_parallelism for a process whose `jobs` jobs run at once, each
// on a thread of its own: the jobs' threads take `jobs` cores and TBB's
// workers the rest (the parameter counts one calling thread: workers are
// one fewer). All of them when one job runs.
inline size_t shared_process_threads(size_t cores, int jobs) {
  if (jobs <= 1) return cores;
  return cores > size_t(jobs) ? cores - size_t(jobs) + 1 : 1;
}

// Caps this process's TBB threads at `threads` while it lives; no cap at the
// host's threads or more.
class ThreadCap {
 public:
  explicit ThreadCap(size_t threads) {
    if (threads < host_threads()) control_.emplace(tbb::global_control::max_allowed_parallelism, threads);
  }
  ThreadCap(const ThreadCap&) = delete;
  ThreadCap& operator=(const ThreadCap&) = delete;

 private:
  std::optional<tbb::global_control> control_;
};

}  // namespace vpr
