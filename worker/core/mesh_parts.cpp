#include "core/mesh_parts.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

namespace vpr {
namespace {

uint32_t find(std::vector<uint32_t>& up, uint32_t v) {
  while (up[v] != v) v = up[v] = up[up[v]];
  return v;
}

}  // namespace

std::vector<uint32_t> face_parts(const Mesh& mesh, size_t* parts) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  std::vector<uint32_t> up(nv);
  std::iota(up.begin(), up.end(), 0u);
  auto valid = [&](size_t f) {
    return mesh.indices[3 * f] < nv && mesh.indices[3 * f + 1] < nv && mesh.indices[3 * f + 2] < nv;
  };
  for (size_t f = 0; f < nf; ++f) {
    if (!valid(f)) continue;
    const uint32_t a = find(up, mesh.indices[3 * f]);
    for (int k = 1; k < 3; ++k) {
      const uint32_t b = find(up, mesh.indices[3 * f + k]);
      if (a != b) up[std::max(a, b)] = std::min(a, b);
    }
  }
  std::vector<uint32_t> id_of_root(nv, UINT32_MAX), part(nf, UINT32_MAX);
  uint32_t count = 0;
  for (size_t f = 0; f < nf; ++f) {
    if (!valid(f)) continue;
    const uint32_t r = find(up, mesh.indices[3 * f]);
    if (id_of_root[r] == UINT32_MAX) id_of_root[r] = count++;
    part[f] = id_of_root[r];
  }
  if (parts) *parts = count;
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
