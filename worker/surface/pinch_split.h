// Pinched vertices: a vertex whose faces form several fans, joined at it and
// nowhere else (a table leg welded to its top at one vertex, a cone's tip on
// a plane, a part touching itself). No 2-manifold keeps such a vertex, and
// the surface CVT (surface_cvt.h), whose cells grow over edges, would grow
// a cell through it from one fan into the other, which the dual cannot
// mesh. Each fan after the first gets its own copy of the vertex instead, so
// the sheets meet there only by position.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace vpr {

// indices: triangles over vertex_count vertices, rewritten so that every
// vertex's faces form one fan (faces joined by edges at that vertex); the
// copies are numbered from vertex_count on, in the order of their original
// vertex and then of their fan's first face, and vertex_count grows by
// their number. Returns (copy, original) for each copy, in that order.
// Faces with a repeated corner are left as they are.
std::vector<std::pair<uint32_t, uint32_t>> split_pinched_vertices(std::vector<uint32_t>* indices, size_t* vertex_count);

}  // namespace vpr
