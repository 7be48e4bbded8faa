// Stage 4 for the surface back half (our addition; the paper's own field is
// saliency_field.h, kept for --density paper): where a person is likely to
// look, as one value per input vertex with range.
//
// Three cues, measured on ../shared/gaze/ (docs/perception.md):
//  - Surface centre-surround (after Lee, Varshney and Jacobs, "Mesh saliency",
//    SIGGRAPH 2005): the convex part of the mean curvature (concave edges
//    weighed down, concave_weight below) at the input's own scale and averaged
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
//  - Image-space features, when the caller has them: the saliency points of
//    the paper's front half (inner-feature and thin-silhouette pixels of every
//    view, unprojected, unproject.h). Their weighted count within 2 sigma of a
//    vertex keeps the cue's strength instead of a yes/no flag: a vertex near
//    many feature pixels, in many views, scores higher. It enters as a third
//    map beside the two curvature scales, over its median and capped like
//    them, and the three are averaged (Itti, Koch and Niebur 1998 sum their
//    normalized conspicuity maps the same way).
// The raw value is then normalized by rank to [min_importance, 1], so that the
// field spans its whole range whatever the input (equal raw values share their
// mean rank; one vertex, or one set of equal ones, is at the maximum).
//
// Every vertex's value is independent work over a uniform grid of cells two
// coarse scales wide (the weights' support), shared by both twins; the GPU
// twin runs the per-vertex weighted averages and then the maps and the rank
// normalization on the device (attention_finish.cuh), the CPU twin
// finish_attention_field.
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
  // The curvature cue's concave edges count this much of their dihedral
  // angle (the caller computes the curvature it passes in with
  // surface_density.h's mean_curvatures(mesh, concave_weight)): people look
  // at convex protrusions and rims far more than at the creases where
  // surfaces meet (docs/perception.md, "Convexity": on ../shared/gaze/ the
  // mean AUC rises on every model as this falls, 0.680 at 1 to 0.708 at 0).
  // 1: plain |H|; 0: the convex part only. In [0, 1].
  float concave_weight = 0.0f;
  // Floor of the field, so that no region is starved: values lie in
  // [min_importance, 1]. In (0, 1].
  float min_importance = 0.2f;
  // The image cue (feature points near a vertex, see above), when the caller
  // has the points (--image-cue). Off by default: on ../shared/gaze/ it did
  // not raise the mean AUC (docs/perception.md, "What each cue contributes").
  bool image_cue = false;
};

// Image-space feature points for the field: #points x 3 floats in the
// vertices' space (null and 0 when the caller has none).
struct FeaturePoints {
  const float* xyz = nullptr;
  size_t count = 0;
};

// Argument check shared by both twins: options in range, curvature non-null
// when vertices are given, feature points non-null when counted.
Status check_attention_field_args(const AttentionFieldOptions& options, size_t vertex_count, const float* curvature,
                                  FeaturePoints features = {});

// Whether the field takes the image cue: asked for, and there are points.
inline bool use_image_cue(const AttentionFieldOptions& options, FeaturePoints features) {
  return options.image_cue && features.count > 0;
}

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

// The image-space feature points binned on the vertex grid's cells (same lo,
// cell and dims): sorted holds x, y, z, 1 per point, order their input index.
// Points outside the grid go to its border cells (the scan clamps alike).
VertexGrid bin_points(const VertexGrid& shape, const float* points, size_t point_count);

