// Stage 7: mesh the optimized points into an oriented 2-manifold. CGAL's
// Advancing Front Surface Reconstruction stands in for the paper's Tight CoCone;
// then repair: orient, split non-manifold vertices, fill small holes.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"

namespace vpr {

struct MeshingOptions {
  double radius_ratio_bound = 5.0;  // CGAL AFSR: candidate triangles with larger radius ratio are rejected
  double beta = 0.52;               // CGAL AFSR: sliver angle (radians)
  size_t max_hole_edges = 60;       // holes with up to this many boundary edges are filled
  // Faces, and hole patches, with an edge longer than this many median edge
  // lengths are removed: they bridge separate parts rather than follow the
  // surface (measured on beast.obj at 3000 vertices: a fan of 30x edges from a
  // lone particle; legitimate edges stay under 6x).
  double max_edge_ratio = 8.0;
  // Parallel reconstruction (our addition; AFSR itself is serial): the points
  // are cut into slabs along the longest axis, at least points_per_slab each
  // (at most max_slabs), each slab reconstructed with a halo of halo_spacings x
  // spacing on both sides, and each keeps the facets whose centroid lies in
  // its own slab. The result is used only when every seam closes (every edge
  // near a cut is shared by exactly two facets); otherwise the points are
  // reconstructed whole, as before. The slab count depends on the point count
  // only, so the result does not depend on the thread count.
  // spacing: the expected distance between neighbouring points (model units);
  // 0 = unknown, which turns slabs off.
  double spacing = 0;
  double halo_spacings = 8;
  size_t points_per_slab = 5000;  // measured on the H100: 2 slabs of 2500 lost more to halos than they won
  size_t max_slabs = 16;
  // A soup that needs no repair (an oriented manifold in one part, no
  // bridge, no hole to fill) is flattened directly rather than through a
  // CGAL mesh: the same result (false takes CGAL's way; tests compare).
  bool clean_soup_shortcut = true;
};

struct MeshingStats {
  size_t points_in = 0;
  size_t vertices_out = 0;
  size_t points_dropped = 0;  // points the reconstruction left out
  size_t holes_filled = 0;
  size_t holes_left = 0;
  size_t bridges_removed = 0;  // faces removed for an edge over max_edge_ratio
  size_t vertices_split = 0;   // vertices added by duplicating non-manifold points
  size_t slabs = 1;            // slabs reconstructed in parallel (1: the whole point set at once)
  size_t seam_defects = 0;     // open or over-used edges at the cuts of a slab attempt that was rejected
};

// points: n x 3 floats (the AWLOP particles). out: the surface, its vertices a
// subset of the points (a point is repeated where the surface pinches there),
// faces counter-clockwise seen from outside; no non-manifold edge or vertex.
// Holes up to max_hole_edges are filled without new vertices; a closed result
// bounds a volume (orient_to_bound_a_volume), an open one has each component
// oriented to positive signed volume about its centroid.
// source_point: for each output vertex, the index of the input point it is.
// source_point and stats may be null.
// INVALID_ARGUMENT: n < 4, a non-finite coordinate, all points coplanar, bad
// options, or no surface found; INTERNAL if CGAL throws.
Status mesh_points(const float* points, size_t n, const MeshingOptions& options, Mesh* out,
                   std::vector<uint32_t>* source_point, MeshingStats* stats);

// The repair half of mesh_points, on any triangle soup over `points`: orient
// (duplicating points at non-manifold edges and vertices), fill holes up to
// options.max_hole_edges, orient outward, drop unreferenced points.
// triangles: triangle_count x 3 indices into points. Same outputs as mesh_points.
// INVALID_ARGUMENT: no triangle, an index >= n, a triangle that repeats a
// vertex, or a non-finite coordinate.
Status repair_triangle_soup(const float* points, size_t n, const uint32_t* triangles, size_t triangle_count,
                            const MeshingOptions& options, Mesh* out, std::vector<uint32_t>* source_point,
                            MeshingStats* stats);

}  // namespace vpr
