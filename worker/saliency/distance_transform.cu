// Distance transform (Eq. 4), GPU twin. The same two separable passes as the
// CPU twin (Felzenszwalb and Huttenlocher 2012), each parallel:
//  1. per column, one thread sweeps down and up for the distance g to the
//     nearest seed in that column (integers, as the CPU's column_pass);
//  2. per pixel, d^2 = min over columns x' of (x - x')^2 + g(x', y)^2, searched
//     outward from x and stopped once (x - x')^2 alone reaches the best value,
//     instead of FH's sequential lower envelope: the cost is about twice the
//     distance per pixel, and every pixel runs in parallel.
// Both give the exact integer minimum, and the distance is the float of the
// correctly rounded double square root on either device, so the maps are
// bit-identical to the CPU twin's.
#include <climits>
#include <cmath>
#include <string>
#include <utility>

#include "saliency/distance_transform.h"
#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "saliency/image_saliency_device.cuh"

namespace vpr::cuda {
namespace detail {
namespace {

constexpr int kNoSeed = -1;  // column without any seed

// Pass 1 (the CPU's column_pass): g[y * w + x] = |y - nearest seed row| in
// column x, or kNoSeed. Threads of a warp take adjacent columns, so every row
// step is one coalesced access.
__global__ void column_pass_kernel(const uint8_t* __restrict__ seeds, int w, int h, int* __restrict__ g) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  if (x >= w) return;
  int last = INT_MIN / 2;
#pragma unroll 8
  for (int y = 0; y < h; ++y) {  // nearest seed above (or at) y
    const long long i = static_cast<long long>(y) * w + x;
    if (seeds[i]) last = y;
    g[i] = last < 0 ? kNoSeed : y - last;
  }
  last = INT_MAX / 2;
#pragma unroll 8
  for (int y = h - 1; y >= 0; --y) {  // nearest seed below
    const long long i = static_cast<long long>(y) * w + x;
    if (seeds[i]) last = y;
    if (last < h) {
      const int below = last - y;
      const int above = g[i];
      if (above == kNoSeed || below < above) g[i] = below;
    }
  }
}

// Pass 2: exact min over the row of (x - x')^2 + g(x')^2, in int64 as the CPU.
__global__ void row_pass_kernel(const int* __restrict__ g, int w, int h, const uint8_t* __restrict__ needed,
                                float* __restrict__ dist) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  const long long i = static_cast<long long>(y) * w + x;
  if (needed && !needed[i]) {
    dist[i] = 0.f;
    return;
  }
  const int* row = g + static_cast<long long>(y) * w;
  long long best = LLONG_MAX;
  for (int r = 0; r < w; ++r) {  // r = |x - x'|
    const long long r2 = static_cast<long long>(r) * r;
    if (r2 >= best) break;  // every farther column costs at least r^2
    const int left = x - r, right = x + r;
    if (left < 0 && right >= w) break;
    if (left >= 0) {
      const int gl = row[left];
      if (gl != kNoSeed) best = min(best, r2 + static_cast<long long>(gl) * gl);
    }
    if (r > 0 && right < w) {
      const int gr = row[right];
      if (gr != kNoSeed) best = min(best, r2 + static_cast<long long>(gr) * gr);
    }
  }
  // The CPU twin's float(sqrt(double(d2))): IEEE double sqrt, then round to float.
  dist[i] = best == LLONG_MAX ? INFINITY : static_cast<float>(sqrt(static_cast<double>(best)));
}

}  // namespace

Status distance_transform_device(const uint8_t* seeds, int w, int h, const uint8_t* needed, float* dist,
                                 const ExecContext& ctx) {
  DeviceBuffer<int> g;
  VPR_RETURN_IF_ERROR(g.allocate(size_t(w) * size_t(h), ctx));
  constexpr int kColumnBlock = 64;
  column_pass_kernel<<<blocks_for(size_t(w), kColumnBlock), kColumnBlock, 0, stream_of(ctx)>>>(seeds, w, h, g.get());
  VPR_CUDA_LAUNCHED("column_pass_kernel");
  row_pass_kernel<<<pixel_grid(w, h), pixel_block(), 0, stream_of(ctx)>>>(g.get(), w, h, needed, dist);
  VPR_CUDA_LAUNCHED("row_pass_kernel");
  return Status::Ok();  // g is freed in stream order, after the kernels
}

}  // namespace detail

Status distance_transform(const Mask& seeds, FloatImage* dist, const ExecContext& ctx) {
  assert(dist != nullptr);
  VPR_RETURN_IF_ERROR(check_distance_transform_args(seeds));
  const int w = seeds.width, h = seeds.height;
  VPR_RETURN_IF_ERROR(detail::require_stream(ctx, "distance_transform"));
  bool any_seed = false;
  for (uint8_t s : seeds.pixels) any_seed = any_seed || s;
  if (!any_seed) {  // as the CPU twin; also spares pass 2 its full-row searches
    *dist = FloatImage(w, h, INFINITY);
    return Status::Ok();
  }
  const size_t pixels = seeds.pixels.size();
  DeviceBuffer<uint8_t> device_seeds;
  DeviceBuffer<float> device_dist;
  VPR_RETURN_IF_ERROR(device_seeds.upload(seeds.pixels.data(), pixels, ctx));
  VPR_RETURN_IF_ERROR(device_dist.allocate(pixels, ctx));
  VPR_RETURN_IF_ERROR(detail::distance_transform_device(device_seeds.get(), w, h, nullptr, device_dist.get(), ctx));
  FloatImage result(w, h, 0.f);
  VPR_RETURN_IF_ERROR(device_dist.download(result.pixels.data(), pixels));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream_of(ctx)));
  *dist = std::move(result);
  return Status::Ok();
}

}  // namespace vpr::cuda
