#include "render/drawn_geometry.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <utility>

#include "render/corner_normals.h"

namespace vpr {

Status check_face_indices(const Mesh& mesh) {
  for (uint32_t i : mesh.indices)
    if (i >= mesh.vertex_count())
      return invalid_argument("face index " + std::to_string(i) + " is out of range; the mesh has " +
                              std::to_string(mesh.vertex_count()) + " vertices");
  return Status::Ok();
}

DrawnGeometry drawn_geometry(const Mesh& mesh, bool indexed) {
  DrawnGeometry out;
  out.indexed = indexed;
  const size_t nf = mesh.face_count();
  const Aabb box = bounding_box(mesh);
  const Vec3d centre{0.5 * (double(box.lo[0]) + box.hi[0]), 0.5 * (double(box.lo[1]) + box.hi[1]),
                     0.5 * (double(box.lo[2]) + box.hi[2])};
  out.centre = centre;
  // Two parallel passes: which faces are drawable (and their normals), then
  // their normals at the slots a prefix sum gives them (face order kept).
  std::vector<Vec3d> all_normals(nf);
  std::vector<uint32_t> slot(nf + 1, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f < r.end(); ++f) {
      const Vec3d a = load3d(mesh.positions.data(), mesh.indices[3 * f]) - centre;
      const Vec3d b = load3d(mesh.positions.data(), mesh.indices[3 * f + 1]) - centre;
      const Vec3d c = load3d(mesh.positions.data(), mesh.indices[3 * f + 2]) - centre;
      all_normals[f] = cross(b - a, c - a);
      const double len = norm(all_normals[f]);
      slot[f + 1] = (len > 0.0) && std::isfinite(len);  // degenerate: nothing to draw, no normal
    }
  });
  for (size_t f = 0; f < nf; ++f) slot[f + 1] += slot[f];
  const size_t kept = slot[nf];
  std::vector<Vec3> face_normals(kept);  // float: at 40M faces the doubles would cost another 0.5 GB
  std::vector<Vec3d> area_normals(kept);
  std::vector<uint32_t> kept_faces(kept);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f < r.end(); ++f) {
      if (slot[f + 1] == slot[f]) continue;
      const size_t k = slot[f];
      const Vec3d n = all_normals[f];
      const double len = norm(n);
      face_normals[k] = Vec3{float(n.x / len), float(n.y / len), float(n.z / len)};
      area_normals[k] = n;
      kept_faces[k] = uint32_t(f);
    }
  });
  all_normals = {};
  slot = {};
  gl::CornerNormals corner = gl::corner_normals(mesh, kept_faces, face_normals, area_normals);
  area_normals = {};
  face_normals = {};
  gl::SharedCorners shared;
  if (indexed) shared = gl::share_corners(corner);
  corner.start = {};
  corner.corners = {};
  // The drawn vertices: every corner, or each shared vertex's first corner.
  const size_t drawn = indexed ? shared.corner.size() : 3 * kept;
  out.corners = 3 * kept;
  if (indexed) out.normals.resize(drawn);
  out.positions.resize(3 * drawn);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, drawn, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const uint32_t c = indexed ? shared.corner[i] : uint32_t(i);
      if (indexed) out.normals[i] = corner.normal[c];
      const Vec3d p = load3d(mesh.positions.data(), mesh.indices[3 * size_t(kept_faces[c / 3]) + c % 3]) - centre;
      out.positions[3 * i] = float(p.x);
      out.positions[3 * i + 1] = float(p.y);
      out.positions[3 * i + 2] = float(p.z);
    }
  });
  if (indexed) {
    out.indices = std::move(shared.index);
  } else {
    out.normals = std::move(corner.normal);
  }
  return out;
}

Status drawn_geometry(const Mesh& mesh, bool indexed, const DrawnGeometryTwin& twin, DrawnGeometry* out,
                      bool* on_device, std::string* note) {
  *on_device = false;
  note->clear();
  VPR_RETURN_IF_ERROR(check_face_indices(mesh));
  if (twin) {
    const Status s = twin(mesh, indexed, out);
    if (s.ok()) {
      *on_device = true;
      return Status::Ok();
    }
    *note = "GPU failed (" + s.to_string() + "), prepared on the host";
  }
  *out = drawn_geometry(mesh, indexed);
  return Status::Ok();
}

}  // namespace vpr
