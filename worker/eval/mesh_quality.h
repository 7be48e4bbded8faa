// Triangle quality and topology counts of a mesh (for `vpremesh eval`).
#pragma once

#include <cstddef>

#include "pipeline/mesh.h"

namespace vpr {

struct MeshQuality {
  size_t vertices = 0;
  size_t faces = 0;
  double min_angle_deg = 0;          // smallest interior angle over non-degenerate faces
  double share_angles_below_30 = 0;  // fraction of interior angles under 30 degrees
  size_t degenerate_faces = 0;       // zero-area faces
  size_t non_manifold_edges = 0;     // edges with more than two incident faces
  size_t non_manifold_vertices = 0;  // vertices whose incident faces form more than one fan
  size_t boundary_edges = 0;
  size_t boundary_loops = 0;
  size_t components = 0;             // connected by shared vertices
  bool closed = false;               // no boundary edge and no non-manifold edge
  long euler_characteristic = 0;     // V - E + F
};

MeshQuality mesh_quality(const Mesh& mesh);

}  // namespace vpr
