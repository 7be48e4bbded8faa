// Stage 3 (Section III-C), GPU twin: feature pixels back to 3D through the
// depth buffer. A flag per pixel, an inclusive scan (cub) for each point's
// slot, and one thread per flagged pixel writing its point: a stable
// compaction, so the points come out in the CPU twin's row-major order. The
// arithmetic is the CPU's, in double, operation for operation, with the
// round-to-nearest intrinsics so that nvcc fuses no multiply-add: the points
// match the CPU twin's to the last bit on IEEE hosts that do not contract
// either (x86-64 without -mfma, our build).
#include <climits>
#include <cub/device/device_scan.cuh>
#include <string>
#include <vector>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "saliency/image_saliency_device.cuh"
#include "saliency/unproject.h"

namespace vpr::cuda {
namespace detail {
namespace {

// inv_view_proj by value: 128 bytes of kernel parameters.
struct Matrix {
  double m[16];  // column-major
};

__global__ void flag_kernel(const uint8_t* __restrict__ features, const float* __restrict__ depth, int n,
                            int* __restrict__ flags) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) flags[i] = (features[i] && depth[i] < 1.0f) ? 1 : 0;  // depth 1: no surface
}

// m[a] * x + m[b] * y + m[c] * z + m[d], evaluated left to right as views.cpp's
// transform_point.
__device__ inline double row_dot(const Matrix& mat, int r, double x, double y, double z) {
  const double* m = mat.m;
  double s = __dmul_rn(m[r], x);
  s = __dadd_rn(s, __dmul_rn(m[4 + r], y));
  s = __dadd_rn(s, __dmul_rn(m[8 + r], z));
  return __dadd_rn(s, m[12 + r]);
}

// slots: inclusive prefix sum of the flags, so pixel i's point is slots[i] - 1.
__global__ void unproject_kernel(const int* __restrict__ flags, const int* __restrict__ slots,
                                 const float* __restrict__ depth, int w, int h, Matrix inv_view_proj,
                                 float* __restrict__ points) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= w * h || !flags[i]) return;
  const int x = i % w, y = i / w;
  // Pixel centre; row 0 is the top of the image, GL window coordinates count
  // from the bottom (as unproject.cpp).
  const double ndc_x = __dadd_rn(__ddiv_rn(__dmul_rn(2.0, __dadd_rn(double(x), 0.5)), double(w)), -1.0);
  const double ndc_y = __dadd_rn(__ddiv_rn(__dmul_rn(2.0, __dadd_rn(double(h - y), -0.5)), double(h)), -1.0);
  const double ndc_z = __dadd_rn(__dmul_rn(2.0, double(depth[i])), -1.0);
  const double px = row_dot(inv_view_proj, 0, ndc_x, ndc_y, ndc_z);
  const double py = row_dot(inv_view_proj, 1, ndc_x, ndc_y, ndc_z);
  const double pz = row_dot(inv_view_proj, 2, ndc_x, ndc_y, ndc_z);
  const double pw = row_dot(inv_view_proj, 3, ndc_x, ndc_y, ndc_z);
  float* out = points + 3ll * (slots[i] - 1);
  out[0] = float(__ddiv_rn(px, pw));
  out[1] = float(__ddiv_rn(py, pw));
  out[2] = float(__ddiv_rn(pz, pw));
}

}  // namespace

Status unproject_device(const uint8_t* features, const float* depth, int w, int h, const View& view,
                        std::vector<float>* points, const ExecContext& ctx) {
  const size_t pixels = size_t(w) * size_t(h);
  if (pixels == 0) return Status::Ok();
  if (pixels > size_t(INT_MAX)) {
    return invalid_argument("unproject_features: " + std::to_string(w) + " x " + std::to_string(h) +
                            " pixels is more than the GPU twin's int indexing takes");
  }
  const int n = int(pixels);
  cudaStream_t stream = stream_of(ctx);
  DeviceBuffer<int> flags, slots;
  VPR_RETURN_IF_ERROR(flags.allocate(pixels, ctx));
  VPR_RETURN_IF_ERROR(slots.allocate(pixels, ctx));
  flag_kernel<<<blocks_for(pixels), kBlock, 0, stream>>>(features, depth, n, flags.get());
  VPR_CUDA_LAUNCHED("flag_kernel");

  size_t temp_bytes = 0;
  VPR_CUDA_TRY(cub::DeviceScan::InclusiveSum(nullptr, temp_bytes, flags.get(), slots.get(), n, stream));
  DeviceBuffer<uint8_t> temp;
  VPR_RETURN_IF_ERROR(temp.allocate(temp_bytes, ctx));
  VPR_CUDA_TRY(cub::DeviceScan::InclusiveSum(temp.get(), temp_bytes, flags.get(), slots.get(), n, stream));

  // The host needs the count to size the output: the scan's last element.
  int count = 0;
  VPR_CUDA_TRY(cudaMemcpyAsync(&count, slots.get() + (n - 1), sizeof(int), cudaMemcpyDeviceToHost, stream));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  if (count == 0) return Status::Ok();

  Matrix m;
  for (int k = 0; k < 16; ++k) m.m[k] = view.inv_view_proj[size_t(k)];
  DeviceBuffer<float> device_points;
  VPR_RETURN_IF_ERROR(device_points.allocate(3 * size_t(count), ctx));
  unproject_kernel<<<blocks_for(pixels), kBlock, 0, stream>>>(flags.get(), slots.get(), depth, w, h, m,
                                                              device_points.get());
  VPR_CUDA_LAUNCHED("unproject_kernel");
  std::vector<float> host(3 * size_t(count));
  VPR_RETURN_IF_ERROR(device_points.download(host.data(), host.size()));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  points->insert(points->end(), host.begin(), host.end());
  return Status::Ok();
}

}  // namespace detail

Status unproject_features(const Mask& features, const FloatImage& depth, const View& view, std::vector<float>* points,
                          const ExecContext& ctx) {
  assert(points != nullptr);
  VPR_RETURN_IF_ERROR(check_unproject_args(features, depth, view));
  const int w = depth.width, h = depth.height;
  if (w <= 0 || h <= 0) return Status::Ok();
  VPR_RETURN_IF_ERROR(detail::require_stream(ctx, "unproject_features"));
  const size_t pixels = size_t(w) * size_t(h);
  DeviceBuffer<uint8_t> device_features;
  DeviceBuffer<float> device_depth;
  VPR_RETURN_IF_ERROR(device_features.upload(features.pixels.data(), pixels, ctx));
  VPR_RETURN_IF_ERROR(device_depth.upload(depth.pixels.data(), pixels, ctx));
  return detail::unproject_device(device_features.get(), device_depth.get(), w, h, view, points, ctx);
}

}  // namespace vpr::cuda
