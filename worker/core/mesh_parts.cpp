#include "core/mesh_parts.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>

#include "core/concurrent_parents.h"

namespace vpr {

// In parallel, with a serial walk's numbering: the union-find roots each
// part at its lowest vertex whatever the schedule, and the parts are then
// numbered by their first face, as a loop over the faces in order numbers
// them. The dual and the CVT's part fallback call it on the refined surface
// (up to millions of faces), the density on the input.
std::vector<uint32_t> face_parts(const Mesh& mesh, size_t* parts) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  const uint32_t* idx = mesh.indices.data();
  auto valid = [&](size_t f) { return idx[3 * f] < nv && idx[3 * f + 1] < nv && idx[3 * f + 2] < nv; };
  ConcurrentParents parents(nv);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f)
      if (valid(f)) {
        parents.unite(idx[3 * f], idx[3 * f + 1]);
        parents.unite(idx[3 * f], idx[3 * f + 2]);
      }
  });
  // Each face's root, and each root's first face (the lowest, by atomic min).
  std::vector<uint32_t> part(nf, UINT32_MAX);
  std::unique_ptr<std::atomic<uint32_t>[]> first(new std::atomic<uint32_t>[nv]);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) first[v].store(UINT32_MAX, std::memory_order_relaxed);
  });
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f) {
      if (!valid(f)) continue;
      const uint32_t root = parents.find(idx[3 * f]);
      part[f] = root;
      uint32_t seen = first[root].load(std::memory_order_relaxed);
      while (uint32_t(f) < seen && !first[root].compare_exchange_weak(seen, uint32_t(f), std::memory_order_relaxed)) {
      }
    }
  });
  // Roots in order of their first face: the parts' numbers.
  std::vector<uint32_t> roots;
  for (size_t v = 0; v < nv; ++v)
    if (first[v].load(std::memory_order_relaxed) != UINT32_MAX) roots.push_back(uint32_t(v));
  std::sort(roots.begin(), roots.end(), [&](uint32_t a, uint32_t b) {
    return first[a].load(std::memory_order_relaxed) < first[b].load(std::memory_order_relaxed);
  });
  std::vector<uint32_t> id_of_root(roots.empty() ? 0 : nv);
  for (size_t i = 0; i < roots.size(); ++i) id_of_root[roots[i]] = uint32_t(i);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f)
      if (part[f] != UINT32_MAX) part[f] = id_of_root[part[f]];
  });
  if (parts) *parts = roots.size();
  return part;
}

size_t drop_small_parts(Mesh* mesh, double min_fraction) {
  if (!(min_fraction > 0)) return 0;
  size_t parts = 0;
  const std::vector<uint32_t> part = face_parts(*mesh, &parts);
  if (parts < 2) return 0;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  std::vector<std::array<float, 6>> box(parts, {kInf, kInf, kInf, -kInf, -kInf, -kInf});
  std::array<float, 6> all = {kInf, kInf, kInf, -kInf, -kInf, -kInf};
  for (size_t f = 0; f < part.size(); ++f) {
    if (part[f] == UINT32_MAX) continue;
    for (int c = 0; c < 3; ++c) {
      const float* p = &mesh->positions[3 * size_t(mesh->indices[3 * f + c])];
      for (int a = 0; a < 3; ++a) {
        for (auto* b : {&box[part[f]], &all}) {
          (*b)[a] = std::min((*b)[a], p[a]);
          (*b)[3 + a] = std::max((*b)[3 + a], p[a]);
        }
      }
    }
  }
  auto diagonal = [](const std::array<float, 6>& b) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) d2 += double(b[3 + a] - b[a]) * double(b[3 + a] - b[a]);
    return std::sqrt(d2);
  };
  std::vector<double> size(parts);
  for (size_t p = 0; p < parts; ++p) size[p] = diagonal(box[p]);
  const size_t largest = size_t(std::max_element(size.begin(), size.end()) - size.begin());
  const double limit = min_fraction * diagonal(all);
  std::vector<char> drop(parts, 0);
  size_t dropped = 0;
  for (size_t p = 0; p < parts; ++p)
    if (p != largest && size[p] < limit) drop[p] = 1, ++dropped;
  if (dropped == 0) return 0;
  std::vector<uint32_t> kept;
  kept.reserve(mesh->indices.size());
  for (size_t f = 0; f < part.size(); ++f)
    if (part[f] == UINT32_MAX || !drop[part[f]])
      kept.insert(kept.end(), &mesh->indices[3 * f], &mesh->indices[3 * f + 3]);
  mesh->indices = std::move(kept);
  return dropped;
}

}  // namespace vpr
