// The mesh of a surface CVT (surface_cvt.h): the dual of the restricted
// Voronoi cells. Every face of the refined surface whose three corners lie in
// three different cells gives the triangle of those cells (Valette and
// Chassery 2004), with the face's orientation; the input's boundary loops
// stay boundary loops, its holes stay open, and small holes the dual leaves
// where four or more cells meet are closed. A cell's vertex is placed by its
// faces' quadric error (Garland and Heckbert 1997; planes of the input
// boundary's edges added), solved about the cell's centroid with small
// eigenvalues dropped (Lindstrom 2000), so it lands on a crease or corner the
// cell covers and at the centroid on a flat one; then it is projected onto the
// cell's own triangles, so it lies on the input surface, on its own sheet.
// Non-manifold configurations are repaired by repair_triangle_soup. Then
// rounds of tangential relaxation and Delaunay flips (free vertices in their
// tangent plane, crease vertices along their crease, corners and boundary
// held) remove most thin triangles. Last, the vertices off creases, corners
// and the boundary are offset along their normals to the least-squares fit
// of the input (offset_fit.h), so the triangles are no longer chords of the
// surface.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "surface/mesh_edges.h"
#include "surface/meshing.h"
#include "surface/offset_fit.h"
#include "core/status.h"

namespace vpr {

struct ClusterMeshStats {
  size_t cells = 0;            // clusters asked for
  size_t cells_unused = 0;     // clusters no dual triangle uses (dropped)
  size_t holes_closed = 0;     // dual holes closed (not input boundary)
  size_t boundary_loops = 0;   // loops kept open (the input's boundary)
  size_t points_separated = 0; // cells moved off a point another cell took
  MeshingStats repair;         // repair_triangle_soup's account
  OffsetFitStats offset;       // fit_offsets' account
};

struct ClusterMeshOptions {
  // Rounds of tangential relaxation, each followed by Delaunay flips, before
  // the fit (0: the CVT's vertices as they are).
  int relax_rounds = 2;
  // The cells' quadrics and centroids summed per cell in parallel (1) or in
  // one loop over the faces (0); -1: in parallel where the machine has 8 or
  // more threads. The same bits either way.
  int per_cell_sums = -1;
  OffsetFitOptions offset;  // the L2 fit of the vertices along their normals (on by default)
};

// surface: the refined input; label: its vertices' cells, count cells.
// cell_of_vertex: per output vertex, its cell.
Status mesh_clusters(const Mesh& surface, const std::vector<uint32_t>& label, uint32_t count, Mesh* out,
                     std::vector<uint32_t>* cell_of_vertex, ClusterMeshStats* stats,
                     const ClusterMeshOptions& options = {});
// The same with the surface's edges already built (mesh_edges(surface)).
Status mesh_clusters(const Mesh& surface, const MeshEdges& edges, const std::vector<uint32_t>& label, uint32_t count,
                     Mesh* out, std::vector<uint32_t>* cell_of_vertex, ClusterMeshStats* stats,
                     const ClusterMeshOptions& options = {});

}  // namespace vpr
