#include "core/mesh.h"

#include <cmath>
#include <string>

#include "core/vec3.h"

namespace vpr {

float Aabb::diagonal() const {
  float dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

Status validate_mesh(const Mesh& mesh, const MeshLimits& limits) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (mesh.positions.size() % 3 != 0 || mesh.indices.size() % 3 != 0)
    return invalid_argument("mesh arrays are not multiples of 3");
  if (nv == 0) return invalid_argument("empty mesh: no vertices");
  if (nf == 0)
    return invalid_argument("no faces: the input is a point cloud with " + std::to_string(nv) +
                            " points, a triangle mesh or polygon soup is required");
  if (nv > limits.max_vertices)
    return resource_exhausted("mesh has " + std::to_string(nv) + " vertices, the limit is " +
                              std::to_string(limits.max_vertices));
  if (nf > limits.max_faces)
    return resource_exhausted("mesh has " + std::to_string(nf) + " faces, the limit is " +
                              std::to_string(limits.max_faces));
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    if (!std::isfinite(mesh.positions[i]))
      return invalid_argument("vertex " + std::to_string(i / 3) + " has a non-finite coordinate (NaN or infinity)");
  }
  for (size_t i = 0; i < mesh.indices.size(); ++i) {
    if (mesh.indices[i] >= nv)
      return invalid_argument("face " + std::to_string(i / 3) + " references vertex " +
                              std::to_string(mesh.indices[i]) + " but the mesh has " + std::to_string(nv) +
                              " vertices");
  }
  if (!(total_area(mesh) > 0.0)) return invalid_argument("degenerate mesh: every face has zero area");
  return Status::Ok();
}

Aabb bounding_box(const float* p, size_t n) {
  Aabb box;
  if (n == 0) return box;
  box.lo = {p[0], p[1], p[2]};
  box.hi = box.lo;
  for (size_t i = 1; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = std::min(box.lo[a], p[3 * i + a]);
      box.hi[a] = std::max(box.hi[a], p[3 * i + a]);
    }
  }
  return box;
}

std::vector<double> face_areas(const Mesh& mesh) {
  const size_t nf = mesh.face_count();
  std::vector<double> areas(nf);
  for (size_t f = 0; f < nf; ++f) {
    const Vec3d a = load3d(mesh.positions.data(), mesh.indices[3 * f]);
    const Vec3d b = load3d(mesh.positions.data(), mesh.indices[3 * f + 1]);
    const Vec3d c = load3d(mesh.positions.data(), mesh.indices[3 * f + 2]);
    areas[f] = 0.5 * norm(cross(b - a, c - a));
  }
  return areas;
}

double total_area(const Mesh& mesh) {
  double sum = 0.0;
  for (double a : face_areas(mesh)) sum += a;
  return sum;
}

double mean_edge_length(const Mesh& mesh) {
  const size_t nf = mesh.face_count();
  if (nf == 0) return 0.0;
  double sum = 0.0;
  for (size_t f = 0; f < nf; ++f) {
    for (int e = 0; e < 3; ++e) {
      const Vec3d a = load3d(mesh.positions.data(), mesh.indices[3 * f + e]);
      const Vec3d b = load3d(mesh.positions.data(), mesh.indices[3 * f + (e + 1) % 3]);
      sum += norm(b - a);
    }
  }
  return sum / (3.0 * nf);
}

}  // namespace vpr
