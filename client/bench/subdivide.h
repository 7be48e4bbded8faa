// Benchmark inputs bigger than the shared models: midpoint subdivision (each
// triangle into four, new vertices at edge midpoints, so the surface is
// unchanged) until the mesh has at least a given number of faces.
#pragma once

#include <cstdint>
#include <unordered_map>

#include "core/mesh.h"

namespace vpr::bench {

inline Mesh subdivide_once(const Mesh& in) {
  Mesh out;
  out.positions = in.positions;
  out.origin = in.origin;
  out.scale = in.scale;
  std::unordered_map<uint64_t, uint32_t> midpoint;
  midpoint.reserve(in.indices.size());
  auto mid = [&](uint32_t a, uint32_t b) {
    const uint64_t key = a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
    auto [it, fresh] = midpoint.emplace(key, uint32_t(out.positions.size() / 3));
    if (fresh)
      for (int c = 0; c < 3; ++c) out.positions.push_back(0.5f * (in.positions[3 * a + c] + in.positions[3 * b + c]));
    return it->second;
  };
  out.indices.reserve(4 * in.indices.size());
  for (size_t f = 0; f < in.face_count(); ++f) {
    const uint32_t a = in.indices[3 * f], b = in.indices[3 * f + 1], c = in.indices[3 * f + 2];
    const uint32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    for (uint32_t t : {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca}) out.indices.push_back(t);
  }
  return out;
}

inline Mesh subdivide_to(Mesh mesh, size_t min_faces) {
  while (mesh.face_count() < min_faces) mesh = subdivide_once(mesh);
  return mesh;
}

}  // namespace vpr::bench
