// Stage 7: mesh the optimized points into an oriented 2-manifold. CGAL's
// Advancing Front Surface Reconstruction stands in for the paper's Tight CoCone;
// then repair: orient, split non-manifold vertices, fill small holes.
#pragma once

#include <cstdint>
#include <vector>

#include "mesh.h"
#include "status.h"

namespace vpr {

struct MeshingOptions {
  double radius_ratio_bound = 5.0;  // CGAL AFSR: candidate triangles with larger radius ratio are rejected
  double beta = 0.52;               // CGAL AFSR: sliver angle (radians)
  size_t max_hole_edges = 60;       // holes with up to this many boundary edges are filled
};

struct MeshingStats {
  size_t points_in = 0;
  size_t vertices_out = 0;
  size_t points_dropped = 0;   // points the reconstruction left out
  size_t holes_filled = 0;
  size_t holes_left = 0;
  size_t vertices_split = 0;   // non-manifold vertices duplicated
};

// out: the surface; source_point: for each output vertex, the input point it came from.
Status mesh_points(const float* points, size_t n, const MeshingOptions& options, Mesh* out,
                   std::vector<uint32_t>* source_point, MeshingStats* stats);

}  // namespace vpr
