// Stage 4 (Section IV-A, Algorithm 1): k-NN graph, parallel advancing front and
// the importance field I = beta^d on the mesh vertices.
#include "saliency/saliency_field.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <flann/flann.hpp>
#include <limits>
#include <optional>
#include <string>
#include <utility>

namespace vpr {

float resolve_depth_scale(const SaliencyFieldOptions& options, double target_spacing, double mean_edge_length) {
  if (options.depth_scale > 0.0f) return options.depth_scale;
  const double ratio = target_spacing / mean_edge_length;
  if (!std::isfinite(ratio) || ratio < 1.0) return 1.0f;
  return float(ratio);
}

Status check_knn_graph_args(size_t n, int k) {
  if (k < 1) return invalid_argument("k-NN graph: k = " + std::to_string(k) + ", it must be at least 1");
  if (n <= size_t(k))
    return invalid_argument("k-NN graph: " + std::to_string(n) + " points (n) cannot have k = " + std::to_string(k) +
                            " neighbours each; n must exceed k");
  if (n > std::numeric_limits<uint32_t>::max())
    return resource_exhausted("k-NN graph: " + std::to_string(n) + " points, the limit is " +
                              std::to_string(std::numeric_limits<uint32_t>::max()));
  return Status::Ok();
}

Status check_advancing_front_args(const uint32_t* neighbors, size_t n, int k) {
  if (k < 1) return invalid_argument("advancing front: k = " + std::to_string(k) + ", it must be at least 1");
  if (n > size_t(std::numeric_limits<int32_t>::max()))
    return resource_exhausted("advancing front: " + std::to_string(n) + " nodes, the limit is " +
                              std::to_string(std::numeric_limits<int32_t>::max()));
  const size_t kk = size_t(k);
  for (size_t i = 0; i < n * kk; ++i) {
    if (neighbors[i] >= n)
      return invalid_argument("advancing front: node " + std::to_string(i / kk) + " lists neighbour " +
                              std::to_string(neighbors[i]) + " but the graph has " + std::to_string(n) + " nodes");
  }
  return Status::Ok();
}

Status check_saliency_field_args(const SaliencyFieldOptions& options, float depth_scale) {
  if (options.k < 1)
    return invalid_argument("saliency field: k = " + std::to_string(options.k) + ", it must be at least 1");
  if (!(options.beta > 0.0f && options.beta < 1.0f))
    return invalid_argument("saliency field: beta = " + std::to_string(options.beta) + ", it must lie in (0, 1)");
  if (!(options.min_importance > 0.0f && options.min_importance <= 1.0f))
    return invalid_argument("saliency field: min_importance = " + std::to_string(options.min_importance) +
                            ", it must lie in (0, 1]");
  if (!(depth_scale >= 1.0f) || !std::isfinite(depth_scale))
    return invalid_argument("saliency field: depth_scale = " + std::to_string(depth_scale) +
                            ", it must be finite and at least 1");
  return Status::Ok();
}

namespace cpu {
namespace {

using KdTree = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;

// Leaf size 12: the middle of FLANN's useful 10-16 range for 3-D points.
constexpr int kLeafSize = 12;
// Extra neighbours fetched beyond k + 1 (self), so that one query usually shows
// a strictly larger distance after the k-th neighbour and needs no retry.
constexpr size_t kTiePad = 3;

struct DistIndex {
  float dist;
  uint32_t index;
  bool operator<(const DistIndex& o) const { return dist < o.dist || (dist == o.dist && index < o.index); }
};

// Per-thread buffers of query_row, reused across the rows of one block.
struct RowScratch {
  explicit RowScratch(size_t capacity) : result(capacity), ids(capacity), dists(capacity) {}
  flann::KNNSimpleResultSet<float> result;
  std::vector<size_t> ids;
  std::vector<float> dists;
  std::vector<DistIndex> sorted;
};

// The k nearest other points of `query`, ordered by (squared distance, index).
// FLANN keeps the first of equally distant candidates it meets, so the K it
// returns contain every point closer than its K-th distance but only some of
// those at it; when that tie reaches the k-th place we ask again for twice as
// many until it does not (or K = n, every point).
void query_row(const KdTree& tree, const float* query, uint32_t self, size_t n, size_t k, size_t base_capacity,
               RowScratch* scratch, uint32_t* row) {
  const flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED, 0.0f, true);
  size_t capacity = base_capacity;
  for (;;) {
    std::optional<flann::KNNSimpleResultSet<float>> wider;
    flann::KNNSimpleResultSet<float>* result = &scratch->result;
    if (capacity != base_capacity) result = &wider.emplace(capacity);
    result->clear();
    tree.findNeighbors(*result, query, params);
    const size_t found = result->size();
    scratch->ids.resize(found);
    scratch->dists.resize(found);
    result->copy(scratch->ids.data(), scratch->dists.data(), found, true);

    std::vector<DistIndex>& sorted = scratch->sorted;
    sorted.clear();
    float worst = 0.0f;
    for (size_t i = 0; i < found; ++i) {
      worst = std::max(worst, scratch->dists[i]);
      if (scratch->ids[i] != self) sorted.push_back({scratch->dists[i], uint32_t(scratch->ids[i])});
    }
    std::sort(sorted.begin(), sorted.end());
    const bool complete = found == n || (sorted.size() >= k && sorted[k - 1].dist < worst);
    if (complete) {
      assert(sorted.size() >= k);
      for (size_t j = 0; j < k; ++j) row[j] = sorted[j].index;
      return;
    }
    capacity = std::min(n, 2 * capacity);
  }
}

}  // namespace

Status knn_graph(const float* points, size_t n, int k, std::vector<uint32_t>* neighbors, const ExecContext&) {
  assert(neighbors != nullptr);
  VPR_RETURN_IF_ERROR(check_knn_graph_args(n, k));
  assert(points != nullptr);

  // FLANN's Matrix wants a non-const pointer; the tree copies the points
  // (reorder = true) and never writes through it.
  const flann::Matrix<float> data(const_cast<float*>(points), n, 3);
  KdTree tree(data, flann::KDTreeSingleIndexParams(kLeafSize, true));
  tree.buildIndex();

  const size_t kk = size_t(k);
  const size_t base_capacity = std::min(n, kk + 1 + kTiePad);
  neighbors->assign(n * kk, 0);
  uint32_t* out = neighbors->data();
  // Each row is computed alone from the shared read-only tree, so blocks may run
  // on any thread in any order.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 512), [&](const tbb::blocked_range<size_t>& r) {
    RowScratch scratch(base_capacity);
    for (size_t i = r.begin(); i != r.end(); ++i)
      query_row(tree, points + 3 * i, uint32_t(i), n, kk, base_capacity, &scratch, out + i * kk);
  });
  return Status::Ok();
}

