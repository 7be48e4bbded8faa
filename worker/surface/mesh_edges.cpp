#include "surface/mesh_edges.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/vertex_ranges.h"

namespace vpr {

// From this many threads a job fills the rows with atomic slots (below).
constexpr size_t kAtomicSlotThreads = 8;

namespace {

// A row of a vertex ascending: most rows are short (about the degree, or
// twice it), where insertion sort beats std::sort; a long one (a fan's apex)
// by std::sort, never quadratic.
void sort_row(uint32_t* row, size_t n) {
  if (n > 32) {
    std::sort(row, row + n);
    return;
  }
  for (size_t i = 1; i < n; ++i) {
    const uint32_t x = row[i];
    size_t j = i;
    for (; j > 0 && row[j - 1] > x; --j) row[j] = row[j - 1];
    row[j] = x;
  }
}

}  // namespace

VertexCorners vertex_corners(const std::vector<uint32_t>& indices, size_t vertex_count) {
  const size_t nv = vertex_count, nc = indices.size();
  const uint32_t* idx = indices.data();
  VertexCorners vc;
  vc.offset.assign(nv + 1, 0);
  vc.corner.resize(nc);
  if (job_threads() < kAtomicSlotThreads) {  // a counting sort: each row ascending as filled
    for (size_t h = 0; h < nc; ++h) ++vc.offset[idx[h] + 1];
    for (size_t v = 0; v < nv; ++v) vc.offset[v + 1] += vc.offset[v];
    std::vector<uint32_t> fill(vc.offset.begin(), vc.offset.end() - 1);
    for (size_t h = 0; h < nc; ++h) vc.corner[fill[idx[h]]++] = uint32_t(h);
    return vc;
  }
  // Counted and filled with atomic slots (the corners read twice), then each
  // row sorted: the slots fill a row in any order.
  auto bump = [](uint32_t* slot) { return __atomic_fetch_add(slot, 1u, __ATOMIC_RELAXED); };
  auto each_corner = [&](auto&& visit) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nc, 3 * 8192), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t h = r.begin(); h != r.end(); ++h) visit(h);
    });
  };
  each_corner([&](size_t h) { bump(&vc.offset[idx[h] + 1]); });
  for (size_t v = 0; v < nv; ++v) vc.offset[v + 1] += vc.offset[v];
  std::vector<uint32_t> fill(vc.offset.begin(), vc.offset.end() - 1);
  each_corner([&](size_t h) { vc.corner[bump(&fill[idx[h]])] = uint32_t(h); });
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      uint32_t* row = vc.corner.data() + vc.offset[v];
      const size_t n = vc.offset[v + 1] - vc.offset[v];
      sort_row(row, n);
    }
  });
  return vc;
}

MeshEdges mesh_edges(const Mesh& mesh) { return mesh_edges(mesh.indices, mesh.vertex_count()); }

MeshEdges mesh_edges(const std::vector<uint32_t>& indices, size_t vertex_count, VertexCorners* corners_out) {
  const size_t nv = vertex_count, nf = indices.size() / 3;
  const uint32_t* idx = indices.data();
  // Each face edge into both its ends' rows (repeats included): counted,
  // then filled. The rows are sorted below, so the order in which a row's
  // entries land does not matter, and either way of filling gives the same
  // rows on any thread count:
  // - On 8 threads or more, by corners: each vertex's corners listed with
  //   atomic slots (faces read twice), then each row filled from its own
  //   corners, the corner's next and previous vertex (the same entries as
  //   the face edges at the vertex: an edge (a, a) gives none).
  // - On fewer, by vertex ranges (core/vertex_ranges.h): each thread reads
  //   every face and keeps its own vertices' entries, with plain increments.
  // Measured on an 800,000-face torus (H200 host, 2026-11-29, ms, none run
  // first): on 16 threads vertex ranges 36-41, atomic slots per edge end 25;
  // on 8, 34-38 and 28-32; on 4, 36-42 and 45-48; on 2, 36-46 and 61-76 (a
  // locked increment stalls the core's other loads, which few threads cannot
  // hide). Listing corners instead of edge ends halves the locked
  // increments.
  auto each_end_in = [&](uint32_t lo, uint32_t hi, auto&& visit) {
    for (size_t f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) {
        const uint32_t a = idx[3 * f + c], b = idx[3 * f + (c + 1) % 3];
        if (a == b) continue;
        if (a >= lo && a < hi) visit(a, b);
        if (b >= lo && b < hi) visit(b, a);
      }
  };
  // Row v: raw[begin[v] ..] with length[v] entries.
  std::vector<uint32_t> begin(nv), length(nv), raw;
  if (job_threads() >= kAtomicSlotThreads) {
    VertexCorners vc = vertex_corners(indices, nv);
    const std::vector<uint32_t>&corners = vc.offset, &corner = vc.corner;
    // Two entries a corner at most: row v in raw from 2 * corners[v].
    raw.resize(2 * 3 * nf);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v) {
        begin[v] = 2 * corners[v];
        uint32_t* row = raw.data() + begin[v];
        uint32_t n = 0;
        for (uint32_t i = corners[v]; i < corners[v + 1]; ++i) {
          const size_t h = corner[i], base = h - h % 3;
          const uint32_t next = idx[base + (h % 3 + 1) % 3], prev = idx[base + (h % 3 + 2) % 3];
          if (next != v) row[n++] = next;
          if (prev != v) row[n++] = prev;
        }
        length[v] = n;
      }
    });
    if (corners_out) *corners_out = std::move(vc);
  } else {
    if (corners_out) *corners_out = VertexCorners{};
    std::vector<uint32_t> start(nv + 1, 0);
    in_vertex_ranges(nv, [&](uint32_t lo, uint32_t hi) {
      each_end_in(lo, hi, [&](uint32_t v, uint32_t) { ++start[v + 1]; });
    });
    for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
    raw.resize(start[nv]);
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    in_vertex_ranges(nv, [&](uint32_t lo, uint32_t hi) {
      each_end_in(lo, hi, [&](uint32_t v, uint32_t w) { raw[fill[v]++] = w; });
    });
    for (size_t v = 0; v < nv; ++v) begin[v] = start[v], length[v] = start[v + 1] - start[v];
  }
  // Rows sorted, repeats counted and dropped in place: per row its distinct
  // neighbours, each with the length of its run (the faces using the edge).
  std::vector<uint32_t> runs(raw.size()), distinct(nv + 1, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      uint32_t* row = raw.data() + begin[v];
      uint32_t* run = runs.data() + begin[v];
      const size_t n = length[v];
      sort_row(row, n);
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
      std::copy(raw.begin() + begin[v], raw.begin() + begin[v] + distinct[v + 1], e.neighbor.begin() + e.offset[v]);
      std::copy(runs.begin() + begin[v], runs.begin() + begin[v] + distinct[v + 1], e.faces.begin() + e.offset[v]);
    }
  });
  return e;
}

}  // namespace vpr
