#include "surface/mesh_edges.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/vertex_ranges.h"

namespace vpr {

// From this many threads a job fills the rows with atomic slots (below).
constexpr size_t kAtomicSlotThreads = 8;

MeshEdges mesh_edges(const Mesh& mesh) { return mesh_edges(mesh.indices, mesh.vertex_count()); }

MeshEdges mesh_edges(const std::vector<uint32_t>& indices, size_t vertex_count) {
  const size_t nv = vertex_count, nf = indices.size() / 3;
  const uint32_t* idx = indices.data();
  // Each face edge into both its ends' rows (repeats included): counted,
  // then filled. The rows are sorted below, so the order in which a row's
  // entries land does not matter, and either way of filling gives the same
  // rows on any thread count:
  // - On 8 threads or more, by ranges of faces with atomic slots: the faces
  //   are read twice in all.
  // - On fewer, by vertex ranges (core/vertex_ranges.h): each thread reads
  //   every face and keeps its own vertices' entries, with plain increments.
  // Measured on an 800,000-face torus (H200 host, 2026-11-29, ms, none run
  // first): on 16 threads vertex ranges 36-41, atomic slots 25; on 8, 34-38
  // and 28-32; on 4, 36-42 and 45-48; on 2, 36-46 and 61-76 (a locked
  // increment stalls the core's other loads, which few threads cannot hide).
  auto each_edge = [&](auto&& visit) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 8192), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t f = r.begin(); f != r.end(); ++f)
        for (int c = 0; c < 3; ++c) {
          const uint32_t a = idx[3 * f + c], b = idx[3 * f + (c + 1) % 3];
          if (a != b) visit(a, b);
        }
    });
  };
  auto each_end_in = [&](uint32_t lo, uint32_t hi, auto&& visit) {
    for (size_t f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) {
        const uint32_t a = idx[3 * f + c], b = idx[3 * f + (c + 1) % 3];
        if (a == b) continue;
        if (a >= lo && a < hi) visit(a, b);
        if (b >= lo && b < hi) visit(b, a);
      }
  };
  auto bump = [](uint32_t* slot) { return __atomic_fetch_add(slot, 1u, __ATOMIC_RELAXED); };
  const bool atomic_slots = job_threads() >= kAtomicSlotThreads;
  std::vector<uint32_t> start(nv + 1, 0);
  if (atomic_slots) {
    each_edge([&](uint32_t a, uint32_t b) {
      bump(&start[a + 1]);
      bump(&start[b + 1]);
    });
  } else {
    in_vertex_ranges(nv, [&](uint32_t lo, uint32_t hi) {
      each_end_in(lo, hi, [&](uint32_t v, uint32_t) { ++start[v + 1]; });
    });
  }
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<uint32_t> raw(start[nv]), fill(start.begin(), start.end() - 1);
  if (atomic_slots) {
    each_edge([&](uint32_t a, uint32_t b) {
      raw[bump(&fill[a])] = b;
      raw[bump(&fill[b])] = a;
    });
  } else {
    in_vertex_ranges(nv, [&](uint32_t lo, uint32_t hi) {
      each_end_in(lo, hi, [&](uint32_t v, uint32_t w) { raw[fill[v]++] = w; });
    });
  }
  // Rows sorted, repeats counted and dropped in place: per row its distinct
  // neighbours, each with the length of its run (the faces using the edge).
  std::vector<uint32_t> runs(raw.size()), distinct(nv + 1, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      uint32_t* row = raw.data() + start[v];
      uint32_t* run = runs.data() + start[v];
      const size_t n = start[v + 1] - start[v];
      if (n <= 32) {  // most rows (about twice the degree): insertion sort beats std::sort there
        for (size_t i = 1; i < n; ++i) {
          const uint32_t x = row[i];
          size_t j = i;
          for (; j > 0 && row[j - 1] > x; --j) row[j] = row[j - 1];
          row[j] = x;
        }
      } else {
        std::sort(row, row + n);
      }
      size_t kept = 0;
      for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && row[j] == row[i]) ++j;
        row[kept] = row[i];
        run[kept++] = uint32_t(j - i);
        i = j;
      }
      distinct[v + 1] = uint32_t(kept);
    }
  });
  MeshEdges e;
  e.offset.resize(nv + 1);
  e.offset[0] = 0;
  for (size_t v = 0; v < nv; ++v) e.offset[v + 1] = e.offset[v] + distinct[v + 1];
  e.neighbor.resize(e.offset[nv]);
  e.faces.resize(e.offset[nv]);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      std::copy(raw.begin() + start[v], raw.begin() + start[v] + distinct[v + 1], e.neighbor.begin() + e.offset[v]);
      std::copy(runs.begin() + start[v], runs.begin() + start[v] + distinct[v + 1], e.faces.begin() + e.offset[v]);
    }
  });
  return e;
}

}  // namespace vpr
