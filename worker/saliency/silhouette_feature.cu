// Silhouette-feature filter (Section III-B, Eq. 4-5), GPU twin: one thread
// per pixel runs the CPU twin's per-pixel rules (silhouette_at, skeleton_at,
// near_thick_part in image_kernels.h). The skeleton kernel is float, but it
// rounds the same on either device (see skeleton_response_at), so the masks
// are identical.
#include <cmath>
#include <string>
#include <utility>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "saliency/image_kernels.h"
#include "saliency/image_saliency_device.cuh"
#include "saliency/silhouette_feature.h"

namespace vpr::cuda {
namespace detail {
namespace {

__global__ void silhouette_kernel(const uint8_t* __restrict__ foreground, int w, int h, uint8_t* __restrict__ out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  out[static_cast<long long>(y) * w + x] = silhouette_at(foreground, w, h, x, y) ? 1 : 0;
}

// The CPU's `masked` array: D on the foreground, 0 elsewhere.
__global__ void mask_distance_kernel(const float* __restrict__ dist, const uint8_t* __restrict__ foreground, size_t n,
                                     float* __restrict__ masked) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) masked[i] = foreground[i] ? dist[i] : 0.f;
}

// Eq. (5). skeleton_at<true> everywhere: inside the image it reads the same
// samples as the CPU's unchecked variant, in the same order.
__global__ void skeleton_kernel(const float* __restrict__ masked, int w, int h, int m, uint8_t* __restrict__ out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  out[static_cast<long long>(y) * w + x] = skeleton_at<true>(masked, w, h, x, y, m) ? 1 : 0;
}

// Order-independent reductions for thin_features: the largest distance over the
// foreground (non-negative floats order like their bit patterns, +inf
// included) and whether any skeleton pixel exists.
__global__ void thin_stats_kernel(const float* __restrict__ dist, const uint8_t* __restrict__ foreground,
                                  const uint8_t* __restrict__ skeleton, size_t n, unsigned* stats) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  unsigned max_bits = 0, any = 0;
  if (i < n) {
    if (foreground[i]) max_bits = __float_as_uint(fmaxf(dist[i], 0.f));
    any = skeleton[i] != 0;
  }
  // One atomic per warp.
  for (int offset = 16; offset > 0; offset >>= 1) {
    max_bits = max(max_bits, __shfl_down_sync(0xffffffffu, max_bits, offset));
    any |= __shfl_down_sync(0xffffffffu, any, offset);
  }
  if ((threadIdx.x & 31) == 0) {
    if (max_bits) atomicMax(&stats[0], max_bits);
    if (any) atomicOr(&stats[1], 1u);
  }
}

__global__ void thin_kernel(const uint8_t* __restrict__ foreground, const uint8_t* __restrict__ silhouette,
                            const float* __restrict__ dist, const float* __restrict__ to_skeleton, int w, int h,
                            float threshold_px, const unsigned* __restrict__ stats, const uint8_t* __restrict__ inner,
                            uint8_t* __restrict__ thin, uint8_t* __restrict__ features) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  const long long i = static_cast<long long>(y) * w + x;
  bool is_thin = false;
  if (silhouette[i]) {
    // With no skeleton at all, the largest distance stands in for the feature
    // size of the whole view (cpu::thin_features).
    const bool all_thin = stats[1] == 0 && __uint_as_float(stats[0]) < threshold_px;
    const bool thin_parts_count = threshold_px > kSkeletonMinDistance;
    is_thin = all_thin || to_skeleton[i] < threshold_px ||
              (thin_parts_count && !near_thick_part(dist, foreground, w, h, x, y));
  }
  thin[i] = is_thin ? 1 : 0;
  if (features) features[i] = (inner[i] || is_thin) ? 1 : 0;
}

}  // namespace

Status launch_silhouette(const uint8_t* foreground, int w, int h, uint8_t* out, const ExecContext& ctx) {
  silhouette_kernel<<<pixel_grid(w, h), pixel_block(), 0, stream_of(ctx)>>>(foreground, w, h, out);
  VPR_CUDA_LAUNCHED("silhouette_kernel");
  return Status::Ok();
}

Status launch_skeleton(const float* masked, int w, int h, int m, uint8_t* out, const ExecContext& ctx) {
  skeleton_kernel<<<pixel_grid(w, h), pixel_block(), 0, stream_of(ctx)>>>(masked, w, h, m, out);
  VPR_CUDA_LAUNCHED("skeleton_kernel");
  return Status::Ok();
}

