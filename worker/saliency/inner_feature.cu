// Inner-feature filter (Section III-A, Eq. 1-3), GPU twin: one thread per
// pixel runs gaussian_sum_at and inner_feature_test (image_kernels.h). The
// weights are the CPU twin's fixed-point integers (gaussian_weights_fixed) and
// the sum is exact in int32 on either device, so the pixels are identical.
#include <cmath>
#include <string>
#include <utility>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "saliency/image_kernels.h"
#include "saliency/image_saliency_device.cuh"
#include "saliency/inner_feature.h"

namespace vpr::cuda {
namespace detail {
namespace {

__global__ void inner_feature_kernel(const uint8_t* __restrict__ filtered, const uint8_t* __restrict__ foreground,
                                     const uint8_t* __restrict__ exclude, int w, int h, const int* __restrict__ weights,
                                     int n, int c, uint8_t* __restrict__ out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  const long long i = static_cast<long long>(y) * w + x;
  bool feature = foreground[i] && !(exclude && exclude[i]);  // only the object carries features
  // Eq. (2)-(3): darker than the weighted mean by more than C.
  if (feature) feature = inner_feature_test(gaussian_sum_at(filtered, w, h, x, y, weights, n), filtered[i], c);
  out[i] = feature ? 1 : 0;
}

}  // namespace

Status launch_inner_features(const uint8_t* filtered, const uint8_t* foreground, const uint8_t* exclude, int w, int h,
                             const int* weights, int n, int c, uint8_t* features, const ExecContext& ctx) {
  inner_feature_kernel<<<pixel_grid(w, h), pixel_block(), 0, stream_of(ctx)>>>(filtered, foreground, exclude, w, h,
                                                                               weights, n, c, features);
  VPR_CUDA_LAUNCHED("inner_feature_kernel");
  return Status::Ok();
}

}  // namespace detail

Status inner_features(const GrayImage& filtered, const Mask& foreground, int n, float sigma, int c, Mask* features,
                      const ExecContext& ctx) {
  assert(features != nullptr);
  VPR_RETURN_IF_ERROR(check_inner_features_args(filtered, foreground, n, sigma, c));
  const int w = filtered.width, h = filtered.height;
  VPR_RETURN_IF_ERROR(detail::require_stream(ctx, "inner_features"));
  const std::vector<int> weights = gaussian_weights_fixed(n, sigma);
  const size_t pixels = filtered.pixels.size();
  DeviceBuffer<uint8_t> gray, fg, out;
  DeviceBuffer<int> device_weights;
  VPR_RETURN_IF_ERROR(gray.upload(filtered.pixels.data(), pixels, ctx));
  VPR_RETURN_IF_ERROR(fg.upload(foreground.pixels.data(), pixels, ctx));
  VPR_RETURN_IF_ERROR(device_weights.upload(weights.data(), weights.size(), ctx));
  VPR_RETURN_IF_ERROR(out.allocate(pixels, ctx));
  VPR_RETURN_IF_ERROR(
      detail::launch_inner_features(gray.get(), fg.get(), nullptr, w, h, device_weights.get(), n, c, out.get(), ctx));
  Mask result(w, h, 0);
  VPR_RETURN_IF_ERROR(out.download(result.pixels.data(), pixels));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream_of(ctx)));
  *features = std::move(result);
  return Status::Ok();
}

}  // namespace vpr::cuda
