// Stage 5 (Section IV-B, Eq. 7-16) on the GPU: visual quantity per face
// (Eq. 7-8), counts from an exact fixed-point prefix scan (Eq. 9), one thread
// per sample (Eq. 11-16). The per-element math is sampling_kernels.h, shared
// with the CPU twin; this file is built with --fmad=false so that it rounds
// exactly as the host does.
#include <algorithm>
#include <cub/device/device_scan.cuh>
#include <string>

#include "resample/adaptive_sampling.h"
#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"

namespace vpr::cuda {
namespace {

__global__ void visual_quantity_kernel(const float* positions, const uint32_t* indices, const float* importance,
                                       size_t face_count, double* quantity) {
  const size_t f = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (f < face_count) quantity[f] = face_visual_quantity(positions, indices, importance, f);
}

__global__ void quantize_kernel(const double* quantity, size_t face_count, double max_quantity, QuantitySum* fixed) {
  const size_t f = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (f < face_count) fixed[f] = quantize_quantity(quantity[f], max_quantity);
}

struct AddSums {
  __device__ QuantitySum operator()(const QuantitySum& a, const QuantitySum& b) const { return a + b; }
};

// inclusive: the face_count inclusive prefix sums P_1 .. P_F (P_0 = 0).
__global__ void offsets_kernel(const QuantitySum* inclusive, size_t face_count, uint32_t target, uint32_t* offsets,
                               uint32_t* counts) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i > face_count) return;
  const QuantitySum total = inclusive[face_count - 1];
  const uint32_t here = rounded_offset(i == 0 ? QuantitySum(0) : inclusive[i - 1], total, target);
  offsets[i] = here;
  if (i < face_count) counts[i] = rounded_offset(inclusive[i], total, target) - here;
}

// Sample s belongs to the face f with offsets[f] <= s < offsets[f + 1] (the
// last such f when empty faces repeat an offset).
__device__ size_t face_of_sample(const uint32_t* offsets, size_t face_count, uint32_t s) {
  size_t lo = 0, hi = face_count;  // offsets[lo] <= s < offsets[hi]
  while (hi - lo > 1) {
    const size_t mid = lo + (hi - lo) / 2;
    if (offsets[mid] <= s)
      lo = mid;
    else
      hi = mid;
  }
  return lo;
}

__global__ void sample_kernel(const float* positions, const uint32_t* indices, const float* importance,
                              const uint32_t* counts, const uint32_t* offsets, size_t face_count, uint32_t total,
                              uint32_t adaptive_min_samples, uint64_t seed, float* points, float* point_importance) {
  const uint32_t s = blockIdx.x * blockDim.x + threadIdx.x;
  if (s >= total) return;
  const size_t f = face_of_sample(offsets, face_count, s);
  // Section IV-B: too few samples to follow a density; uniform is unbiased.
  const bool adaptive = counts[f] >= adaptive_min_samples;
  sample_point(positions, indices, importance, f, s - offsets[f], seed, adaptive, points + 3 * size_t(s),
               point_importance + s);
}

// The mesh and its importance on the device.
struct DeviceMesh {
  DeviceBuffer<float> positions, importance;
  DeviceBuffer<uint32_t> indices;
  Status upload(const Mesh& mesh, const float* vertex_importance, const ExecContext& ctx) {
    VPR_RETURN_IF_ERROR(positions.upload(mesh.positions.data(), mesh.positions.size(), ctx));
    VPR_RETURN_IF_ERROR(indices.upload(mesh.indices.data(), mesh.indices.size(), ctx));
    return importance.upload(vertex_importance, mesh.vertex_count(), ctx);
  }
};

}  // namespace

Status visual_quantity(const Mesh& mesh, const float* importance, std::vector<double>* quantity,
                       const ExecContext& ctx) {
  assert(quantity != nullptr && importance != nullptr);
  VPR_RETURN_IF_ERROR(check_importance(importance, mesh.vertex_count()));
  const size_t nf = mesh.face_count();
  quantity->resize(nf);
  if (nf == 0) return Status::Ok();
  DeviceMesh d;
  VPR_RETURN_IF_ERROR(d.upload(mesh, importance, ctx));
  DeviceBuffer<double> d_quantity;
  VPR_RETURN_IF_ERROR(d_quantity.allocate(nf, ctx));
  visual_quantity_kernel<<<blocks_for(nf), kBlock, 0, stream_of(ctx)>>>(d.positions.get(), d.indices.get(),
                                                                        d.importance.get(), nf, d_quantity.get());
  VPR_CUDA_LAUNCHED("visual_quantity_kernel");
  VPR_RETURN_IF_ERROR(d_quantity.download(quantity->data(), nf));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream_of(ctx)));
  return Status::Ok();
}

