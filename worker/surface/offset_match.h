// The L2 fit's samples matched to the output (offset_fit.h): one sample per
// input face, at its centroid, weighted by its area, matched to the nearest
// output triangle among those around its cell's vertices that lie within 30
// degrees of the sample's face plane, and the sums the fit takes of them (per
// triangle, in sample order; the RMS). Each sample is independent of the
// others, so the matching is the fit's step a GPU does at once: on igea at
// 10,000 it tests about ten triangles for each of 800,000 samples, half the
// fit's time on the host. On a device the samples stay there and only the
// triangles' sums come back (the matches are 58 MB on igea: fetching them
// cost what matching them on the host does). The host matches a block of
// samples at a time and sums it before the next, so it keeps no sample
// either: a 250 MB array of matches (igea at 50,000) took 1.2 s of first
// touches on a 2-core virtual machine, more than the matching. Both twins
// share the arithmetic below (the .cu is compiled without FMA contraction)
// and give the same bits.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "core/exec_context.h"
#include "core/mesh.h"
#include "core/status.h"
#include "core/vec3.h"

namespace vpr {

// cos(30 degrees): a sample is fitted only by a triangle within 30 degrees of
// its own input face's plane (either winding: scans come with faces wound
// both ways), not by one that cuts across a crease.
constexpr double kOffsetSameSide = 0.8660254037844386;

// One sample of the input matched to the output: the triangle, barycentrics
// of the nearest point, the triangle's unit normal, the signed distance along
// it from the triangle's first corner, and the sample's weight.
struct OffsetMatch {
  int64_t face = -1;  // -1: no triangle matched (weight 0)
  Vec3d bary;
  Vec3d normal;
  double residual = 0;
  double weight = 0;
};

// What the matching reads, as flat arrays (host or device memory).
struct OffsetMatchView {
  const float* surface_positions;  // the (refined) input
  const uint32_t* surface_indices;
  const uint32_t* label;  // per input vertex, its cell or UINT32_MAX
  uint32_t cells;
  const float* positions;  // the output mesh
  const uint32_t* indices;
  const Vec3d* unit_normal;  // per output triangle (zero: degenerate)
  const uint32_t* vert_start;  // cell c's output vertices: verts_of[vert_start[c] .. vert_start[c + 1])
  const uint32_t* verts_of;
  const uint32_t* face_start;  // vertex v's triangles: faces_of[face_start[v] .. face_start[v + 1])
  const uint32_t* faces_of;
};

VPR_HD inline double component(const Vec3d& v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }

// n over its length (each coordinate divided, as Eigen's normalized()), or
// zero for a zero vector.
VPR_HD inline Vec3d unit_or_zero(const Vec3d& n) {
  const double z = dot(n, n);
  if (!(z > 0)) return {0, 0, 0};
  const double s = std::sqrt(z);
  return {n.x / s, n.y / s, n.z / s};
}

VPR_HD inline Vec3d triangle_unit_normal(const float* positions, const uint32_t* indices, size_t g) {
  const uint32_t* u = indices + 3 * g;
  const Vec3d a = load3d(positions, u[0]);
  return unit_or_zero(cross(load3d(positions, u[1]) - a, load3d(positions, u[2]) - a));
}

// The closest point of triangle abc to p, as barycentric weights of a, b, c
// (Ericson, Real-Time Collision Detection, 5.1.5).
VPR_HD inline Vec3d closest_barycentric(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const Vec3d bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Vec3d cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = 1.0 / (va + vb + vc);
  return {1 - (vb + vc) * denom, vb * denom, vc * denom};
}

// Input face f's sample matched (face -1 when the face has no area, no
// labelled corner, or no triangle near its cell faces its way). The sample
// belongs to the cell of its first labelled corner: the refined faces are a
// sixteenth of a cell, so the one-ring searched covers the cell's
// neighbourhood either way.
VPR_HD inline OffsetMatch match_offset_sample(const OffsetMatchView& in, size_t f) {
  OffsetMatch best;
  const uint32_t* t = in.surface_indices + 3 * f;
  const Vec3d a = load3d(in.surface_positions, t[0]), b = load3d(in.surface_positions, t[1]),
              c = load3d(in.surface_positions, t[2]);
  const Vec3d cr = cross(b - a, c - a);
  const double area = 0.5 * norm(cr);
  if (!(area > 0)) return best;
  const Vec3d input_normal = unit_or_zero(cr);
  uint32_t cell = UINT32_MAX;
  for (int k = 0; k < 3 && cell == UINT32_MAX; ++k) cell = in.label[t[k]];
  if (cell == UINT32_MAX || cell >= in.cells) return best;
  const Vec3d s = a + b + c;
  const Vec3d p{s.x / 3, s.y / 3, s.z / 3};
  double best_d = INFINITY;
  for (uint32_t i = in.vert_start[cell]; i < in.vert_start[cell + 1]; ++i) {
    const uint32_t v = in.verts_of[i];
    for (uint32_t j = in.face_start[v]; j < in.face_start[v + 1]; ++j) {
      const uint32_t g = in.faces_of[j];
      const Vec3d n = in.unit_normal[g];
      if (std::fabs(dot(n, input_normal)) < kOffsetSameSide) continue;  // a degenerate one too (n = 0)
      const uint32_t* u = in.indices + 3 * size_t(g);
      const Vec3d x = load3d(in.positions, u[0]), y = load3d(in.positions, u[1]), z = load3d(in.positions, u[2]);
      const Vec3d bc = closest_barycentric(p, x, y, z);
      const double d = norm2(p - (x * bc.x + y * bc.y + z * bc.z));
      if (d < best_d) {
        best_d = d;
        best.face = g;
        best.bary = bc;
        best.normal = n;
        best.residual = dot(n, p - x);
      }
    }
  }
  if (best.face >= 0) best.weight = area;
  return best;
}

// Per output triangle, its samples' terms of the fit's normal equations
// (offset_fit.cpp), summed in sample order: sum w b_k b_l (9), sum w b_k r
// (3), sum w b_k (3).
using OffsetFaceSums = std::array<double, 15>;

VPR_HD inline void add_offset_sample(const OffsetMatch& m, double* s) {
  for (int k = 0; k < 3; ++k) {
    const double wb = m.weight * component(m.bary, k);
    for (int l = 0; l < 3; ++l) s[3 * k + l] += wb * component(m.bary, l);
    s[9 + k] += wb * m.residual;
    s[12 + k] += wb;
  }
}

// The fit's RMS over the samples (a statistic, not used by the solve): the
// sums of w r^2 and of w over blocks of this many samples in order, then the
// blocks' sums in order, so that either twin on any thread count gives one
// result.
constexpr size_t kOffsetRmsBlock = 1024;

// The change in one triangle's sum w r^2 when its corners move by a_k along
// its normal (the fit's linear model: each sample's residual r becomes
// r - sum_k b_k a_k), from the triangle's sums alone:
//   -2 sum_k a_k (sum w b_k r) + sum_k sum_l a_k a_l (sum w b_k b_l).
// The RMS after the fit thus needs no sample kept (they are 72 bytes each,
// 250 MB on igea at 50,000 vertices).
inline double offset_wr2_change(const OffsetFaceSums& s, const std::array<double, 3>& a) {
  double change = 0;
  for (int k = 0; k < 3; ++k) {
    change -= 2 * a[k] * s[9 + k];
    for (int l = 0; l < 3; ++l) change += a[k] * a[l] * s[3 * k + l];
  }
  return change;
}

// The host's arrays behind an OffsetMatchView.
struct OffsetSamples {
  const Mesh* surface = nullptr;
  const std::vector<uint32_t>* label = nullptr;
  uint32_t cells = 0;
  const Mesh* mesh = nullptr;  // read again at every match: the fit moves its vertices between rounds
  const std::vector<uint32_t>* vert_start = nullptr;
  const std::vector<uint32_t>* verts_of = nullptr;
  const std::vector<uint32_t>* face_start = nullptr;
  const std::vector<uint32_t>* faces_of = nullptr;
};

// The samples, matched where they live (host or device), and what the fit
// takes of them; only the triangles' sums and the RMS sums cross over.
class OffsetSampleSet {
 public:
  virtual ~OffsetSampleSet() = default;
  // Matches every sample to the mesh as it is now. per_face: one sum per
  // output triangle; wr2, w: the RMS sums of the residuals.
  virtual Status match(std::vector<OffsetFaceSums>* per_face, double* wr2, double* w) = 0;
};

// A device's sample set for the fit, or an error (the fit then uses the host's).
using OffsetSampleSource = std::function<StatusOr<std::unique_ptr<OffsetSampleSet>>(const OffsetSamples&)>;

namespace cpu {
// Every sample's match, in face order (the reference; tests).
Status match_offset_samples(const OffsetSamples& samples, std::vector<OffsetMatch>* matches);
// The host's sample set: blocks of this many samples matched in parallel,
// each summed in order before the next (a multiple of kOffsetRmsBlock).
constexpr size_t kOffsetMatchBlock = 64 * kOffsetRmsBlock;
std::unique_ptr<OffsetSampleSet> offset_sample_set(const OffsetSamples& samples);
}  // namespace cpu

// GPU twin, built when VPR_HAVE_CUDA (offset_match.cu): the same bits.
namespace cuda {
Status match_offset_samples(const OffsetSamples& samples, std::vector<OffsetMatch>* matches, const ExecContext& ctx);
StatusOr<std::unique_ptr<OffsetSampleSet>> offset_sample_set(const OffsetSamples& samples, const ExecContext& ctx);
}  // namespace cuda

}  // namespace vpr
