#include "surface/surface_refine.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>
#include <unordered_map>

#include "core/vec3.h"

namespace vpr {
namespace {

Vec3d at(const std::vector<double>& p, uint32_t i) {
  return {p[3 * size_t(i)], p[3 * size_t(i) + 1], p[3 * size_t(i) + 2]};
}

uint64_t edge_key(uint32_t a, uint32_t b) {
  return a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
}

}  // namespace

StatusOr<RefinedSurface> refine_surface(const Mesh& input, const std::vector<float>& value, int channels,
                                        double max_edge, size_t max_vertices) {
  const size_t k = size_t(channels);
  if (channels < 1 || value.size() != k * input.vertex_count())
    return invalid_argument("refine: `channels` values per vertex expected");
  if (!(max_edge > 0) || !std::isfinite(max_edge)) return invalid_argument("refine: max_edge must be positive");
  RefinedSurface out;
  out.channels = channels;
  size_t count = 0;  // refined vertices
  // Weld exact duplicates (the lowest index wins, so a welded mesh keeps its order).
  std::map<std::array<float, 3>, uint32_t> first;
  std::vector<uint32_t> weld(input.vertex_count());
  for (size_t v = 0; v < input.vertex_count(); ++v) {
    const std::array<float, 3> p = {input.positions[3 * v], input.positions[3 * v + 1], input.positions[3 * v + 2]};
    auto [it, added] = first.emplace(p, uint32_t(count));
    if (added) {
      out.mesh.positions.insert(out.mesh.positions.end(), p.begin(), p.end());
      out.value.insert(out.value.end(), value.begin() + k * v, value.begin() + k * (v + 1));
      ++count;
    }
    weld[v] = it->second;
  }
  std::vector<double> pos(out.mesh.positions.begin(), out.mesh.positions.end());  // double while splitting
  for (size_t f = 0; f < input.face_count(); ++f) {
    const uint32_t a = weld[input.indices[3 * f]], b = weld[input.indices[3 * f + 1]], c = weld[input.indices[3 * f + 2]];
    if (a == b || b == c || c == a) continue;
    const Vec3d pa = at(pos, a), pb = at(pos, b), pc = at(pos, c);
    if (!(norm(cross(pb - pa, pc - pa)) > 0)) continue;  // zero area: no surface to sample
    out.mesh.indices.insert(out.mesh.indices.end(), {a, b, c});
    out.face.push_back(uint32_t(f));
  }
  if (out.mesh.indices.empty()) return invalid_argument("refine: the mesh has no face of positive area");

  // Passes of midpoint splits: each face keeps its corners' order, so the
  // refined faces keep the input's orientation.
  const double max2 = max_edge * max_edge;
  for (int pass = 0; pass < 64; ++pass) {
    std::unordered_map<uint64_t, uint32_t> mid;
    auto length2 = [&](uint32_t a, uint32_t b) {
      const Vec3d d = at(pos, a) - at(pos, b);
      return dot(d, d);
    };
    auto midpoint = [&](uint32_t a, uint32_t b) -> uint32_t {
      auto [it, added] = mid.emplace(edge_key(a, b), uint32_t(count));
      if (added) {
        for (int c = 0; c < 3; ++c) pos.push_back(0.5 * (pos[3 * a + c] + pos[3 * b + c]));
        for (size_t c = 0; c < k; ++c) out.value.push_back(0.5f * (out.value[k * a + c] + out.value[k * b + c]));
        ++count;
      }
      return it->second;
    };
    const size_t faces = out.mesh.indices.size() / 3;
    for (size_t f = 0; f < faces; ++f)
      for (int c = 0; c < 3; ++c) {
        const uint32_t a = out.mesh.indices[3 * f + c], b = out.mesh.indices[3 * f + (c + 1) % 3];
        if (length2(a, b) > max2) midpoint(a, b);
      }
    if (mid.empty()) break;
    if (count > max_vertices)
      return resource_exhausted("refining the surface to edges of " + std::to_string(max_edge) + " would need over " +
                                std::to_string(max_vertices) + " vertices");
    std::vector<uint32_t> indices;
    std::vector<uint32_t> face;
    indices.reserve(out.mesh.indices.size() * 2);
    for (size_t f = 0; f < faces; ++f) {
      const uint32_t v[3] = {out.mesh.indices[3 * f], out.mesh.indices[3 * f + 1], out.mesh.indices[3 * f + 2]};
      uint32_t m[3];
      int split = 0;
      for (int c = 0; c < 3; ++c) {
        auto it = mid.find(edge_key(v[c], v[(c + 1) % 3]));
        m[c] = it == mid.end() ? UINT32_MAX : it->second;
        split += m[c] != UINT32_MAX;
      }
      auto emit = [&](uint32_t a, uint32_t b, uint32_t c) {
        indices.insert(indices.end(), {a, b, c});
        face.push_back(out.face[f]);
      };
      if (split == 0) {
        emit(v[0], v[1], v[2]);
      } else if (split == 3) {  // 1:4
        emit(v[0], m[0], m[2]);
        emit(v[1], m[1], m[0]);
        emit(v[2], m[2], m[1]);
        emit(m[0], m[1], m[2]);
      } else if (split == 1) {  // 1:2 across the split edge
        const int c = m[0] != UINT32_MAX ? 0 : m[1] != UINT32_MAX ? 1 : 2;
        emit(v[c], m[c], v[(c + 2) % 3]);
        emit(m[c], v[(c + 1) % 3], v[(c + 2) % 3]);
      } else {  // two split edges: the corner between them, then the quad by its shorter diagonal
        // e: the unsplit edge (v[e], v[e+1]); the corner opposite it, v[e+2], is cut off.
        const int e = m[0] == UINT32_MAX ? 0 : m[1] == UINT32_MAX ? 1 : 2;
        const uint32_t a = v[e], b = v[(e + 1) % 3], o = v[(e + 2) % 3];
        const uint32_t mb = m[(e + 1) % 3], ma = m[(e + 2) % 3];  // on (b, o) and (o, a)
        emit(ma, mb, o);
        if (length2(a, mb) < length2(b, ma)) {
          emit(a, b, mb);
          emit(a, mb, ma);
        } else {
          emit(a, b, ma);
          emit(b, mb, ma);
        }
      }
    }
    out.mesh.indices = std::move(indices);
    out.face = std::move(face);
  }
  out.mesh.positions.assign(pos.begin(), pos.end());
  return out;
}

}  // namespace vpr
