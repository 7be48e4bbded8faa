// The input surface made fine enough to carry a discrete centroidal Voronoi
// tessellation (surface_cvt.h): every edge at most `max_edge` long, by
// splitting edges at their midpoints (the shape is unchanged: new vertices lie
// on the input's triangles). Exact duplicate positions are welded first, so a
// mesh exported as separate triangles regains its connectivity; then a vertex
// where several fans meet gets a copy per extra fan (surface/pinch_split.h).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"
#include "surface/mesh_edges.h"

namespace vpr {

struct RefinedSurface {
  Mesh mesh;                   // welded, degenerate faces dropped, refined
  int channels = 1;
  std::vector<float> value;    // channels per refined vertex: the input's values, linearly interpolated
  std::vector<uint32_t> face;  // per refined face: the input face it lies in
  MeshEdges edges;             // the refined mesh's edges (mesh_edges(mesh)), a by-product of the last pass
  VertexCorners corners;       // its corners by vertex, when mesh_edges made them (8 threads or more, or the GPU)
  // Where the edge rows were made: "" on the host as asked, "gpu", or why
  // the twin failed (then made on the host).
  std::string edges_twin;
  // (copy, original) for each vertex split where fans met (surface/pinch_split.h)
  std::vector<std::pair<uint32_t, uint32_t>> pinch_copies;
  // Where each refined vertex comes from, for carry_values: the welded
  // vertices (the first source.size()) are input vertices, then come the
  // pinch copies in order, then the midpoints, two ends each, pass by pass
  // (pass_end: midpoints made by the end of each pass).
  size_t input_vertices = 0;
  std::vector<uint32_t> source;
  std::vector<uint32_t> midpoint_ends;
  std::vector<size_t> pass_end;
};

// How long a refined edge may be: max_edge everywhere, and rim_max_edge
// where an end lies within rim_band of an open edge (an edge of one face or
// of more than two, after the weld: surface/rim_band.h). The dual keeps a
// rim only where its cells hold enough elements along it, which the CVT
// itself does not need elsewhere (docs/pipeline.md, "5-7").
struct EdgeBounds {
  double max_edge = 0;
  double rim_max_edge = 0;  // <= max_edge; 0: the same bound at rims
  double rim_band = 0;      // distance from an open edge; 0: no band
};

// value: `channels` numbers per input vertex (e.g. importance, density),
// carried to the new vertices. max_vertices bounds the result
// (RESOURCE_EXHAUSTED past it).
StatusOr<RefinedSurface> refine_surface(const Mesh& input, const std::vector<float>& value, int channels,
                                        const EdgeBounds& bounds, size_t max_vertices);
StatusOr<RefinedSurface> refine_surface(const Mesh& input, const std::vector<float>& value, int channels,
                                        double max_edge, size_t max_vertices);

// The same in two steps: the geometry (value and channels left empty), which
// needs no values, so a job can start it before its field exists; then the
// values carried to the refined vertices, the same bits as refine_surface.
// edge_rows, when set, makes the last pass's edge rows and corners (the GPU's
// twin: the same rows); on its error the host makes them.
StatusOr<RefinedSurface> refine_geometry(const Mesh& input, const EdgeBounds& bounds, size_t max_vertices,
                                         const MeshEdgesTwin& edge_rows = {});
StatusOr<RefinedSurface> refine_geometry(const Mesh& input, double max_edge, size_t max_vertices);
Status carry_values(const std::vector<float>& value, int channels, RefinedSurface* refined);

}  // namespace vpr
