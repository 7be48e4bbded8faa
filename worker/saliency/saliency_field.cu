// Stage 4 (Section IV-A, Algorithm 1) on the GPU: the k-NN graph over a
// uniform grid (knn_grid.cuh: exact, FLANN's float distances, ties by index,
// so the graph equals the CPU twin's), the parallel advancing front one level
// per launch, and I = beta^d per vertex (importance_from_depth, shared).
#include <algorithm>
#include <cstring>
#include <limits>
#include <string>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "gpu/knn_grid.cuh"
#include "saliency/saliency_field.h"

namespace vpr::cuda {
namespace {

// Levels launched between two looks at the host: a front that stops mid-batch
// costs the remaining launches (each exits at once), a look costs a sync.
constexpr int kLevelsPerSync = 16;

Status check_k_fits(int k, const char* stage) {
  if (k > kMaxGridK)
    return unavailable(std::string(stage) + ": k = " + std::to_string(k) +
                       ", the GPU twin handles k <= " + std::to_string(kMaxGridK) + "; use the CPU twin");
  return Status::Ok();
}

// One thread per point, in grid order (neighbouring threads search
// neighbouring cells). Row of point i: its k nearest others, nearest first.
template <int K>
__global__ void knn_graph_kernel(GridView grid, int k, uint32_t* neighbors) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= grid.n) return;
  const GridParams gp = *grid.params;
  const float4 p = grid.points[t];
  const uint32_t self = __float_as_uint(p.w);
  TopK<K> top;
  top.k = k;
  grid_knn(grid, gp, p.x, p.y, p.z, self, &top);
  // Fewer than k only with non-finite coordinates: fill with self so that every
  // index stays in range for the front.
  uint32_t* row = neighbors + size_t(self) * size_t(k);
  for (int j = 0; j < k; ++j) row[j] = j < top.count ? top.index[j] : self;
}

// Algorithm 1, pull form (as the CPU twin): an unreached node takes depth
// step + 1 when one of its neighbours has depth step. Writes during the
// launch are step + 1, never step, so reading them in place keeps each
// launch exactly one BFS level.
__global__ void front_level_kernel(const uint32_t* neighbors, uint32_t n, int k, int32_t step, int32_t* depth,
                                   int32_t* last_level) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || depth[i] != -1) return;
  const uint32_t* row = neighbors + size_t(i) * size_t(k);
  for (int j = 0; j < k; ++j) {
    if (depth[row[j]] == step) {
      depth[i] = step + 1;
      *last_level = step + 1;  // every writer stores the same value
      return;
    }
  }
}

__global__ void seed_depth_kernel(const uint8_t* is_seed, uint32_t seed_count, uint32_t n, int32_t* depth) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const bool seed = is_seed ? is_seed[i] != 0 : i < seed_count;
  depth[i] = seed ? 0 : -1;
}

__global__ void importance_kernel(const int32_t* depth, uint32_t count, float beta, float min_importance,
                                  float depth_scale, float* importance) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < count) importance[v] = importance_from_depth(depth[v], beta, min_importance, depth_scale);
}

// The graph of n device points (n > k, k <= kMaxGridK) into neighbors (n x k).
Status build_graph(const float* points, size_t n, int k, DeviceBuffer<uint32_t>* neighbors, const ExecContext& ctx) {
  KnnGrid grid;
  VPR_RETURN_IF_ERROR(grid.build(points, n, ctx));
  VPR_RETURN_IF_ERROR(neighbors->allocate(n * size_t(k), ctx));
  const GridView view = grid.view();
  return dispatch_k(k, [&](auto kk) -> Status {
    knn_graph_kernel<decltype(kk)::value>
        <<<blocks_for(n, kSearchBlock), kSearchBlock, 0, stream_of(ctx)>>>(view, k, neighbors->get());
    VPR_CUDA_LAUNCHED("knn_graph_kernel");
    return Status::Ok();
  });
}

// Runs the front over depths already seeded (0 or -1), kLevelsPerSync
// levels per look at last_level: when a level reaches nobody, later levels
// cannot either.
Status run_front(const uint32_t* neighbors, size_t n, int k, int32_t* depth, const ExecContext& ctx) {
  const cudaStream_t stream = stream_of(ctx);
  DeviceBuffer<int32_t> last_level;
  VPR_RETURN_IF_ERROR(last_level.allocate(1, ctx));
  VPR_RETURN_IF_ERROR(last_level.zero());
  for (int32_t step = 0;; step += kLevelsPerSync) {
    for (int32_t s = step; s < step + kLevelsPerSync; ++s) {
      front_level_kernel<<<blocks_for(n), kBlock, 0, stream>>>(neighbors, uint32_t(n), k, s, depth, last_level.get());
      VPR_CUDA_LAUNCHED("front_level_kernel");
    }
    int32_t reached = 0;
    VPR_RETURN_IF_ERROR(last_level.download(&reached, 1));
    VPR_CUDA_TRY(cudaStreamSynchronize(stream));
    if (reached < step + kLevelsPerSync) return Status::Ok();
  }
}

}  // namespace

