// Closest points on a triangle mesh: a CGAL AABB tree over the faces that
// have area, queried for the nearest point, its face and its barycentric
// coordinates. Shared by the Hausdorff distance (eval/hausdorff.h) and the
// color transfer (pipeline/color_transfer.h).
#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "core/mesh.h"
#include "core/vec3.h"

namespace vpr {

class ClosestPointTree {
 public:
  struct Hit {
    uint32_t face = 0;                  // index into the mesh's faces
    std::array<double, 3> barycentric;  // of the face's corners, each in [0, 1], summing to 1 (to rounding)
    double squared_distance = 0;        // in the mesh's position units, squared
  };

  // Builds the tree over mesh's faces, in its position units (the frame
  // stays out: queries are positions of the same frame). Faces CGAL finds
  // degenerate (collinear corners) are left out. Queries from many threads
  // at once are safe once the constructor returns.
  explicit ClosestPointTree(const Mesh& mesh);
  ~ClosestPointTree();
  ClosestPointTree(const ClosestPointTree&) = delete;
  ClosestPointTree& operator=(const ClosestPointTree&) = delete;

  // True when every face is degenerate: then no query may be made.
  bool empty() const;
  // The nearest point of the surface to p. For a tie between faces the
  // answer depends on the tree alone, never on the calling thread.
  Hit closest(const Vec3d& p) const;
  double squared_distance(const Vec3d& p) const;

 private:
  struct Tree;
  std::unique_ptr<Tree> tree_;
};

}  // namespace vpr