Status thin_features_device(const uint8_t* foreground, const uint8_t* silhouette, const uint8_t* skeleton,
                            const float* silhouette_distance, int w, int h, float threshold_px, uint8_t* thin,
                            const uint8_t* inner, uint8_t* features_out, const ExecContext& ctx) {
  assert(features_out == nullptr || inner != nullptr);
  const size_t n = size_t(w) * size_t(h);
  // Feature size: distance to the skeleton, needed on silhouette pixels only.
  DeviceBuffer<float> to_skeleton;
  DeviceBuffer<unsigned> stats;  // [0]: bits of the largest foreground distance, [1]: any skeleton pixel
  VPR_RETURN_IF_ERROR(to_skeleton.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(stats.allocate(2, ctx));
  VPR_RETURN_IF_ERROR(stats.zero());
  VPR_RETURN_IF_ERROR(distance_transform_device(skeleton, w, h, silhouette, to_skeleton.get(), ctx));
  thin_stats_kernel<<<blocks_for(n), kBlock, 0, stream_of(ctx)>>>(silhouette_distance, foreground, skeleton, n,
                                                                  stats.get());
  VPR_CUDA_LAUNCHED("thin_stats_kernel");
  thin_kernel<<<pixel_grid(w, h), pixel_block(), 0, stream_of(ctx)>>>(foreground, silhouette, silhouette_distance,
                                                                      to_skeleton.get(), w, h, threshold_px,
                                                                      stats.get(), inner, thin, features_out);
  VPR_CUDA_LAUNCHED("thin_kernel");
  return Status::Ok();
}

}  // namespace detail

namespace {

// Downloads a device mask into *out and waits for it.
Status finish(const DeviceBuffer<uint8_t>& device, int w, int h, Mask* out, const ExecContext& ctx) {
  Mask result(w, h, 0);
  VPR_RETURN_IF_ERROR(device.download(result.pixels.data(), result.pixels.size()));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream_of(ctx)));
  *out = std::move(result);
  return Status::Ok();
}

}  // namespace

Status silhouette_pixels(const Mask& foreground, Mask* silhouette, const ExecContext& ctx) {
  assert(silhouette != nullptr);
  VPR_RETURN_IF_ERROR(check_silhouette_pixels_args(foreground));
  const int w = foreground.width, h = foreground.height;
  VPR_RETURN_IF_ERROR(detail::require_stream(ctx, "silhouette_pixels"));
  DeviceBuffer<uint8_t> fg, out;
  VPR_RETURN_IF_ERROR(fg.upload(foreground.pixels.data(), foreground.pixels.size(), ctx));
  VPR_RETURN_IF_ERROR(out.allocate(foreground.pixels.size(), ctx));
  VPR_RETURN_IF_ERROR(detail::launch_silhouette(fg.get(), w, h, out.get(), ctx));
  return finish(out, w, h, silhouette, ctx);
}

Status skeleton(const FloatImage& silhouette_distance, const Mask& foreground, int lambda, Mask* skeleton,
                const ExecContext& ctx) {
  assert(skeleton != nullptr);
  VPR_RETURN_IF_ERROR(check_skeleton_args(silhouette_distance, foreground, lambda));
  const int w = silhouette_distance.width, h = silhouette_distance.height;
  VPR_RETURN_IF_ERROR(detail::require_stream(ctx, "skeleton"));
  const size_t n = size_t(w) * size_t(h);
  DeviceBuffer<float> dist, masked;
  DeviceBuffer<uint8_t> fg, out;
  VPR_RETURN_IF_ERROR(dist.upload(silhouette_distance.pixels.data(), n, ctx));
  VPR_RETURN_IF_ERROR(fg.upload(foreground.pixels.data(), n, ctx));
  VPR_RETURN_IF_ERROR(masked.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(out.allocate(n, ctx));
  detail::mask_distance_kernel<<<blocks_for(n), kBlock, 0, stream_of(ctx)>>>(dist.get(), fg.get(), n, masked.get());
  VPR_CUDA_LAUNCHED("mask_distance_kernel");
  // Eq. (5): the kernel spans lambda + 1 pixels, lambda / 2 each way.
  VPR_RETURN_IF_ERROR(detail::launch_skeleton(masked.get(), w, h, lambda / 2, out.get(), ctx));
  return finish(out, w, h, skeleton, ctx);
}

Status thin_features(const Mask& foreground, const Mask& silhouette, const Mask& skeleton,
                     const FloatImage& silhouette_distance, float threshold_px, Mask* thin, const ExecContext& ctx) {
  assert(thin != nullptr);
  VPR_RETURN_IF_ERROR(check_thin_features_args(foreground, silhouette, skeleton, silhouette_distance, threshold_px));
  const int w = foreground.width, h = foreground.height;
  VPR_RETURN_IF_ERROR(detail::require_stream(ctx, "thin_features"));
  const size_t n = size_t(w) * size_t(h);
  DeviceBuffer<uint8_t> fg, sil, skel, out;
  DeviceBuffer<float> dist;
  VPR_RETURN_IF_ERROR(fg.upload(foreground.pixels.data(), n, ctx));
  VPR_RETURN_IF_ERROR(sil.upload(silhouette.pixels.data(), n, ctx));
  VPR_RETURN_IF_ERROR(skel.upload(skeleton.pixels.data(), n, ctx));
  VPR_RETURN_IF_ERROR(dist.upload(silhouette_distance.pixels.data(), n, ctx));
  VPR_RETURN_IF_ERROR(out.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(detail::thin_features_device(fg.get(), sil.get(), skel.get(), dist.get(), w, h, threshold_px,
                                                   out.get(), nullptr, nullptr, ctx));
  return finish(out, w, h, thin, ctx);
}

}  // namespace vpr::cuda
