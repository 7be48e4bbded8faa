// The topology of a set of triangles, as the part fallback (part_fallback.h)
// holds a part's dual to its input part: a manifold (every directed edge
// once, every vertex one fan), closed (every edge in two faces, once each
// way), one piece, its Euler characteristic and its boundary loops.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace vpr {

struct TriangleShape {
  bool manifold = false;
  bool closed_manifold = false;
  bool one_piece = false;
  int64_t euler = 0;  // V - E + F over the vertices the faces use
  size_t loops = 0;   // pieces of the edges without their reverse
};

// rank: a table the calls share, indexed by vertex (grown as needed, left
// all UINT32_MAX as it was found), so that a call costs the faces' size,
// not the largest vertex number's.
TriangleShape triangle_shape(const std::vector<std::array<uint32_t, 3>>& faces, std::vector<uint32_t>* rank);

}  // namespace vpr
