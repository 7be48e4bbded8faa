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
#include <string>
#include <utility>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"
#include "core/vec3.h"
#include "surface/dual_projection.h"
#include "surface/mesh_edges.h"
#include "surface/meshing.h"
#include "surface/offset_fit.h"

namespace vpr {

struct ClusterMeshStats {
  size_t cells = 0;            // clusters asked for
  size_t cells_unused = 0;     // clusters no dual triangle uses (dropped)
  size_t holes_closed = 0;     // dual holes closed (not input boundary)
  size_t boundary_loops = 0;   // loops kept open (the input's boundary)
  size_t points_separated = 0; // cells moved off a point another cell took
  MeshingStats repair;         // repair_triangle_soup's account
  OffsetFitStats offset;       // fit_offsets' account
  // The projections onto the cells' faces (placing and relaxing) ran on the
  // device to the end; projection_fallback: why the host made them instead.
  bool projected_on_device = false;
  std::string projection_fallback;
};

// What the dual reads of the refined surface alone, whatever its cells: made
// on its own thread while the CVT runs (pipeline.cpp), which does not need it.
struct DualSurface {
  // on_boundary[3 f + c]: face f's edge from corner c is a boundary edge (one face).
  std::vector<char> on_boundary;
  // Edges whose first two faces (in face order) are more than 30 degrees
  // apart, the flips' crease: (u, w) with u < w, in the rows' order.
  std::vector<std::pair<uint32_t, uint32_t>> sharp_edges;
  // Per face, its unit normal and area (the quadrics' planes), when made
  // with face_planes; empty otherwise.
  std::vector<Vec3d> normal;
  std::vector<double> area;
};
// with_planes: also the faces' planes (what mesh_clusters' sums read; made
// there when the facts have none).
DualSurface dual_surface(const Mesh& surface, const MeshEdges& edges, bool with_planes);
// Whether mesh_clusters sums the cells' quadrics per cell (and reads the
// faces' planes) with these options on this machine.
bool per_cell_sums(int option);

struct ClusterMeshOptions {
  // Rounds of tangential relaxation, each followed by Delaunay flips, before
  // the fit (0: the CVT's vertices as they are).
  int relax_rounds = 2;
  // The cells' quadrics and centroids summed per cell in parallel (1) or in
  // one loop over the faces (0); -1: in parallel where the machine has 8 or
  // more threads. The same bits either way.
  int per_cell_sums = -1;
  OffsetFitOptions offset;  // the L2 fit of the vertices along their normals (on by default)
  // dual_surface(surface, edges, ...) made already (null: made here). Its
  // planes are made here if it has none.
  const DualSurface* surface_facts = nullptr;
  // The projections onto the cells' faces made on a device (the host's bits;
  // null, or a device that fails: on the host).
  DualProjectorSource device_projector;
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
