// The arithmetic of mean_curvatures (surface_density.h) that both twins run:
// a face's normal and area, an edge's terms, a vertex's sum. The GPU twin
// (mean_curvature.cu) is compiled without FMA contraction, so these round as
// the host does, and it hands the one acos per edge to the host (CUDA's is
// not rounded as glibc's): the twins give the same bits.
#pragma once

#include <cstdint>

#include "core/vec3.h"

namespace vpr {

// Face f's unit normal (zero when degenerate) and twice its area.
VPR_HD inline void face_normal_area(const float* p, const uint32_t* t, Vec3d* normal, double* twice_area) {
  const Vec3d a = load3d(p, t[0]), b = load3d(p, t[1]), c = load3d(p, t[2]);
  const Vec3d n = cross(b - a, c - a);
  const double len = norm(n);
  *normal = len > 0 ? n * (1.0 / len) : Vec3d{0, 0, 0};
  *twice_area = len;
}

// Whether face `face` runs along a -> b.
VPR_HD inline bool face_runs_forward(const uint32_t* t, uint32_t a, uint32_t b) {
  return (t[0] == a && t[1] == b) || (t[1] == a && t[2] == b) || (t[2] == a && t[0] == b);
}
// The face's corner that is neither a nor b.
VPR_HD inline uint32_t face_far_corner(const uint32_t* t, uint32_t a, uint32_t b) {
  return t[0] != a && t[0] != b ? t[0] : t[1] != a && t[1] != b ? t[1] : t[2];
}

// The smallest cosine between the normals of the faces of the half-edges
// i .. j - 1 (face(k): the face of half-edge k), at least -1, NaN skipped;
// 2 where no two faces give one (1 or more: no angle). Its acos is the
// largest angle between them (acos falls as its argument grows); the host
// takes it (edge_angle) on either twin.
template <class FaceOf>
VPR_HD inline double edge_min_cosine(const Vec3d* normal, FaceOf face, uint32_t i, uint32_t j) {
  double least = 2.0;
  for (uint32_t a = i; a < j; ++a)
    for (uint32_t b = a + 1; b < j; ++b) {
      const double d = dot(normal[face(a)], normal[face(b)]);
      if (d < least) least = d;
    }
  return least < -1.0 ? -1.0 : least;
}
inline double edge_angle(double min_cosine) {
  return min_cosine >= 1.0 ? 0.0 : std::acos(min_cosine);
}

// Edge lo-hi's term, 1/4 |dihedral angle| x length, from its largest angle
// (edge_angle); *weighted (when weigh): the same times concave_weight where
// the edge is concave (surface_density.h; outwards: per face, whether its
// part faces outwards, or null when concave_weight is 1).
template <class FaceOf>
VPR_HD inline void edge_curvature_terms(const float* p, const uint32_t* idx, const Vec3d* normal, FaceOf face,
                                        uint32_t i, uint32_t j, uint32_t lo, uint32_t hi, double angle, bool weigh,
                                        double concave_weight, const char* outwards, double* term, double* weighted) {
  const double length = norm(load3d(p, lo) - load3d(p, hi));
  *term = 0.25 * angle * length;
  if (!weigh) return;
  double w = 1.0;
  if (j - i == 2 && concave_weight != 1.0) {
    const uint32_t fa = face(i), fb = face(i + 1);
    const uint32_t* ta = &idx[3 * size_t(fa)];
    const uint32_t* tb = &idx[3 * size_t(fb)];
    if (face_runs_forward(ta, lo, hi) != face_runs_forward(tb, lo, hi)) {
      const double below = dot(normal[fa], load3d(p, face_far_corner(tb, lo, hi)) - load3d(p, lo));
      const bool concave = outwards[fa] ? below > 0 : below < 0;
      if (concave) w = concave_weight;
    }
  }
  *weighted = *term * w;
}

// Vertex v's lists: its faces (corner_face[c0 .. c1), ascending), its edges
// to lower vertices (down[d0 .. d1), ascending edge numbers), its edges to
// higher ones (edges e0 .. e1 - 1, numbered by (lower, upper)); lower(e) and
// upper(e): an edge's ends.
struct VertexCurvatureRows {
  const double* twice_area;
  const uint32_t* corner_face;
  uint32_t c0, c1;
  const uint32_t* down;
  uint32_t d0, d1;
  const uint32_t* edge_lower;
  uint32_t e0, e1;
};

// v's sum of its edges' terms t over its area (a third of its faces'), in
// the order the lists give: the same bits on any thread count and either twin.
template <class Upper>
VPR_HD inline double vertex_curvature(uint32_t v, const VertexCurvatureRows& r, const double* t, Upper upper) {
  double area = 0.0, integral = 0.0;
  for (uint32_t i = r.c0; i < r.c1; ++i) area += r.twice_area[r.corner_face[i]] / 6.0;
  for (uint32_t i = r.d0; i < r.d1; ++i)
    if (r.edge_lower[r.down[i]] != v) integral += t[r.down[i]];
  for (uint32_t e = r.e0; e < r.e1; ++e) {
    integral += t[e];
    if (upper(e) == v) integral += t[e];  // an edge from v to itself counts at both ends
  }
  return area > 0 ? integral / area : 0.0;
}

}  // namespace vpr
