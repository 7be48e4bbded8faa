// GPU twin of the attention field (attention_field.h): the per-vertex weighted
// means of |H| and weighted counts of feature points over the host-built
// grids, one thread a vertex, with the same arithmetic as the CPU twin
// (coarse_curvature_mean, feature_point_density, compiled without FMA
// contraction); then the cue maps and the rank normalization on the device
// as well (attention_finish.cu), so only the field comes back.
#include <cassert>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "saliency/attention_field.h"
#include "saliency/attention_finish.cuh"

namespace vpr::cuda {
namespace {

struct GridShape {
  float lo[3];
  float cell;
  int dims[3];
};

// One thread per grid entry, in the grid's order (neighbouring threads scan
// the same cells: fewer distinct loads per warp than in vertex order, and the
// same sum per vertex); sorted holds each vertex's own position, so every
// vertex's mean has the CPU twin's bits. coarse: #V outputs in original order.
__global__ void coarse_curvature_kernel(const uint32_t* order, uint32_t n, const float* sorted,
                                        const uint32_t* cell_start, GridShape shape, float sigma, float* coarse) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= n) return;
  coarse[order[t]] = coarse_curvature_mean(sorted, cell_start, shape.lo, shape.cell, shape.dims, sorted[4 * t],
                                           sorted[4 * t + 1], sorted[4 * t + 2], sigma);
}

// The image cue: weighted count of feature points near each vertex.
__global__ void feature_density_kernel(const float* vertices, uint32_t n, const float* sorted,
                                       const uint32_t* cell_start, GridShape shape, float sigma, float* density) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= n) return;
  density[v] = feature_point_density(sorted, cell_start, shape.lo, shape.cell, shape.dims, vertices[3 * v],
                                     vertices[3 * v + 1], vertices[3 * v + 2], sigma);
}

}  // namespace

Status attention_field(const float* vertices, const float* curvature, const float* visibility, FeaturePoints features,
                       size_t n, const AttentionFieldOptions& options, std::vector<float>* importance,
                       const ExecContext& ctx, const AttentionPrep* prep) {
  assert(importance != nullptr);
  VPR_RETURN_IF_ERROR(check_attention_field_args(options, n, curvature, features));
  importance->clear();
  if (n == 0) return Status::Ok();
  AttentionPrep own;
  if (!prep) own = prepare_attention(vertices, curvature, n, options);
  const VertexGrid& grid = prep ? prep->grid : own.grid;
  assert(grid.order.size() == n);
  GridShape shape;
  for (int a = 0; a < 3; ++a) {
    shape.lo[a] = grid.lo[a];
    shape.dims[a] = grid.dims[a];
  }
  shape.cell = grid.cell;

  DeviceBuffer<float> d_sorted, d_coarse;
  DeviceBuffer<uint32_t> d_cell_start, d_order;
  VPR_RETURN_IF_ERROR(d_sorted.upload(grid.sorted.data(), grid.sorted.size(), ctx));
  VPR_RETURN_IF_ERROR(d_order.upload(grid.order.data(), grid.order.size(), ctx));
  VPR_RETURN_IF_ERROR(d_cell_start.upload(grid.cell_start.data(), grid.cell_start.size(), ctx));
  VPR_RETURN_IF_ERROR(d_coarse.allocate(n, ctx));
  const cudaStream_t stream = stream_of(ctx);
  coarse_curvature_kernel<<<blocks_for(n), kBlock, 0, stream>>>(d_order.get(), uint32_t(n), d_sorted.get(),
                                                                d_cell_start.get(), shape, grid.sigma, d_coarse.get());
  VPR_CUDA_LAUNCHED("coarse_curvature_kernel");
  VertexGrid points;  // host copies live until the stream is synchronized (the finish does)
  DeviceBuffer<float> d_vertices, d_points, d_density;
  DeviceBuffer<uint32_t> d_point_start;
  if (use_image_cue(options, features)) {
    VPR_RETURN_IF_ERROR(d_vertices.upload(vertices, 3 * n, ctx));
    points = bin_points(grid, features.xyz, features.count);
    VPR_RETURN_IF_ERROR(d_points.upload(points.sorted.data(), points.sorted.size(), ctx));
    VPR_RETURN_IF_ERROR(d_point_start.upload(points.cell_start.data(), points.cell_start.size(), ctx));
    VPR_RETURN_IF_ERROR(d_density.allocate(n, ctx));
    feature_density_kernel<<<blocks_for(n), kBlock, 0, stream>>>(d_vertices.get(), uint32_t(n), d_points.get(),
                                                                 d_point_start.get(), shape, points.sigma,
                                                                 d_density.get());
    VPR_CUDA_LAUNCHED("feature_density_kernel");
  }
  // The maps, the raw cue and the ranks on the device too (attention_finish.cuh).
  return finish_attention_on_device(d_sorted.get(), d_order.get(), d_coarse.get(),
                                    d_density.size() ? d_density.get() : nullptr, prep ? prep->fine : own.fine,
                                    visibility, n, options, importance, ctx);
}

}  // namespace vpr::cuda
