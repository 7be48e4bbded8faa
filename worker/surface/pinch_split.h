// Pinched vertices and edges: a vertex whose faces form several fans, joined
// at it and nowhere else (a table leg welded to its top at one vertex, a
// cone's tip on a plane, a part touching itself), and an edge of more than
// two faces (two boxes that share an edge, a fin standing on a face). No
// 2-manifold keeps either, and the surface CVT (surface_cvt.h), whose cells
// grow over edges, would grow a cell through them from one sheet into the
// other, which the dual cannot mesh (two boxes sharing an edge came back with
// 20% more vertices than asked, from cells split for topology that could not
// be merged away). Each fan after the first gets its own copy of the vertex
// instead, so the sheets meet there only by position.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace vpr {

// indices: triangles over vertex_count vertices (positions: x, y, z per
// vertex), rewritten so that every vertex's faces form one fan: faces joined
// by an edge at that vertex, where an edge of more than two faces joins only
// the pairs that bound one solid's inside (going round the edge, a face whose
// normal points away from the sector before the next face, and that next
// face whose normal points away from it too; a face left unpaired, a fin, is
// a sheet of its own there; an edge where two faces lie on top of each
// other, a double-sided sheet, joins all its faces as a manifold edge does).
// The copies are numbered from vertex_count on, in the order of their
// original vertex and then of their fan's first face, and vertex_count grows
// by their number. Returns (copy, original) for each
// copy, in that order. Faces with a repeated corner are left as they are.
// open_edges, when given, gets the mesh's edges (as it came, before any
// copy) used by one face or by more than two: its rims and the feet of its
// fins, where the split leaves the surface open. Each as (lower, higher)
// vertex, ascending; a by-product of the fans' search, which meets every
// edge at both its ends.
std::vector<std::pair<uint32_t, uint32_t>> split_pinched_vertices(
    std::vector<uint32_t>* indices, size_t* vertex_count, const std::vector<double>& positions,
    std::vector<std::pair<uint32_t, uint32_t>>* open_edges = nullptr);

}  // namespace vpr
