// Stage 4 (Section IV-A, Algorithm 1): the saliency field. A k-NN graph over the
// saliency points and the mesh vertices; a parallel advancing front from the
// saliency points gives every vertex a depth d (graph hops to the nearest
// saliency point); importance I = beta^(d - 1), floored and stretched as
// documented on SaliencyFieldOptions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/exec_context.h"
#include "core/status.h"
#include "core/vec3.h"

namespace vpr {

struct SaliencyFieldOptions {
  int k = 10;         // Algorithm 1: neighbours per node of the k-NN graph (k >= 1)
  float beta = 0.7f;  // Algorithm 1: I = beta^d, 0 < beta < 1
  // Our addition: a floor on I, so that regions far from every feature still get
  // samples (the paper's I tends to 0 there and the mesher would leave holes).
  // 0 < min_importance <= 1; unreachable vertices get exactly this value.
  float min_importance = 0.2f;
  // Our addition: depth is divided by this scale before I = beta^(d / scale), so
  // the field's reach is measured in output sample spacings rather than input
  // graph hops (dense inputs otherwise get a band only a few input edges wide).
  // 0 = automatic (target spacing / mean graph edge length, at least 1): see
  // resolve_depth_scale.
  float depth_scale = 0.0f;
};

// options.depth_scale if it is set (> 0), else max(1, target_spacing /
// mean_edge_length). Both lengths in model units; a non-positive or non-finite
// ratio resolves to 1.
float resolve_depth_scale(const SaliencyFieldOptions& options, double target_spacing, double mean_edge_length);

// Algorithm 1's I = beta^d with our floor and scale (see saliency_field below):
// depth d >= 1 -> max(min_importance, beta^((d - 1) / depth_scale)); d < 0
// (unreachable) -> min_importance. Computed in double so every device agrees.
VPR_HD inline float importance_from_depth(int32_t depth, float beta, float min_importance, float depth_scale) {
  if (depth < 0) return min_importance;
  const double hops = depth > 1 ? double(depth - 1) : 0.0;
  const double value = std::pow(double(beta), hops / double(depth_scale));
  return value > double(min_importance) ? float(value) : min_importance;
}

// Argument checks shared by the CPU and GPU twins, so both fail alike.
// knn_graph: k >= 1, k < n, n fits uint32 indices.
Status check_knn_graph_args(size_t n, int k);
// advancing_front: k >= 1, n fits int32 depths, every neighbour index < n.
Status check_advancing_front_args(const uint32_t* neighbors, size_t n, int k);
// saliency_field: options in range (see SaliencyFieldOptions), depth_scale
// finite and >= 1.
Status check_saliency_field_args(const SaliencyFieldOptions& options, float depth_scale);

namespace cpu {

// points: n x 3 floats. neighbors: n x k indices of the k nearest other points
// (the query's own index excluded; duplicates of the query at distance 0 are
// neighbours), nearest first; equal squared distances (in float, as FLANN
// computes them) are ordered by the smaller index, including at the k-th place,
// so the graph is exact and independent of the thread count.
// n <= k: INVALID_ARGUMENT.
Status knn_graph(const float* points, size_t n, int k, std::vector<uint32_t>* neighbors, const ExecContext& ctx);

// Parallel advancing front (Algorithm 1) in pull form: a node reached at no
// earlier step takes depth d + 1 when one of its own k neighbours has depth d.
// Equals BFS on the directed graph with an edge j -> i iff j is in N(i).
// neighbors: n x k (as from knn_graph); is_seed: n flags. Seeds have depth 0;
// unreachable nodes get -1.
Status advancing_front(const uint32_t* neighbors, size_t n, int k, const uint8_t* is_seed, std::vector<int32_t>* depth,
                       const ExecContext& ctx);

// Importance of each mesh vertex (#V floats in [min_importance, 1]).
// vertices: #V x 3 floats; saliency_points: #S x 3 floats, both model space.
// The graph's nodes are the saliency points (the seeds) followed by the
// vertices. A vertex at depth d >= 1 gets
//   I = max(min_importance, beta^((d - 1) / depth_scale)),
// so vertices one hop from a saliency point get I = 1; unreachable vertices get
// min_importance. With no saliency points at all every vertex gets I = 1: there
// is nothing to adapt to, and the remeshing is uniform.
// depth_scale: as in the options, already resolved (>= 1).
Status saliency_field(const float* vertices, size_t vertex_count, const float* saliency_points,
                      size_t saliency_point_count, const SaliencyFieldOptions& options, float depth_scale,
                      std::vector<float>* importance, const ExecContext& ctx);

}  // namespace cpu

// GPU twins, built when VPR_HAVE_CUDA (saliency_field.cu, knn_grid.cu): same
// contracts and results as the CPU twins above (graph and depths identical;
// importance within 1e-6, as pow differs in the last bit between devices).
// Host arrays in and out; the work runs on ctx's stream, device memory is
// charged to ctx.budget (RESOURCE_EXHAUSTED past it). The k-NN search keeps
// its lists in registers: k > 64 is UNAVAILABLE (use the CPU twin).
namespace cuda {

Status knn_graph(const float* points, size_t n, int k, std::vector<uint32_t>* neighbors, const ExecContext& ctx);

Status advancing_front(const uint32_t* neighbors, size_t n, int k, const uint8_t* is_seed, std::vector<int32_t>* depth,
                       const ExecContext& ctx);

Status saliency_field(const float* vertices, size_t vertex_count, const float* saliency_points,
                      size_t saliency_point_count, const SaliencyFieldOptions& options, float depth_scale,
                      std::vector<float>* importance, const ExecContext& ctx);

}  // namespace cuda
}  // namespace vpr