Status distribute_counts(const double* quantity, size_t face_count, uint32_t target, std::vector<uint32_t>* counts,
                         std::vector<uint32_t>* offsets, const ExecContext& ctx) {
  assert(counts != nullptr && offsets != nullptr);
  double max_quantity = 0.0;
  VPR_RETURN_IF_ERROR(check_quantities(quantity, face_count, &max_quantity));  // face_count >= 1 from here
  const cudaStream_t stream = stream_of(ctx);
  DeviceBuffer<double> d_quantity;
  DeviceBuffer<QuantitySum> fixed, inclusive;
  DeviceBuffer<uint32_t> d_counts, d_offsets;
  VPR_RETURN_IF_ERROR(d_quantity.upload(quantity, face_count, ctx));
  VPR_RETURN_IF_ERROR(fixed.allocate(face_count, ctx));
  VPR_RETURN_IF_ERROR(inclusive.allocate(face_count, ctx));
  VPR_RETURN_IF_ERROR(d_counts.allocate(face_count, ctx));
  VPR_RETURN_IF_ERROR(d_offsets.allocate(face_count + 1, ctx));

  quantize_kernel<<<blocks_for(face_count), kBlock, 0, stream>>>(d_quantity.get(), face_count, max_quantity,
                                                                 fixed.get());
  VPR_CUDA_LAUNCHED("quantize_kernel");
  // Eq. (9): integer sums are exact, so the scan's order of additions is free.
  size_t temp_bytes = 0;
  VPR_CUDA_TRY(
      cub::DeviceScan::InclusiveScan(nullptr, temp_bytes, fixed.get(), inclusive.get(), AddSums{}, face_count, stream));
  DeviceBuffer<uint8_t> temp;
  VPR_RETURN_IF_ERROR(temp.allocate(std::max<size_t>(temp_bytes, 1), ctx));
  VPR_CUDA_TRY(cub::DeviceScan::InclusiveScan(temp.get(), temp_bytes, fixed.get(), inclusive.get(), AddSums{},
                                              face_count, stream));
  offsets_kernel<<<blocks_for(face_count + 1), kBlock, 0, stream>>>(inclusive.get(), face_count, target,
                                                                    d_offsets.get(), d_counts.get());
  VPR_CUDA_LAUNCHED("offsets_kernel");
  counts->resize(face_count);
  offsets->resize(face_count + 1);
  VPR_RETURN_IF_ERROR(d_counts.download(counts->data(), face_count));
  VPR_RETURN_IF_ERROR(d_offsets.download(offsets->data(), face_count + 1));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

Status sample_triangles(const Mesh& mesh, const float* importance, const uint32_t* counts, const uint32_t* offsets,
                        const SamplingOptions& options, std::vector<float>* points,
                        std::vector<float>* point_importance, const ExecContext& ctx) {
  assert(points != nullptr && point_importance != nullptr);
  const size_t nf = mesh.face_count();
  VPR_RETURN_IF_ERROR(check_offsets(counts, offsets, nf));
  const uint32_t total = offsets[nf];
  points->resize(3 * size_t(total));
  point_importance->resize(total);
  if (total == 0) return Status::Ok();
  const cudaStream_t stream = stream_of(ctx);
  DeviceMesh d;
  VPR_RETURN_IF_ERROR(d.upload(mesh, importance, ctx));
  DeviceBuffer<uint32_t> d_counts, d_offsets;
  VPR_RETURN_IF_ERROR(d_counts.upload(counts, nf, ctx));
  VPR_RETURN_IF_ERROR(d_offsets.upload(offsets, nf + 1, ctx));
  DeviceBuffer<float> d_points, d_importance;
  VPR_RETURN_IF_ERROR(d_points.allocate(3 * size_t(total), ctx));
  VPR_RETURN_IF_ERROR(d_importance.allocate(total, ctx));
  // Each sample's numbers come from (seed, face, j): threads are independent.
  sample_kernel<<<blocks_for(total), kBlock, 0, stream>>>(
      d.positions.get(), d.indices.get(), d.importance.get(), d_counts.get(), d_offsets.get(), nf, total,
      options.adaptive_min_samples, options.seed, d_points.get(), d_importance.get());
  VPR_CUDA_LAUNCHED("sample_kernel");
  VPR_RETURN_IF_ERROR(d_points.download(points->data(), 3 * size_t(total)));
  VPR_RETURN_IF_ERROR(d_importance.download(point_importance->data(), total));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

}  // namespace vpr::cuda
