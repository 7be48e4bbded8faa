#include "surface/mesh_edges.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>


namespace vpr {

MeshEdges mesh_edges(const Mesh& mesh) { return mesh_edges(mesh.indices, mesh.vertex_count()); }

MeshEdges mesh_edges(const std::vector<uint32_t>& indices, size_t vertex_count) {
  const size_t nv = vertex_count, nf = indices.size() / 3;
  const uint32_t* idx = indices.data();
  // Each face edge into both its ends' rows (repeats included): counted,
  // then filled, by ranges of faces in parallel with atomic slots. A row's
  // entries land in any order, but the rows are sorted below, so the result
  // does not depend on it (nor on the thread count). This reads the faces
  // twice in all, where one range of vertices per thread reread every face
  // in each range (core/vertex_ranges.h): on 16 threads 8 ranges made the
  // count and the fill two thirds of this function's time.
  auto each_edge = [&](auto&& visit) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 8192), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t f = r.begin(); f != r.end(); ++f)
        for (int c = 0; c < 3; ++c) {
          const uint32_t a = idx[3 * f + c], b = idx[3 * f + (c + 1) % 3];
          if (a != b) visit(a, b);
        }
    });
  };
  auto bump = [](uint32_t* slot) { return __atomic_fetch_add(slot, 1u, __ATOMIC_RELAXED); };
  std::vector<uint32_t> start(nv + 1, 0);
  each_edge([&](uint32_t a, uint32_t b) {
    bump(&start[a + 1]);
    bump(&start[b + 1]);
  });
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<uint32_t> raw(start[nv]), fill(start.begin(), start.end() - 1);
  each_edge([&](uint32_t a, uint32_t b) {
    raw[bump(&fill[a])] = b;
    raw[bump(&fill[b])] = a;
  });
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