// Sums over the entries of a grid within 2 sigma of p, over the 27 cells
// around p's cell: *weight = sum of w, *sum = sum of w x value (the 4th float
// of an entry). The weight (1 - d^2 / (2 sigma)^2)^2 stands in for Lee et
// al.'s Gaussian truncated at 2 sigma (equal at 0, within 0.05 up to 1 sigma,
// at most 0.16 lower in its tail): plain float products, so both twins
// (compiled without FMA contraction) get the same bits.
VPR_HD inline void weighted_sums_near(const float* sorted, const uint32_t* cell_start, const float lo[3], float cell,
                                      const int dims[3], float px, float py, float pz, float sigma, double* sum_out,
                                      double* weight_out) {
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
      // Without a branch: a point out of reach adds +0.0, which leaves the
      // (never negative) sums' bits as they are, so the result is the same as
      // skipping it, and its value is never read (an infinite |H| far away
      // does not turn the sum into NaN).
      for (uint32_t t = cell_start[row + x0]; t < cell_start[row + x1 + 1]; ++t) {
        const float dx = sorted[4 * t] - px, dy = sorted[4 * t + 1] - py, dz = sorted[4 * t + 2] - pz;
        const float d2 = dx * dx + dy * dy + dz * dz;
        const bool near = !(d2 > reach2);
        const float falloff = 1.0f - d2 * inv_reach2;
        const double w = near ? double(falloff * falloff) : 0.0;
        const double value = near ? double(sorted[4 * t + 3]) : 0.0;
        sum += w * value;
        weight += w;
      }
    }
  }
  *sum_out = sum;
  *weight_out = weight;
}

// Weighted mean of |H| within 2 sigma of vertex p (itself included).
VPR_HD inline float coarse_curvature_mean(const float* sorted, const uint32_t* cell_start, const float lo[3],
                                          float cell, const int dims[3], float px, float py, float pz, float sigma) {
  double sum, weight;
  weighted_sums_near(sorted, cell_start, lo, cell, dims, px, py, pz, sigma, &sum, &weight);
  return weight > 0 ? float(sum / weight) : 0.0f;
}

// Weighted count of feature points within 2 sigma of vertex p (a grid from
// bin_points): the image cue's strength at p.
VPR_HD inline float feature_point_density(const float* sorted, const uint32_t* cell_start, const float lo[3],
                                          float cell, const int dims[3], float px, float py, float pz, float sigma) {
  double sum, weight;
  weighted_sums_near(sorted, cell_start, lo, cell, dims, px, py, pz, sigma, &sum, &weight);
  return float(weight);
}

// What the field needs from the vertices and their curvature alone: the
// vertex grid and the fine cue map (|H| over its median, capped). A caller
// that has the curvature early makes it ahead (the pipeline, beside stages
// 1-3) and hands it to attention_field; otherwise the twins make it.
struct AttentionPrep {
  VertexGrid grid;
  std::vector<double> fine;
};
AttentionPrep prepare_attention(const float* vertices, const float* curvature, size_t vertex_count,
                                const AttentionFieldOptions& options);

// The raw cue of every vertex and its rank normalization (the host part of
// both twins): fine = prepare_attention's map; coarse =
// coarse_curvature_mean per vertex (original order); density =
// feature_point_density per vertex, or null without feature points.
void finish_attention_field(const float* vertices, const std::vector<double>& fine, const float* coarse,
                            const float* density, const float* visibility, size_t vertex_count,
                            const AttentionFieldOptions& options, std::vector<float>* importance);

namespace cpu {

// vertices: #V x 3 floats, model space (the pipeline's normalized copy: unit
// bounding-box diagonal, but any units work). curvature: #V values of |mean
// curvature| (surface_density.h's mean_curvature), per model unit.
// visibility: null, or #V values in [0, 1] that scale the raw cue (the share
// of views that see the vertex, visibility.h). features: the image cue's
// points, or none (the field is then curvature, bias and visibility only).
// importance: #V values in [min_importance, 1]. No vertices: an empty field.
// prep: null, or prepare_attention(vertices, curvature, #V, options)'s
// result, the same bits as the twin making it.
Status attention_field(const float* vertices, const float* curvature, const float* visibility, FeaturePoints features,
                       size_t vertex_count, const AttentionFieldOptions& options, std::vector<float>* importance,
                       const ExecContext& ctx, const AttentionPrep* prep = nullptr);

}  // namespace cpu

// GPU twin, built when VPR_HAVE_CUDA (attention_field.cu): the same contract;
// the weighted means, maps and ranks run on ctx's stream, in the same order
// and arithmetic as on the CPU, so the field is identical.
namespace cuda {

Status attention_field(const float* vertices, const float* curvature, const float* visibility, FeaturePoints features,
                       size_t vertex_count, const AttentionFieldOptions& options, std::vector<float>* importance,
                       const ExecContext& ctx, const AttentionPrep* prep = nullptr);

}  // namespace cuda
}  // namespace vpr