Status knn_graph(const float* points, size_t n, int k, std::vector<uint32_t>* neighbors, const ExecContext& ctx) {
  assert(neighbors != nullptr);
  VPR_RETURN_IF_ERROR(check_knn_graph_args(n, k));
  VPR_RETURN_IF_ERROR(check_k_fits(k, "k-NN graph"));
  DeviceBuffer<float> d_points;
  VPR_RETURN_IF_ERROR(d_points.upload(points, 3 * n, ctx));
  DeviceBuffer<uint32_t> d_neighbors;
  VPR_RETURN_IF_ERROR(build_graph(d_points.get(), n, k, &d_neighbors, ctx));
  neighbors->resize(n * size_t(k));
  VPR_RETURN_IF_ERROR(d_neighbors.download(neighbors->data(), neighbors->size()));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream_of(ctx)));
  return Status::Ok();
}

Status advancing_front(const uint32_t* neighbors, size_t n, int k, const uint8_t* is_seed, std::vector<int32_t>* depth,
                       const ExecContext& ctx) {
  assert(depth != nullptr);
  VPR_RETURN_IF_ERROR(check_advancing_front_args(neighbors, n, k));
  depth->assign(n, -1);
  if (n == 0) return Status::Ok();
  DeviceBuffer<uint32_t> d_neighbors;
  DeviceBuffer<uint8_t> d_seed;
  DeviceBuffer<int32_t> d_depth;
  VPR_RETURN_IF_ERROR(d_neighbors.upload(neighbors, n * size_t(k), ctx));
  VPR_RETURN_IF_ERROR(d_seed.upload(is_seed, n, ctx));
  VPR_RETURN_IF_ERROR(d_depth.allocate(n, ctx));
  seed_depth_kernel<<<blocks_for(n), kBlock, 0, stream_of(ctx)>>>(d_seed.get(), 0, uint32_t(n), d_depth.get());
  VPR_CUDA_LAUNCHED("seed_depth_kernel");
  VPR_RETURN_IF_ERROR(run_front(d_neighbors.get(), n, k, d_depth.get(), ctx));
  VPR_RETURN_IF_ERROR(d_depth.download(depth->data(), n));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream_of(ctx)));
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
  // The graph's nodes: the saliency points (seeds), then the vertices.
  const size_t n = saliency_point_count + vertex_count;
  VPR_RETURN_IF_ERROR(check_knn_graph_args(n, options.k));
  VPR_RETURN_IF_ERROR(check_k_fits(options.k, "saliency field"));
  if (n > size_t(std::numeric_limits<int32_t>::max()))
    return resource_exhausted("saliency field: " + std::to_string(n) + " nodes, the limit is " +
                              std::to_string(std::numeric_limits<int32_t>::max()));
  const cudaStream_t stream = stream_of(ctx);
  DeviceBuffer<float> nodes;
  VPR_RETURN_IF_ERROR(nodes.allocate(3 * n, ctx));
  VPR_RETURN_IF_ERROR(staged_upload(nodes.get(), saliency_points, 3 * saliency_point_count * sizeof(float), stream));
  if (vertex_count > 0)
    VPR_RETURN_IF_ERROR(
        staged_upload(nodes.get() + 3 * saliency_point_count, vertices, 3 * vertex_count * sizeof(float), stream));

  DeviceBuffer<uint32_t> neighbors;
  VPR_RETURN_IF_ERROR(build_graph(nodes.get(), n, options.k, &neighbors, ctx));
  DeviceBuffer<int32_t> depth;
  VPR_RETURN_IF_ERROR(depth.allocate(n, ctx));
  seed_depth_kernel<<<blocks_for(n), kBlock, 0, stream>>>(nullptr, uint32_t(saliency_point_count), uint32_t(n),
                                                          depth.get());
  VPR_CUDA_LAUNCHED("seed_depth_kernel");
  VPR_RETURN_IF_ERROR(run_front(neighbors.get(), n, options.k, depth.get(), ctx));

  importance->resize(vertex_count);
  if (vertex_count == 0) return Status::Ok();
  DeviceBuffer<float> d_importance;
  VPR_RETURN_IF_ERROR(d_importance.allocate(vertex_count, ctx));
  importance_kernel<<<blocks_for(vertex_count), kBlock, 0, stream>>>(
      depth.get() + saliency_point_count, uint32_t(vertex_count), options.beta, options.min_importance, depth_scale,
      d_importance.get());
  VPR_CUDA_LAUNCHED("importance_kernel");
  VPR_RETURN_IF_ERROR(d_importance.download(importance->data(), vertex_count));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

}  // namespace vpr::cuda
