// Flat triangle meshes and polygon soups, the currency of every stage.
// Nothing downstream of input relies on connectivity (paper, Section III):
// a Mesh may be a soup with duplicated, flipped or degenerate faces.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/status.h"

namespace vpr {

struct Mesh {
  std::vector<float> positions;   // #V x 3 floats, model space
  std::vector<uint32_t> indices;  // #F x 3 vertex indices, counter-clockwise when oriented

  size_t vertex_count() const { return positions.size() / 3; }
  size_t face_count() const { return indices.size() / 3; }
};

struct Aabb {
  std::array<float, 3> lo{0, 0, 0};
  std::array<float, 3> hi{0, 0, 0};
  float diagonal() const;
};

// Limits a mesh must satisfy before it enters the pipeline. Each failure names
// the problem and the limit.
struct MeshLimits {
  size_t max_vertices = 20'000'000;  // upload limit for one job
  size_t max_faces = 40'000'000;
};

// Checks: at least one vertex and one face, every coordinate finite, every
// index in range, positive total area. Degenerate faces alone are accepted.
Status validate_mesh(const Mesh& mesh, const MeshLimits& limits = {});

Aabb bounding_box(const float* positions, size_t vertex_count);
inline Aabb bounding_box(const Mesh& m) {
  return bounding_box(m.positions.data(), m.vertex_count());
}

// Area of each face (#F doubles) and their sum; degenerate faces have area 0.
std::vector<double> face_areas(const Mesh& mesh);
double total_area(const Mesh& mesh);

// Mean edge length over all face edges (used by AWLOP's paper-default h).
double mean_edge_length(const Mesh& mesh);

}  // namespace vpr
