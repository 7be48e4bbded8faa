// GPU twins of the edge smoothing (edge_smoothing.h): one thread a vertex a
// pass, two buffers in turn; the arithmetic of smoothed_vector and
// smoothed_scalar.
#include <algorithm>
#include <string>
#include <utility>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "surface/edge_smoothing.h"

namespace vpr::cuda {
namespace {

__global__ void smooth_kernel(const uint32_t* offset, const uint32_t* neighbor, const Vec3d* now, uint32_t n,
                              Vec3d* next) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < n) next[v] = smoothed_vector(offset, neighbor, now, v);
}

__global__ void smooth_kernel(const uint32_t* offset, const uint32_t* neighbor, const float* now, uint32_t n,
                              float* next) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < n) next[v] = smoothed_scalar(offset, neighbor, now, v);
}

template <class T>
Status smooth(const MeshEdges& edges, int passes, std::vector<T>* values, const ExecContext& ctx) {
  const size_t nv = edges.vertex_count();
  if (values->size() != nv)
    return invalid_argument("edge smoothing: " + std::to_string(values->size()) + " values for " + std::to_string(nv) +
                            " vertices");
  if (nv == 0 || passes <= 0) return Status::Ok();
  const cudaStream_t stream = stream_of(ctx);
  DeviceBuffer<uint32_t> d_offset, d_neighbor;
  DeviceBuffer<T> a, b;
  VPR_RETURN_IF_ERROR(UploadBatch(ctx)
                          .add(&d_offset, edges.offset.data(), edges.offset.size())
                          .add(&d_neighbor, edges.neighbor.data(), edges.neighbor.size())
                          .add(&a, values->data(), nv)
                          .run());
  VPR_RETURN_IF_ERROR(b.allocate(nv, ctx));
  for (int pass = 0; pass < passes; ++pass) {
    smooth_kernel<<<blocks_for(nv), kBlock, 0, stream>>>(d_offset.get(), d_neighbor.get(), a.get(), uint32_t(nv),
                                                         b.get());
    VPR_CUDA_LAUNCHED("smooth_kernel");
    std::swap(a, b);
  }
  VPR_RETURN_IF_ERROR(a.download(values->data(), nv));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

}  // namespace

Status smooth_over_edges(const MeshEdges& edges, int passes, std::vector<Vec3d>* values, const ExecContext& ctx) {
  return smooth(edges, passes, values, ctx);
}

Status smooth_over_edges(const MeshEdges& edges, int passes, std::vector<float>* values, const ExecContext& ctx) {
  return smooth(edges, passes, values, ctx);
}

}  // namespace vpr::cuda
