// Median pre-filter (Section III-A), GPU twin: one thread per pixel running
// median_at / majority_at (image_kernels.h), the exact per-pixel rules the CPU
// twin's sliding histogram and box counts compute, so both agree pixel for
// pixel. Global reads with clamped coordinates: the 7 x 7 window stays in L1.
#include <string>
#include <utility>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "saliency/image_kernels.h"
#include "saliency/image_saliency_device.cuh"
#include "saliency/median_filter.h"

namespace vpr::cuda {
namespace detail {
namespace {

__global__ void median_kernel(const uint8_t* __restrict__ gray, int w, int h, int r, uint8_t* __restrict__ out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  // Snapshots are mostly background (0), and a window of zeros has median 0:
  // one pass to find that out instead of median_at's eight (exact, as the
  // CPU twin's skipped all-zero spans).
  bool any = false;
  for (int dy = -r; dy <= r && !any; ++dy) {
    const uint8_t* row = gray + static_cast<long long>(clamp_index(y + dy, h)) * w;
    for (int dx = -r; dx <= r; ++dx) any |= row[clamp_index(x + dx, w)] != 0;
  }
  out[static_cast<long long>(y) * w + x] = any ? median_at(gray, w, h, x, y, r) : 0;
}

__global__ void majority_kernel(const uint8_t* __restrict__ mask, int w, int h, int r, uint8_t* __restrict__ out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  out[static_cast<long long>(y) * w + x] = majority_at(mask, w, h, x, y, r);
}

}  // namespace

Status launch_median(const uint8_t* gray, int w, int h, int size, uint8_t* out, const ExecContext& ctx) {
  median_kernel<<<pixel_grid(w, h), pixel_block(), 0, stream_of(ctx)>>>(gray, w, h, size / 2, out);
  VPR_CUDA_LAUNCHED("median_kernel");
  return Status::Ok();
}

Status launch_majority(const uint8_t* mask, int w, int h, int size, uint8_t* out, const ExecContext& ctx) {
  majority_kernel<<<pixel_grid(w, h), pixel_block(), 0, stream_of(ctx)>>>(mask, w, h, size / 2, out);
  VPR_CUDA_LAUNCHED("majority_kernel");
  return Status::Ok();
}

}  // namespace detail

namespace {

using Launcher = Status (*)(const uint8_t*, int, int, int, uint8_t*, const ExecContext&);

Status run_filter(const char* what, Launcher launch, const Image<uint8_t>& in, int size, Image<uint8_t>* out,
                  const ExecContext& ctx) {
  assert(out != nullptr);
  VPR_RETURN_IF_ERROR(check_median_filter_args(what, in, size));
  VPR_RETURN_IF_ERROR(detail::require_stream(ctx, what));
  const int w = in.width, h = in.height;
  DeviceBuffer<uint8_t> src, dst;
  VPR_RETURN_IF_ERROR(src.upload(in.pixels.data(), in.pixels.size(), ctx));
  VPR_RETURN_IF_ERROR(dst.allocate(in.pixels.size(), ctx));
  VPR_RETURN_IF_ERROR(launch(src.get(), w, h, size, dst.get(), ctx));
  Image<uint8_t> result(w, h, 0);
  VPR_RETURN_IF_ERROR(dst.download(result.pixels.data(), result.pixels.size()));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream_of(ctx)));
  *out = std::move(result);
  return Status::Ok();
}

}  // namespace

Status median_filter(const GrayImage& in, int size, GrayImage* out, const ExecContext& ctx) {
  return run_filter("median_filter", detail::launch_median, in, size, out, ctx);
}

Status majority_filter(const Mask& in, int size, Mask* out, const ExecContext& ctx) {
  return run_filter("majority_filter", detail::launch_majority, in, size, out, ctx);
}

}  // namespace vpr::cuda
