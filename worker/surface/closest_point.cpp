#include "surface/closest_point.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <algorithm>
#include <vector>

namespace vpr {

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using AabbTree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

Point to_point(const Vec3d& v) {
  return {v.x, v.y, v.z};
}

// Barycentric coordinates of q, a point of triangle abc (Ericson, Real-Time
// Collision Detection, 3.4), clamped against rounding.
std::array<double, 3> barycentric(const Point& q, const Triangle& t) {
  const auto v0 = t[1] - t[0], v1 = t[2] - t[0], v2 = q - t[0];
  const double d00 = v0 * v0, d01 = v0 * v1, d11 = v1 * v1, d20 = v2 * v0, d21 = v2 * v1;
  const double denom = d00 * d11 - d01 * d01;
  if (!(denom > 0)) return {1, 0, 0};
  double v = std::clamp((d11 * d20 - d01 * d21) / denom, 0.0, 1.0);
  double w = std::clamp((d00 * d21 - d01 * d20) / denom, 0.0, 1.0);
  if (v + w > 1) {
    const double s = v + w;
    v /= s;
    w /= s;
  }
  return {std::max(0.0, 1 - v - w), v, w};
}

}  // namespace

// The tree keeps iterators into `triangles`, so both live together and are
// neither copied nor moved once built.
struct ClosestPointTree::Tree {
  std::vector<Triangle> triangles;
  std::vector<uint32_t> face;  // of each triangle
  AabbTree tree;
};

ClosestPointTree::ClosestPointTree(const Mesh& mesh) : tree_(std::make_unique<Tree>()) {
  const float* p = mesh.positions.data();
  tree_->triangles.reserve(mesh.face_count());
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    const Triangle t(to_point(load3d(p, mesh.indices[3 * f])), to_point(load3d(p, mesh.indices[3 * f + 1])),
                     to_point(load3d(p, mesh.indices[3 * f + 2])));
    if (t.is_degenerate()) continue;
    tree_->triangles.push_back(t);
    tree_->face.push_back(uint32_t(f));
  }
  if (tree_->triangles.empty()) return;
  tree_->tree.insert(tree_->triangles.cbegin(), tree_->triangles.cend());
  // Both are lazy in CGAL; doing them here keeps the queries read-only.
  tree_->tree.build();
  tree_->tree.accelerate_distance_queries();
}

ClosestPointTree::~ClosestPointTree() = default;

bool ClosestPointTree::empty() const {
  return tree_->triangles.empty();
}

ClosestPointTree::Hit ClosestPointTree::closest(const Vec3d& p) const {
  const Point query = to_point(p);
  const auto [point, id] = tree_->tree.closest_point_and_primitive(query);
  const size_t i = size_t(id - tree_->triangles.cbegin());
  Hit hit;
  hit.face = tree_->face[i];
  hit.barycentric = barycentric(point, tree_->triangles[i]);
  hit.squared_distance = CGAL::squared_distance(query, point);
  return hit;
}

double ClosestPointTree::squared_distance(const Vec3d& p) const {
  return tree_->tree.squared_distance(to_point(p));
}

}  // namespace vpr
