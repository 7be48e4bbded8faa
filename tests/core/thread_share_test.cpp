// TBB's threads shared out among the jobs on a host (core/thread_share.h):
// a job process gets its share of the cores, a process running several jobs
// on threads of their own leaves their threads a core each; a cap lasts as
// long as its ThreadCap, and a job whose cap is already its share splits its
// loops by that share, not by its share of the share.
#include "core/thread_share.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <atomic>

#include "core/running_jobs.h"
#include "core/vertex_ranges.h"

namespace vpr {
namespace {

size_t active_cap() {
  return tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
}

TEST(ThreadShare, AJobProcessGetsItsShareOfTheCores) {
  EXPECT_EQ(one_job_process_threads(16, 1), 16u);
  EXPECT_EQ(one_job_process_threads(16, 4), 4u);
  EXPECT_EQ(one_job_process_threads(16, 3), 5u);
  EXPECT_EQ(one_job_process_threads(16, 16), 1u);
  EXPECT_EQ(one_job_process_threads(16, 40), 1u) << "at least one";
  EXPECT_EQ(one_job_process_threads(2, 0), 2u) << "no count: the job alone";
}

TEST(ThreadShare, JobsOnThreadsOfTheirOwnLeaveThemACoreEach) {
  EXPECT_EQ(shared_process_threads(16, 1), 16u) << "one job: every core";
  EXPECT_EQ(shared_process_threads(16, 0), 16u);
  EXPECT_EQ(shared_process_threads(16, 8), 9u) << "eight jobs' threads and eight workers";
  EXPECT_EQ(shared_process_threads(16, 2), 15u);
  EXPECT_EQ(shared_process_threads(16, 16), 1u) << "no worker: the jobs' threads fill the cores";
  EXPECT_EQ(shared_process_threads(2, 5), 1u);
}

TEST(ThreadShare, ACapLastsAsLongAsItsObjectAndNoneAtTheCores) {
  tbb::task_arena sixteen(16);
  sixteen.execute([] {
    ASSERT_EQ(host_threads(), 16u);
    const size_t before = active_cap();
    {
      const ThreadCap cap(3);
      EXPECT_EQ(active_cap(), 3u);
      EXPECT_LE(job_threads(), 3u);
    }
    EXPECT_EQ(active_cap(), before);
    {
      const ThreadCap none(16);
      EXPECT_EQ(active_cap(), before) << "a cap at the host's threads sets nothing";
    }
  });
}

// A job process among four on a 16-core host: capped at 4 threads, its loops
// split four ways (its share), not one (a quarter of its share).
TEST(ThreadShare, AJobCappedAtItsShareSplitsByThatShare) {
  std::atomic<int> host{4};
  count_host_jobs(&host);
  tbb::task_arena sixteen(16);
  sixteen.execute([] {
    const RunningJob job;
    const ThreadCap share(one_job_process_threads(host_threads(), running_jobs()));
    EXPECT_EQ(active_cap(), 4u);
    EXPECT_EQ(job_threads(), 4u);
    std::atomic<int> ranges{0};
    in_vertex_ranges(400000, [&](uint32_t, uint32_t) { ++ranges; });
    EXPECT_EQ(ranges.load(), 4);
  });
  count_host_jobs(nullptr);
}

}  // namespace
}  // namespace vpr
