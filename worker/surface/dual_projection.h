// The dual's projections onto the input surface (cluster_mesh.h): each
// cell's vertex placed on the nearest point of its cell's faces, and each
// round of tangential relaxation, whose moved vertices go back onto the faces
// of their own cell and of the cell they move towards. These nearest-face
// searches are most of the relaxation's time and independent of each other,
// so a GPU makes them at once (dual_projection.cu, one thread a cell or a
// vertex). Both twins share the arithmetic below (the .cu is compiled
// without FMA contraction) and give the same bits; the host keeps the rest
// of the dual (quadrics, the soup's repair, the flips, the undoing of moves
// that turn a triangle over).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/exec_context.h"
#include "core/mesh.h"
#include "core/status.h"
#include "core/vec3.h"

namespace vpr {

// What a vertex may do in the tangential relaxation.
enum class Freedom : uint8_t { kFree, kAlongLine, kHeld };

// A cell's faces of the surface (in face order) and their bounding spheres
// (face_sphere below).
struct FaceList {
  const uint32_t* face = nullptr;
  const std::array<float, 4>* sphere = nullptr;
  uint32_t count = 0;
};

// The closest point of triangle abc to p (Ericson, Real-Time Collision
// Detection, 5.1.5), as a point.
VPR_HD inline Vec3d closest_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3d bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec3d cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// Squared distance from x to the sphere s (0 inside it): a lower bound of
// the squared distance from x to any point of its triangle.
VPR_HD inline double sphere_gap2(const Vec3d& x, const std::array<float, 4>& s) {
  const double dx = x.x - s[0], dy = x.y - s[1], dz = x.z - s[2];
  const double gap = std::sqrt(dx * dx + dy * dy + dz * dz) - s[3];
  return gap > 0 ? gap * gap : 0.0;
}

// Triangle f's bounding sphere, to prune the nearest-face searches: centre
// x, y, z (the centroid, stored in float) and radius, measured from the
// stored centre and rounded up by 1e-5 of itself, so that a search which
// skips a triangle only when its sphere is farther than the best distance
// (with a relative margin of 1e-6) picks the point a full search picks. The
// centre is rounded to float before the radius is measured from it: far
// from the origin a float's step exceeds a small triangle (1/64 at 2e5), and
// a radius measured from the unrounded centre misses corners there. (The
// Eigen version this replaces came out of GCC 12's -O3, inlined in the
// dual, measuring from the unrounded centre: radii up to 7% short on a torus
// 2e5 units out, where cluster_mesh_test's projections disagreed with these.)
VPR_HD inline std::array<float, 4> face_sphere(const float* positions, const uint32_t* indices, size_t f) {
  const uint32_t* t = indices + 3 * f;
  const Vec3d corner[3] = {load3d(positions, t[0]), load3d(positions, t[1]), load3d(positions, t[2])};
  const Vec3d s = corner[0] + corner[1] + corner[2];
  const Vec3d centre{double(float(s.x / 3)), double(float(s.y / 3)), double(float(s.z / 3))};
  double radius = 0;
  for (const Vec3d& c : corner) {
    const double r = norm(c - centre);
    radius = r > radius ? r : radius;
  }
  return {float(centre.x), float(centre.y), float(centre.z), float(radius * (1 + 1e-5))};
}

// The nearest point to x on the faces of the lists, in list order with the
// first of equally near faces kept (what a plain loop over every face
// gives); *best and *best_d are left alone when no face is nearer than
// *best_d. The face with the nearest sphere is measured first; its distance
// bounds the rest, and a face whose sphere is farther (with a relative margin
// of 1e-6 for rounding) is skipped, so the spheres change how much is
// measured, never the point found.
VPR_HD inline void nearest_on_lists(const Vec3d& x, const FaceList* lists, int list_count, const float* positions,
                                    const uint32_t* indices, Vec3d* best, double* best_d) {
  auto closest = [&](uint32_t f) {
    const uint32_t* t = indices + 3 * size_t(f);
    return closest_on_triangle(x, load3d(positions, t[0]), load3d(positions, t[1]), load3d(positions, t[2]));
  };
  uint32_t first = UINT32_MAX;
  double first_gap = INFINITY;
  for (int l = 0; l < list_count; ++l)
    for (uint32_t i = 0; i < lists[l].count; ++i) {
      const double gap = sphere_gap2(x, lists[l].sphere[i]);
      if (gap < first_gap) first_gap = gap, first = lists[l].face[i];
    }
  if (first == UINT32_MAX) return;
  const double bound = norm2(closest(first) - x);
  for (int l = 0; l < list_count; ++l)
    for (uint32_t i = 0; i < lists[l].count; ++i) {
      const double limit = *best_d < bound ? *best_d : bound;  // std::min(bound, *best_d)
      if (sphere_gap2(x, lists[l].sphere[i]) > limit * (1 + 1e-6)) continue;
      const Vec3d q = closest(lists[l].face[i]);
      const double d = norm2(q - x);
      if (d < *best_d) *best_d = d, *best = q;
    }
}

// One relaxation round's input, as flat arrays (host or device memory).
struct RelaxView {
  const Vec3d* start;          // the output's vertices as the round begins
  const uint32_t* indices;     // its triangles
  const uint32_t* face_start;  // vertex v's triangles: faces_of[face_start[v] .. face_start[v + 1]), in face order
  const uint32_t* faces_of;
  const Freedom* freedom;  // per vertex
  const uint32_t* source;  // per vertex, its cell
  const Vec3d* line;       // per cell, a crease cell's line direction
  const float* surface_positions;
  const uint32_t* surface_indices;
};

// fn(w) once for each vertex w of v's one-ring (the other corners of its
// triangles), in no particular order.
template <class Fn>
VPR_HD void for_each_ring_vertex(const RelaxView& in, uint32_t v, Fn&& fn) {
  for (uint32_t j = in.face_start[v]; j < in.face_start[v + 1]; ++j)
    for (int k = 0; k < 3; ++k) {
      const uint32_t w = in.indices[3 * size_t(in.faces_of[j]) + k];
      if (w == v) continue;
      bool seen = false;  // at an earlier corner of this or an earlier triangle
      for (uint32_t i = in.face_start[v]; i <= j && !seen; ++i)
        for (int m = 0; m < (i == j ? k : 3); ++m)
          if (in.indices[3 * size_t(in.faces_of[i]) + m] == w) seen = true;
      if (!seen) fn(w);
    }
}

// Tangential relaxation (Botsch and Kobbelt 2004, "A remeshing approach to
// multiresolution modeling", Section 4), vertex v's new position: a free
// vertex moves in its tangent plane, by half the way, towards the centroid of
// its one-ring's triangle centroids; a crease vertex moves along its crease
// line towards the midpoint of its two crease neighbours; corners and
// boundary vertices stay. A moved vertex goes back onto the input surface
// (the closest point of the faces of its own cell and of the cell of the ring
// vertex nearest to where it goes: it moves at most half way to its ring's
// centre, so into one neighbouring cell at most). The centroids are not
// weighted by area: a CVT's cells have areas about 1 / density, so area
// weights would pull vertices towards sparse regions and undo the density;
// equal weights keep a smoothly varying spacing. lists(cell) gives a cell's
// FaceList.
template <class Lists>
VPR_HD Vec3d relax_move(const RelaxView& in, const Lists& lists, uint32_t v) {
  const Vec3d here = in.start[v];
  const uint32_t first_face = in.face_start[v], end_face = in.face_start[v + 1];
  if (in.freedom[v] == Freedom::kHeld || first_face == end_face) return here;
  Vec3d normal{0, 0, 0}, centre{0, 0, 0};
  for (uint32_t j = first_face; j < end_face; ++j) {
    const uint32_t* t = in.indices + 3 * size_t(in.faces_of[j]);
    const Vec3d a = in.start[t[0]], b = in.start[t[1]], c = in.start[t[2]];
    normal = normal + cross(b - a, c - a);
    const Vec3d s = a + b + c;
    centre = centre + Vec3d{s.x / 3, s.y / 3, s.z / 3};
  }
  Vec3d step;
  if (in.freedom[v] == Freedom::kFree) {
    const double length = norm(normal);
    if (!(length > 0)) return here;
    normal = {normal.x / length, normal.y / length, normal.z / length};
    const double faces = double(end_face - first_face);
    const Vec3d d = Vec3d{centre.x / faces, centre.y / faces, centre.z / faces} - here;
    step = 0.5 * (d - normal * dot(normal, d));
  } else {
    // The crease neighbours: ring vertices on a crease or corner, along the line.
    const Vec3d dir = in.line[in.source[v]];
    uint32_t along[2] = {0, 0}, count = 0;
    for_each_ring_vertex(in, v, [&](uint32_t w) {
      if (in.freedom[w] == Freedom::kFree) return;
      const Vec3d e = in.start[w] - here;
      const double length = norm(e);
      const Vec3d unit{e.x / length, e.y / length, e.z / length};
      if (std::fabs(dot(unit, dir)) > 0.9) {
        if (count < 2) along[count] = w;
        ++count;
      }
    });
    if (count != 2) return here;
    const Vec3d mid = 0.5 * (in.start[along[0]] + in.start[along[1]]);
    step = (0.5 * dir) * dot(dir, mid - here);
  }
  const Vec3d x = here + step;
  // The ring vertex nearest to x, the smallest index among equally near.
  uint32_t toward = UINT32_MAX;
  for_each_ring_vertex(in, v, [&](uint32_t w) { toward = w < toward ? w : toward; });
  double toward_d = norm2(in.start[toward] - x);
  for_each_ring_vertex(in, v, [&](uint32_t w) {
    const double d = norm2(in.start[w] - x);
    if (d < toward_d || (d == toward_d && w < toward)) toward = w, toward_d = d;
  });
  double best_d = INFINITY;
  Vec3d best = here;
  const FaceList near[2] = {lists(in.source[v]), lists(in.source[toward])};
  nearest_on_lists(x, near, in.source[toward] != in.source[v] ? 2 : 1, in.surface_positions, in.surface_indices, &best,
                   &best_d);
  return best;
}

// The dual's cells' faces, flat: cell c's are face[start[c] .. start[c + 1]).
struct CellFaceLists {
  const Mesh* surface = nullptr;
  const std::vector<uint32_t>* start = nullptr;
  const std::vector<uint32_t>* face = nullptr;
};

// One relaxation round's output mesh as the host holds it.
struct RelaxMesh {
  const Mesh* mesh = nullptr;
  const std::vector<uint32_t>* face_start = nullptr;
  const std::vector<uint32_t>* faces_of = nullptr;
  const std::vector<Freedom>* freedom = nullptr;
  const std::vector<uint32_t>* source = nullptr;
  const std::vector<Vec3d>* line = nullptr;
};

// The projections made where the surface's lists live (a device).
class DualProjector {
 public:
  virtual ~DualProjector() = default;
  // Per cell c, the nearest point to x[c] on its faces, or start[c] where it
  // has none (or none is nearer than infinity).
  virtual Status place(const std::vector<Vec3d>& x, const std::vector<Vec3d>& start, std::vector<Vec3d>* placed) = 0;
  // Every vertex's relax_move (the vertices as mesh.mesh holds them).
  virtual Status relax(const RelaxMesh& mesh, std::vector<Vec3d>* moved) = 0;
};

// A device's projector for one dual, or an error (the host then projects).
using DualProjectorSource = std::function<StatusOr<std::unique_ptr<DualProjector>>(const CellFaceLists&)>;

// GPU twin, built when VPR_HAVE_CUDA (dual_projection.cu): the host's bits.
namespace cuda {
StatusOr<std::unique_ptr<DualProjector>> dual_projector(const CellFaceLists& lists, const ExecContext& ctx);
}  // namespace cuda

}  // namespace vpr
