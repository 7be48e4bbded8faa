// Stage 4 for the surface back half (our addition; the paper's own field is
// saliency_field.h, kept for --density paper): where a person is likely to
// look, as one value per input vertex with range.
//
// Three cues, measured on ../shared/gaze/ (docs/perception.md):
//  - Surface centre-surround (after Lee, Varshney and Jacobs, "Mesh saliency",
//    SIGGRAPH 2005): |mean curvature| at the input's own scale and averaged
//    with Gaussian-like weights at a coarser scale (a fraction of the bounding-box
//    diagonal), each over its median and capped, so that a small bump on a
//    smooth surface stands out by its strength, not by a yes/no flag.
//  - A front-top bias: a person stands in front of an upright object and a
//    little above its middle (Lavoue et al., "Visual attention for rendered 3D
//    shapes", Eurographics 2018, report the bias towards the top and the
//    front). The model's own frame says where that is: +y up, +z front, the
//    convention of glTF 2.0 and of most scanned and modelled meshes. The
//    nearness of a vertex to a viewer in that direction scales the cue; it is
//    a bias, not a gate (the far side keeps 1 - view_bias of its weight).
//  - Visibility over the rendered views (visibility.h), when the caller has
//    it: the raw value is multiplied by the share of views that see the vertex.
// The raw value is then normalized by rank to [min_importance, 1], so that the
// field spans its whole range whatever the input (equal raw values share their
// mean rank; one vertex, or one set of equal ones, is at the maximum).
//
// Every vertex's value is independent work over a uniform grid of cells two
// coarse scales wide (the weights' support), shared by both twins; the GPU
// twin runs the per-vertex weighted averages, the rank normalization stays on
// the host.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/exec_context.h"
#include "core/status.h"
#include "core/vec3.h"

namespace vpr {

struct AttentionFieldOptions {
  // Lee et al. 2005: coarse Gaussian sigma as a fraction of the bounding-box
  // diagonal (their scales are 2..6 eps with eps = 0.3% of the diagonal; 1%
  // is the middle one). Weights as coarse_curvature_mean says, within 2 sigma.
  float coarse_sigma = 0.01f;
  // Each curvature scale over its median is capped here before the two are
  // averaged and square-rooted (the density's curvature term is also a square
  // root: spacing follows the radius of curvature).
  float curvature_cap = 4.0f;
  // Front-top bias: raw value x (1 - view_bias + view_bias x nearness), with
  // nearness in [0, 1] along view_direction. 0 turns the bias off; in [0, 1].
  float view_bias = 0.75f;
  // Towards the viewer, in the model's own frame (not normalized): +y up, +z
  // front, halfway between (a viewer in front and above the middle).
  Vec3 view_direction = {0.0f, 1.0f, 1.0f};
  // Floor of the field, so that no region is starved: values lie in
  // [min_importance, 1]. In (0, 1].
  float min_importance = 0.2f;
};

// Argument check shared by both twins: options in range, curvature non-null
// when vertices are given.
Status check_attention_field_args(const AttentionFieldOptions& options, size_t vertex_count, const float* curvature);

// A uniform grid over the vertices with cells at least 2 sigma wide (model
// units): vertices sorted by cell (x fastest), cell_start[c]..cell_start[c + 1]
// the sorted positions of cell c. Built on the host for both twins.
struct VertexGrid {
  float sigma = 1;  // coarse_sigma x the bounding-box diagonal
  float lo[3] = {0, 0, 0};
  float cell = 1;
  int dims[3] = {1, 1, 1};
  std::vector<uint32_t> order;       // #V: original index of each sorted entry
  std::vector<float> sorted;         // #V x 4: x, y, z, |H| in sorted order
  std::vector<uint32_t> cell_start;  // cells + 1
};
VertexGrid build_vertex_grid(const float* vertices, const float* curvature, size_t vertex_count,
                             const AttentionFieldOptions& options);

// Weighted mean of |H| within 2 sigma of vertex p (itself included), over the
// 27 cells around p's cell. The weight (1 - d^2 / (2 sigma)^2)^2 stands in for
// Lee et al.'s Gaussian truncated at 2 sigma (equal at 0, within 0.05 up to
// 1 sigma, at most 0.16 lower in its tail): plain float products, so both
// twins (compiled without FMA contraction) get the same bits.
VPR_HD inline float coarse_curvature_mean(const float* sorted, const uint32_t* cell_start, const float lo[3],
                                          float cell, const int dims[3], float px, float py, float pz, float sigma) {
  int c[3];
  const float q[3] = {px, py, pz};
  for (int a = 0; a < 3; ++a) {
    int t = int((q[a] - lo[a]) / cell);
    c[a] = t < 0 ? 0 : (t >= dims[a] ? dims[a] - 1 : t);
  }
  const float reach2 = 4.0f * sigma * sigma;
  const float inv_reach2 = 1.0f / reach2;
  double sum = 0, weight = 0;
  for (int z = c[2] - 1; z <= c[2] + 1; ++z) {
    if (z < 0 || z >= dims[2]) continue;
    for (int y = c[1] - 1; y <= c[1] + 1; ++y) {
      if (y < 0 || y >= dims[1]) continue;
      const int x0 = c[0] > 0 ? c[0] - 1 : 0, x1 = c[0] + 1 < dims[0] ? c[0] + 1 : dims[0] - 1;
      const size_t row = (size_t(z) * size_t(dims[1]) + size_t(y)) * size_t(dims[0]);
      for (uint32_t t = cell_start[row + x0]; t < cell_start[row + x1 + 1]; ++t) {
        const float dx = sorted[4 * t] - px, dy = sorted[4 * t + 1] - py, dz = sorted[4 * t + 2] - pz;
        const float d2 = dx * dx + dy * dy + dz * dz;
        if (d2 > reach2) continue;
        const float falloff = 1.0f - d2 * inv_reach2;
        const double w = double(falloff * falloff);
        sum += w * double(sorted[4 * t + 3]);
        weight += w;
      }
    }
  }
  return weight > 0 ? float(sum / weight) : 0.0f;
}

// The raw cue of every vertex and its rank normalization (the host part of
// both twins): coarse = coarse_curvature_mean per vertex (original order).
void finish_attention_field(const float* vertices, const float* curvature, const float* coarse, const float* visibility,
                            size_t vertex_count, const AttentionFieldOptions& options, std::vector<float>* importance);

namespace cpu {

// vertices: #V x 3 floats, model space (the pipeline's normalized copy: unit
// bounding-box diagonal, but any units work). curvature: #V values of |mean
// curvature| (surface_density.h's mean_curvature), per model unit.
// visibility: null, or #V values in [0, 1] that scale the raw cue (the share
// of views that see the vertex, visibility.h).
// importance: #V values in [min_importance, 1]. No vertices: an empty field.
Status attention_field(const float* vertices, const float* curvature, const float* visibility, size_t vertex_count,
                       const AttentionFieldOptions& options, std::vector<float>* importance, const ExecContext& ctx);

}  // namespace cpu

// GPU twin, built when VPR_HAVE_CUDA (attention_field.cu): the same contract;
// the weighted means run on ctx's stream, in the same order and float
// arithmetic as on the CPU, so the field is identical.
namespace cuda {

Status attention_field(const float* vertices, const float* curvature, const float* visibility, size_t vertex_count,
                       const AttentionFieldOptions& options, std::vector<float>* importance, const ExecContext& ctx);

}  // namespace cuda
}  // namespace vpr
