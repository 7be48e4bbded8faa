// A serial scatter over faces run by vertex ranges (core/vertex_ranges.h):
// every vertex gets the serial loop's updates in its order, so sums in
// double come out bit for bit the serial loop's, on any thread count.
#include "core/vertex_ranges.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <vector>

#include "scatter_case.h"

namespace vpr {
namespace {

TEST(VertexRanges, ScatteredSumsAreTheSerialLoopsOnAnyThreadCount) {
  // 300,000 "faces" of three pseudo-random vertices among 100,000, each
  // adding a value whose rounding depends on the order of the additions.
  const size_t nv = 100000, nf = 300000;
  const std::vector<uint32_t> corner = testing::random_corners(nv, nf);
  auto value = testing::order_sensitive_value;
  std::vector<double> serial(nv, 0.0);
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) serial[corner[3 * f + k]] += value(f);
  for (int threads : {1, 2, 3, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<double> sum(nv, 0.0);
    std::atomic<int> ranges{0};
    std::vector<std::atomic<int>> covered(nv);
    in_vertex_ranges(nv, [&](uint32_t lo, uint32_t hi) {
      ++ranges;
      for (uint32_t v = lo; v < hi; ++v) ++covered[v];
      for (size_t f = 0; f < nf; ++f)
        for (int k = 0; k < 3; ++k)
          if (corner[3 * f + k] >= lo && corner[3 * f + k] < hi) sum[corner[3 * f + k]] += value(f);
    });
    EXPECT_GE(ranges.load(), 1);
    EXPECT_LE(ranges.load(), threads) << "at most one range per thread";
    size_t once = 0;
    for (const auto& c : covered) once += c.load() == 1;
    EXPECT_EQ(once, nv) << "the ranges cover every vertex once";
    EXPECT_EQ(sum, serial) << threads << " threads";
  }
}

// How many ranges a loop over 400,000 vertices gets on 16 threads (and that
// they cover every vertex once).
int ranges_on_sixteen_threads() {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 16);
  tbb::task_arena sixteen(16);
  std::atomic<int> ranges{0};
  std::atomic<size_t> covered{0};
  sixteen.execute([&] {
    in_vertex_ranges(400000, [&](uint32_t lo, uint32_t hi) {
      ++ranges;
      covered += hi - lo;
    });
  });
  EXPECT_EQ(covered.load(), 400000u);
  return ranges.load();
}

// Each range reads the whole loop: on a host of 16 cores, 8 ranges at most.
TEST(VertexRanges, ManyThreadsGetAtMostTheRangeCap) {
  EXPECT_EQ(ranges_on_sixteen_threads(), int(kMaxVertexRanges));
}

// Four jobs at once on 16 threads: each splits its loops by its share, 4.
TEST(VertexRanges, ConcurrentJobsSplitByTheirShareOfTheThreads) {
  EXPECT_EQ(running_jobs(), 1) << "outside a job a loop counts as one";
  {
    const RunningJob jobs[4];
    EXPECT_EQ(running_jobs(), 4);
    EXPECT_EQ(ranges_on_sixteen_threads(), 4);
  }
  EXPECT_EQ(running_jobs(), 1) << "the jobs are uncounted when they end";
  EXPECT_EQ(ranges_on_sixteen_threads(), int(kMaxVertexRanges));
}

// A job process of the service: its server counts four busy job processes
// (this one among them) and the job splits its loops as one of four, though
// it is the only job in its own process.
TEST(VertexRanges, AJobProcessSplitsByItsShareOfTheHostsJobs) {
  std::atomic<int> host{4};
  count_host_jobs(&host);
  {
    const RunningJob job;
    EXPECT_EQ(running_jobs(), 4);
    EXPECT_EQ(ranges_on_sixteen_threads(), 4);
    host = 2;
    EXPECT_EQ(ranges_on_sixteen_threads(), 8) << "two jobs on 16 threads: 8 each, the cap";
    host = 0;  // the server has not counted this one yet: the process's own count holds
    EXPECT_EQ(running_jobs(), 1);
  }
  host = 16;
  EXPECT_EQ(ranges_on_sixteen_threads(), 1);
  count_host_jobs(nullptr);
  EXPECT_EQ(running_jobs(), 1);
}

TEST(VertexRanges, FewVerticesAreOneRange) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 8);
  std::vector<std::pair<uint32_t, uint32_t>> seen;
  in_vertex_ranges(20000, [&](uint32_t lo, uint32_t hi) { seen.push_back({lo, hi}); });
  ASSERT_EQ(seen.size(), 1u);  // under two ranges of 16,384
  EXPECT_EQ(seen[0], std::make_pair(0u, 20000u));
}

}  // namespace
}  // namespace vpr
