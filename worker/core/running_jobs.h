// How many pipeline jobs this process runs at once. Loops whose processor
// time grows with the number of ways they are split (core/vertex_ranges.h:
// each range rereads the whole loop) split in proportion to their job's share
// of the threads, so that eight jobs on sixteen cores do not each pay for
// eight rereads. Only how work is split depends on it, never a result.
#pragma once

#include <algorithm>
#include <atomic>

namespace vpr {

inline std::atomic<int>& running_jobs_counter() {
  static std::atomic<int> count{0};
  return count;
}

// Jobs running now, at least one (a loop outside any job counts as one).
inline int running_jobs() {
  return std::max(1, running_jobs_counter().load(std::memory_order_relaxed));
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
