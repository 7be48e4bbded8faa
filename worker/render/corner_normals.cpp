#include "render/corner_normals.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>

namespace vpr::gl {

CornerNormals corner_normals(const Mesh& mesh, const std::vector<uint32_t>& kept_faces,
                             const std::vector<Vec3>& face_normals, const std::vector<Vec3d>& area_normals) {
  const size_t nv = mesh.vertex_count(), nk = kept_faces.size();
  // Weld by exact position, in parallel: vertex ids sorted by their coordinate
  // bits (ties by id); each run of equal positions is one welded vertex.
  using Key = std::array<uint32_t, 3>;
  auto key = [&](uint32_t v) {
    Key k;
    std::memcpy(k.data(), &mesh.positions[3 * size_t(v)], sizeof k);
    return k;
  };
  std::vector<uint32_t> order(nv);
  std::iota(order.begin(), order.end(), 0u);
  tbb::parallel_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const Key ka = key(a), kb = key(b);
    return ka != kb ? ka < kb : a < b;
  });
  std::vector<uint32_t> weld(nv);
  uint32_t groups = 0;
  for (size_t i = 0; i < nv; ++i) {
    if (i > 0 && key(order[i]) != key(order[i - 1])) ++groups;
    weld[order[i]] = groups;
  }
  if (nv > 0) ++groups;
  order = {};

  // Corners around each welded vertex (CSR), each list in corner order, so in
  // face order: a fixed summation order whatever the thread count (filled in
  // parallel, then sorted). A kept face has one corner at each of its three
  // distinct positions.
  CornerNormals out;
  std::vector<uint32_t>& start = out.start;
  std::vector<uint32_t>& corners = out.corners;
  auto corner_vertex = [&](size_t c) { return weld[mesh.indices[3 * size_t(kept_faces[c / 3]) + c % 3]]; };
  start.assign(size_t(groups) + 1, 0);
  corners.resize(3 * nk);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, 3 * nk, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t c = r.begin(); c < r.end(); ++c) __atomic_fetch_add(&start[corner_vertex(c) + 1], 1u, __ATOMIC_RELAXED);
  });
  for (size_t v = 0; v < groups; ++v) start[v + 1] += start[v];
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, 3 * nk, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t c = r.begin(); c < r.end(); ++c)
      corners[__atomic_fetch_add(&fill[corner_vertex(c)], 1u, __ATOMIC_RELAXED)] = uint32_t(c);
  });
  fill = {};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, groups, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v < r.end(); ++v) std::sort(corners.begin() + start[v], corners.begin() + start[v + 1]);
  });

  // Welded vertex by welded vertex: its faces' normals gathered once, then
  // each of its corners sums over them in face order.
  const float min_cos = float(std::cos(kSmoothingAngleDeg * M_PI / 180.0));
  out.normal.resize(3 * nk);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, groups, 1024), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<Vec3> unit;
    std::vector<Vec3d> weighted;
    for (size_t v = r.begin(); v < r.end(); ++v) {
      const uint32_t first = start[v], k = start[v + 1] - first;
      unit.resize(k);
      weighted.resize(k);
      for (uint32_t i = 0; i < k; ++i) {
        unit[i] = face_normals[corners[first + i] / 3];
        weighted[i] = area_normals[corners[first + i] / 3];
      }
      for (uint32_t i = 0; i < k; ++i) {
        const Vec3 own = unit[i];
        Vec3d acc{0, 0, 0};
        for (uint32_t j = 0; j < k; ++j) {
          const float cosine = dot(unit[j], own);
          if (std::abs(cosine) < min_cos) continue;
          acc = acc + (cosine < 0 ? -1.0 : 1.0) * weighted[j];
        }
        const double len = norm(acc);
        out.normal[corners[first + i]] = len > 0 ? Vec3{float(acc.x / len), float(acc.y / len), float(acc.z / len)} : own;
      }
    }
  });
  return out;
}

SharedCorners share_corners(const CornerNormals& cn) {
  const std::vector<uint32_t>& start = cn.start;
  const std::vector<uint32_t>& corners = cn.corners;
  const size_t groups = start.size() - 1;
  auto same_gray = [](Vec3 a, Vec3 b) {
    return (a.x == b.x && a.y == b.y && a.z == b.z) || (a.x == -b.x && a.y == -b.y && a.z == -b.z);
  };
  // Within each welded position, in corner order, a corner joins the first
  // earlier one that starts a shared vertex and has an equal or opposite
  // normal (exact), else starts one. Shared vertices are numbered by welded
  // position, then by their first corner.
  std::vector<uint32_t> first(corners.size()), distinct(groups + 1, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, groups, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v < r.end(); ++v) {
      uint32_t count = 0;
      for (uint32_t i = start[v]; i < start[v + 1]; ++i) {
        const uint32_t c = corners[i];
        uint32_t j = start[v];
        while (j < i && !(first[corners[j]] == corners[j] && same_gray(cn.normal[corners[j]], cn.normal[c]))) ++j;
        first[c] = j < i ? corners[j] : c;
        count += first[c] == c;
      }
      distinct[v + 1] = count;
    }
  });
  for (size_t v = 0; v < groups; ++v) distinct[v + 1] += distinct[v];
  SharedCorners out;
  out.index.resize(corners.size());
  out.corner.resize(distinct[groups]);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, groups, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v < r.end(); ++v) {
      uint32_t next = distinct[v];
      for (uint32_t i = start[v]; i < start[v + 1]; ++i) {
        const uint32_t c = corners[i];
        if (first[c] != c) continue;
        out.corner[next] = c;
        out.index[c] = next++;
      }
      for (uint32_t i = start[v]; i < start[v + 1]; ++i) {
        const uint32_t c = corners[i];
        if (first[c] != c) out.index[c] = out.index[first[c]];
      }
    }
  });
  return out;
}

}  // namespace vpr::gl
