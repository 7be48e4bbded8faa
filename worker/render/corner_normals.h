// Shading geometry for the snapshots (snapshot.cpp): smooth normals per face
// corner, and the corners a GPU's indexed draw may share. Host code, no GL.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/vec3.h"

namespace vpr::gl {

// Faces meeting at a sharper angle than this keep their crease.
inline constexpr double kSmoothingAngleDeg = 60;

// Smooth normals per corner, independent of face orientation and of whether
// the faces share vertex indices (vertices are welded by exact position here,
// for shading only, so a soup shades like the mesh it came from). The normal
// of corner k of face f averages the area-weighted normals of the faces around
// that position that lie within kSmoothingAngleDeg of f's, each flipped to f's
// side first. kept_faces: the #K non-degenerate faces drawn; face_normals and
// area_normals (cross products, length = 2 area) are theirs.
struct CornerNormals {
  std::vector<Vec3> normal;  // #K x 3, per corner (3 k + i)
  // The corners at each welded position, in corner order (CSR): corners[start[v]..start[v + 1]).
  std::vector<uint32_t> start, corners;
};
CornerNormals corner_normals(const Mesh& mesh, const std::vector<uint32_t>& kept_faces,
                             const std::vector<Vec3>& face_normals, const std::vector<Vec3d>& area_normals);

// For a GPU's renderer: the corners at one welded position whose normals are
// equal, or opposite (the same |n . l|, so the same gray), become one vertex
// of an indexed draw. On a smooth closed mesh that is one vertex per input
// vertex instead of about six corners, so the per-view shading and its
// upload fall about six-fold, and every triangle is drawn with the same
// corner values. (A software rasterizer gains nothing from the smaller
// upload and draws unindexed triangles faster: llvmpipe spent about 8 ms more
// on igea with the indexed draw, so it keeps the corners.)
struct SharedCorners {
  std::vector<uint32_t> corner;  // per shared vertex: the first corner (3 k + i) it stands for
  std::vector<uint32_t> index;   // #K x 3: each corner's shared vertex
};
SharedCorners share_corners(const CornerNormals& normals);

}  // namespace vpr::gl
