// What the snapshots draw (snapshot.cpp): the mesh's drawable faces as
// positions relative to the bounding-box centre, with smooth corner normals
// (corner_normals.h), one drawn vertex per corner or, on a GPU's renderer,
// one per group of corners that share a position and a gray (share_corners).
// The host builds it (drawn_geometry) or its CUDA twin does, bit for bit the
// same (drawn_geometry.cu, compiled without FMA contraction): on a GPU job the
// host's part of the render is then only the per-view shading and GL's calls,
// which is where eight jobs at once stretched the render six-fold.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/exec_context.h"
#include "core/mesh.h"
#include "core/status.h"
#include "core/vec3.h"

namespace vpr {

struct DrawnGeometry {
  // Subtracted from every position (in double, before the cast to float) and
  // put back by the view's matrix: GL's float transform would otherwise lose a
  // far-from-origin scan's detail.
  Vec3d centre;
  std::vector<float> positions;   // 3 per drawn vertex
  std::vector<Vec3> normals;      // unit, one per drawn vertex
  std::vector<uint32_t> indices;  // indexed: each corner's drawn vertex (3 per drawable face); else empty
  size_t corners = 0;             // 3 x the drawable faces (non-degenerate, finite)
  bool indexed = false;
};

// The twin a GPU job hands the renderer: fills *out as drawn_geometry does.
using DrawnGeometryTwin = std::function<Status(const Mesh& mesh, bool indexed, DrawnGeometry* out)>;

// Out-of-range face indices are kInvalidArgument (checked here, before any twin runs).
Status check_face_indices(const Mesh& mesh);

// The host's construction. indexed: share corners (a GPU's renderer), else
// every drawable corner is a drawn vertex, in face order.
DrawnGeometry drawn_geometry(const Mesh& mesh, bool indexed);

// Checks the indices, then runs the twin if there is one; if the twin fails,
// the host's construction, with *note saying why ("" otherwise). *on_device:
// whether the twin's result was used.
Status drawn_geometry(const Mesh& mesh, bool indexed, const DrawnGeometryTwin& twin, DrawnGeometry* out,
                      bool* on_device, std::string* note);

// GPU twin, built when VPR_HAVE_CUDA: the same bits as the host's.
namespace cuda {
Status drawn_geometry(const Mesh& mesh, bool indexed, DrawnGeometry* out, const ExecContext& ctx);
}  // namespace cuda

}  // namespace vpr
