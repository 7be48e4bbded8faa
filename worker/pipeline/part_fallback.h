// The last guard of "closed stays closed" and "boundary loops kept": a part
// of the input whose dual (surface/cluster_mesh.h) came out non-manifold, in
// pieces, of another genus, closed where the part is open or open where it
// is closed, with other boundary loops, or not at all, is replaced by a
// quadric decimation of that part (OpenMesh's, peers/peers.h: edge collapses
// that pass the link condition keep a manifold's genus) to the same number
// of vertices, when the decimation is whole. The CVT's topology step
// (surface_cvt.h) makes this rare; it is for the thin or small parts that
// step cannot afford at the target (a wire ring 2% thick at 300 vertices, an
// octagonal table leg at 100, a fin on a box whose four cells at 100 left no
// dual triangle: scripts/stress-shapes.py), where a person would rather see
// a coarse leg or fin than a hole or nothing. Parts that are not manifolds
// (an edge in more than two faces) have no shape to hold the dual to.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"
#include "surface/mesh_edges.h"

namespace vpr {

struct PartFallbackStats {
  size_t closed_parts = 0;     // closed parts of the surface
  size_t open_parts = 0;       // open parts that are manifolds (every edge in one or two faces)
  size_t parts_replaced = 0;   // parts whose dual was broken, now decimated
  size_t parts_left = 0;       // broken, but the decimation was no better (left as the dual made them)
};

// The surface's parts and their shapes (a pure function of the surface and
// its edges: the pipeline makes them beside the CVT, which does not need them).
struct SurfaceParts {
  size_t parts = 0;
  std::vector<uint32_t> face_part;    // per face, its part (UINT32_MAX: none)
  std::vector<uint32_t> vertex_part;  // per vertex, its part (UINT32_MAX: in no face)
  std::vector<char> closed;           // per part: every edge in two faces
  std::vector<char> manifold;         // per part: every edge in one or two faces
  std::vector<int64_t> euler;         // per part: V - E + F
  std::vector<size_t> loops;          // per part: boundary loops
};
SurfaceParts surface_parts(const Mesh& surface, const MeshEdges& edges);

// surface: the refined input the CVT ran on, with its edges; label: its
// vertices' cells. out, cell_of_vertex: the dual and each output vertex's
// cell (mesh_clusters' results), rewritten where a part is replaced; a new
// vertex's cell is that of the surface element nearest to it. target: the
// job's vertex count; a replaced part gets its cells' share of it.
Status replace_broken_parts(const Mesh& surface, const MeshEdges& edges, const std::vector<uint32_t>& label,
                            uint32_t target, Mesh* out, std::vector<uint32_t>* cell_of_vertex,
                            PartFallbackStats* stats);
// The same with the surface's parts already made (surface_parts(surface, edges)).
Status replace_broken_parts(const Mesh& surface, const MeshEdges& edges, const SurfaceParts& shapes,
                            const std::vector<uint32_t>& label, uint32_t target, Mesh* out,
                            std::vector<uint32_t>* cell_of_vertex, PartFallbackStats* stats);

}  // namespace vpr
