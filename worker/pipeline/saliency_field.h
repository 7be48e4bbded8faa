// Stage 4 (Section IV-A, Algorithm 1): the saliency field. A k-NN graph over the
// saliency points and the mesh vertices; a parallel advancing front from the
// saliency points gives every vertex a depth d; importance I = beta^d.
#pragma once

#include <cstdint>
#include <vector>

#include "exec_context.h"
#include "status.h"

namespace vpr {

struct SaliencyFieldOptions {
  int k = 10;            // Algorithm 1: neighbours per node of the k-NN graph
  float beta = 0.7f;     // Algorithm 1: I = beta^d
  // Our addition: a floor on I, so that regions far from every feature still get
  // samples (the paper's I tends to 0 there and the mesher would leave holes).
  float min_importance = 0.2f;
  // Our addition: depth is divided by this scale before I = beta^(d / scale), so
  // the field's reach is measured in output sample spacings rather than input
  // graph hops (dense inputs otherwise get a band only a few input edges wide).
  // 0 = automatic (target spacing / mean graph edge length, at least 1).
  float depth_scale = 0.0f;
};

namespace cpu {

// neighbors: n x k indices of the k nearest other points (self excluded),
// nearest first; ties broken by the smaller index. Exact (FLANN kd-tree).
Status knn_graph(const float* points, size_t n, int k, std::vector<uint32_t>* neighbors, const ExecContext& ctx);

// Parallel advancing front (Algorithm 1) in pull form: a node reached at no
// earlier step takes depth d + 1 when one of its own k neighbours has depth d.
// Seeds have depth 0; unreachable nodes get -1.
Status advancing_front(const uint32_t* neighbors, size_t n, int k, const uint8_t* is_seed,
                       std::vector<int32_t>* depth, const ExecContext& ctx);

// Importance of each mesh vertex (#V floats in [min_importance, 1]).
// depth_scale: as in the options, already resolved (>= 1).
Status saliency_field(const float* vertices, size_t vertex_count, const float* saliency_points,
                      size_t saliency_point_count, const SaliencyFieldOptions& options, float depth_scale,
                      std::vector<float>* importance, const ExecContext& ctx);

}  // namespace cpu
}  // namespace vpr
