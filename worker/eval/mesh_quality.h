// Triangle quality and topology counts of a mesh (for `vpremesh eval`).
#pragma once

#include <cstddef>

#include "core/mesh.h"

namespace vpr {

struct MeshQuality {
  size_t vertices = 0;               // mesh.vertex_count(), referenced or not
  size_t faces = 0;                  // mesh.face_count(), invalid ones included
  double min_angle_deg = 0;          // smallest interior angle over non-degenerate faces (0 if none)
  double share_angles_below_30 = 0;  // fraction of interior angles of non-degenerate faces under 30 degrees
  size_t degenerate_faces = 0;       // zero area in double arithmetic (repeated or collinear corners)
  size_t invalid_faces = 0;          // index out of range or non-finite corner; ignored everywhere else
  size_t non_manifold_edges = 0;     // edges with more than two incident faces
  size_t non_manifold_vertices = 0;  // vertices whose incident faces form more than one fan
  size_t boundary_edges = 0;         // edges with exactly one incident face
  size_t boundary_loops = 0;         // connected components of the boundary-edge graph
  size_t components = 0;             // faces connected by shared vertices
  // Faces connected across shared edges: the surface's pieces. Two sheets that
  // touch at a vertex only are one component but two sheets, and a 2-manifold
  // remesh must keep them apart (a vertex where they touch is non-manifold).
  size_t sheets = 0;
  bool closed = false;               // at least one face, no boundary edge and no non-manifold edge
  long euler_characteristic = 0;     // V - E + F, V = vertices referenced by a valid face
  // The same three counts after merging vertices at exactly the same position
  // (weld_exact): an exporter that splits a surface at its texture or
  // normal seams leaves boundary loops and parts that a person does not see.
  size_t welded_boundary_loops = 0;
  size_t welded_components = 0;
  size_t welded_sheets = 0;
  bool welded_closed = false;
};

// Works on any soup: duplicated faces count as extra incidences of their edges
// (so a doubled face makes non-manifold edges), a face repeating a vertex index
// contributes its one or two distinct edges. Topology counts include degenerate
// faces; angle statistics skip them.
MeshQuality mesh_quality(const Mesh& mesh);

}  // namespace vpr