Status advancing_front(const uint32_t* neighbors, size_t n, int k, const uint8_t* is_seed, std::vector<int32_t>* depth,
                       const ExecContext&) {
  assert(depth != nullptr);
  VPR_RETURN_IF_ERROR(check_advancing_front_args(neighbors, n, k));
  const size_t kk = size_t(k);

  depth->assign(n, -1);
  std::vector<uint32_t> unreached;
  for (size_t i = 0; i < n; ++i) {
    if (is_seed[i])
      (*depth)[i] = 0;
    else
      unreached.push_back(uint32_t(i));
  }

  // Algorithm 1, one parallel sweep per front step. Reads see only the depths of
  // earlier steps (writes go to `hit`, applied after the sweep), so each step is
  // exactly one BFS level whatever the thread count.
  std::vector<uint8_t> hit;
  const int32_t* d_read = depth->data();
  for (int32_t step = 0; !unreached.empty(); ++step) {
    hit.assign(unreached.size(), 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, unreached.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t u = r.begin(); u != r.end(); ++u) {
        const uint32_t* row = neighbors + size_t(unreached[u]) * kk;
        for (size_t j = 0; j < kk; ++j) {
          if (d_read[row[j]] == step) {
            hit[u] = 1;
            break;
          }
        }
      }
    });
    size_t kept = 0;
    for (size_t u = 0; u < unreached.size(); ++u) {
      if (hit[u])
        (*depth)[unreached[u]] = step + 1;
      else
        unreached[kept++] = unreached[u];
    }
    if (kept == unreached.size()) break;  // the front stopped: the rest is unreachable
    unreached.resize(kept);
  }
  return Status::Ok();
}

Status saliency_field(const float* vertices, size_t vertex_count, const float* saliency_points,
                      size_t saliency_point_count, const SaliencyFieldOptions& options, float depth_scale,
                      std::vector<float>* importance, const ExecContext& ctx) {
  assert(importance != nullptr);
  VPR_RETURN_IF_ERROR(check_saliency_field_args(options, depth_scale));

  // No features at all: every vertex matters equally (uniform remeshing).
  if (saliency_point_count == 0) {
    importance->assign(vertex_count, 1.0f);
    return Status::Ok();
  }

  const size_t n = saliency_point_count + vertex_count;
  std::vector<float> nodes(3 * n);
  std::memcpy(nodes.data(), saliency_points, 3 * saliency_point_count * sizeof(float));
  if (vertex_count > 0)
    std::memcpy(nodes.data() + 3 * saliency_point_count, vertices, 3 * vertex_count * sizeof(float));

  std::vector<uint32_t> neighbors;
  VPR_RETURN_IF_ERROR(knn_graph(nodes.data(), n, options.k, &neighbors, ctx));

  std::vector<uint8_t> is_seed(n, 0);
  std::fill(is_seed.begin(), is_seed.begin() + saliency_point_count, uint8_t(1));
  std::vector<int32_t> depth;
  VPR_RETURN_IF_ERROR(advancing_front(neighbors.data(), n, options.k, is_seed.data(), &depth, ctx));

  importance->resize(vertex_count);
  float* out = importance->data();
  const int32_t* vertex_depth = depth.data() + saliency_point_count;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, vertex_count, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v)
      out[v] = importance_from_depth(vertex_depth[v], options.beta, options.min_importance, depth_scale);
  });
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
