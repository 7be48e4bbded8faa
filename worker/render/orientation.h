// Stage 1 (Section III), our addition: the paper photographs the model along
// its own axes and leaves a canonical orientation as future work. We align the
// cameras to the surface's principal axes so that a scan saved in an arbitrary
// pose is seen from the same six sides.
#pragma once

#include <array>

#include "core/mesh.h"
#include "core/vec3.h"

namespace vpr {

struct PrincipalAxes {
  // Row-major 3x3 rotation, model space -> aligned frame; row k is the k-th
  // principal axis in model space. Right-handed (det = +1).
  std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};
  Vec3d centroid;                     // area-weighted surface centroid, model space
  std::array<double, 3> variances{};  // along each axis, largest first (model units^2)
};

// Area-weighted PCA of the surface (every triangle integrated exactly, so the
// result does not depend on how finely a region is tessellated).
// Sign convention, so that the result is deterministic: axes 1 and 2 point
// where the surface's third moment along them is positive (the heavier tail);
// when that skew is negligible (a symmetric model) the largest-magnitude model
// component of the axis is made positive. Axis 3 = axis 1 x axis 2.
// Where principal variances coincide (a cube, a sphere, a cylinder's cross
// section) the axes in that eigenspace are not defined by the data; we take
// the model axes projected into it instead of whatever the eigensolver returns.
// Degenerate faces weigh nothing; a mesh of zero area gets the identity.
PrincipalAxes surface_principal_axes(const Mesh& mesh);

}  // namespace vpr
