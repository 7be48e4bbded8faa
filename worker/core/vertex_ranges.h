// A serial loop over faces that adds into per-vertex values, run in parallel
// without atomics: the vertices are cut into one range per thread, and each
// range's thread runs the whole loop, keeping only the updates of its own
// vertices. Every vertex then gets the serial loop's updates in the serial
// loop's order (the same bits on any thread count), each thread reads the
// faces in order, and the scattered writes, which were the serial loop's
// cost, are shared out. For scans of every face of a large mesh (vertex
// normals, edge rows on few threads); below min_range vertices a range, one thread. The
// "vertices" may be any items a loop scatters into: edge entries, cells.
#pragma once

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "core/running_jobs.h"

namespace vpr {

// Every range reads the whole loop, so the ranges are at most
// kMaxVertexRanges: past that the repeated reads cost more processor time
// than the scatter they share out, which matters when concurrent jobs keep
// every core busy (one range per core of a 16-core host: 16 reads of the
// faces for one serial loop's writes). For the same reason a job gets its
// share of the threads when several run (core/running_jobs.h).
constexpr size_t kMaxVertexRanges = 8;

// The threads this job's loops may count on: the arena's shared out among
// the running jobs (at least 1), or fewer where a global_control limits them
// (a cap that already is this job's share, core/thread_share.h, is not
// shared out again).
inline size_t job_threads() {
  const size_t share = std::max<size_t>(1, size_t(tbb::this_task_arena::max_concurrency()) / size_t(running_jobs()));
  return std::min<size_t>(share, tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

// How many ranges a loop over vertex_count items gets: one per thread this
// job may count on, at least min_range items each, at most kMaxVertexRanges.
inline size_t vertex_range_count(size_t vertex_count, size_t min_range) {
  return std::max<size_t>(1, std::min<size_t>({job_threads(), vertex_count / min_range, kMaxVertexRanges}));
}

// body(lo, hi): the loop, applying only the updates of vertices in [lo, hi).
template <class Body>
void in_vertex_ranges(size_t vertex_count, Body&& body, size_t min_range = 16384) {
  const size_t ranges = vertex_range_count(vertex_count, min_range);
  tbb::parallel_for(size_t(0), ranges, [&](size_t r) {
    body(uint32_t(vertex_count * r / ranges), uint32_t(vertex_count * (r + 1) / ranges));
  });
}

}  // namespace vpr
