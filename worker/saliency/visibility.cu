// GPU twin of the visibility cue (visibility.h): one thread a vertex, every
// view's depth image on the device; the same double arithmetic as the CPU twin
// (seen_by_view, compiled without FMA contraction; the views' weights summed
// in the same order).
#include <cassert>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "saliency/visibility.h"

namespace vpr::cuda {
namespace {

// view_proj: views x 16 doubles; depth: the views' images back to back, each
// width x height (all views share one size, as make_views makes them).
// weight: views doubles (view_weights), total their sum, as on the CPU.
__global__ void visibility_kernel(const float* vertices, uint32_t n, const double* view_proj, const double* weight,
                                  double total, const float* depth, int views, int width, int height, float tolerance,
                                  float* out) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= n) return;
  double seen = 0;
  for (int i = 0; i < views; ++i)
    if (seen_by_view(view_proj + 16 * i, depth + size_t(i) * size_t(width) * size_t(height), width, height, tolerance,
                     vertices[3 * v], vertices[3 * v + 1], vertices[3 * v + 2]))
      seen += weight[i];
  out[v] = float(seen / total);
}

}  // namespace

Status view_visibility_on_device(const float* vertices, size_t n, const std::vector<View>& views,
                                 const float* device_depths, const VisibilityOptions& options,
                                 std::vector<float>* visibility, const ExecContext& ctx) {
  assert(visibility != nullptr);
  VPR_RETURN_IF_ERROR(check_visibility_options(options));
  visibility->assign(n, 1.0f);
  if (views.empty() || n == 0) return Status::Ok();
  const int width = views[0].width, height = views[0].height;
  for (const View& v : views)
    if (v.width != width || v.height != height)
      return unavailable("visibility on the GPU: views of different sizes (use the CPU twin)");
  if (width <= 0 || height <= 0 || !device_depths)
    return invalid_argument("visibility on the GPU: no depth images for " + std::to_string(width) + "x" +
                            std::to_string(height) + " views");
  std::vector<double> matrices(16 * views.size());
  for (size_t i = 0; i < views.size(); ++i)
    for (int k = 0; k < 16; ++k) matrices[16 * i + k] = views[i].view_proj[k];

  const std::vector<double> weight = view_weights(views, options);
  double total = 0;
  for (double w : weight) total += w;

  const cudaStream_t stream = stream_of(ctx);
  DeviceBuffer<float> d_vertices, d_out;
  DeviceBuffer<double> d_matrices, d_weight;
  VPR_RETURN_IF_ERROR(d_vertices.upload(vertices, 3 * n, ctx));
  VPR_RETURN_IF_ERROR(d_matrices.upload(matrices.data(), matrices.size(), ctx));
  VPR_RETURN_IF_ERROR(d_weight.upload(weight.data(), weight.size(), ctx));
  VPR_RETURN_IF_ERROR(d_out.allocate(n, ctx));
  visibility_kernel<<<blocks_for(n), kBlock, 0, stream>>>(d_vertices.get(), uint32_t(n), d_matrices.get(),
                                                          d_weight.get(), total, device_depths, int(views.size()),
                                                          width, height, options.depth_tolerance, d_out.get());
  VPR_CUDA_LAUNCHED("visibility_kernel");
  VPR_RETURN_IF_ERROR(d_out.download(visibility->data(), n));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

Status view_visibility(const float* vertices, size_t n, const std::vector<View>& views,
                       const std::vector<Snapshot>& snapshots, const VisibilityOptions& options,
                       std::vector<float>* visibility, const ExecContext& ctx) {
  assert(visibility != nullptr);
  VPR_RETURN_IF_ERROR(check_visibility_args(views, snapshots, options));
  visibility->assign(n, 1.0f);
  if (views.empty() || n == 0) return Status::Ok();
  const int width = snapshots[0].depth.width, height = snapshots[0].depth.height;
  for (const Snapshot& s : snapshots)
    if (s.depth.width != width || s.depth.height != height)
      return unavailable("visibility on the GPU: views of different sizes (use the CPU twin)");
  // A view of width 0 takes its depth image's size (check_visibility_args).
  std::vector<View> sized = views;
  for (View& v : sized) {
    v.width = width;
    v.height = height;
  }
  const size_t pixels = size_t(width) * size_t(height);
  DeviceBuffer<float> d_depth;
  VPR_RETURN_IF_ERROR(d_depth.allocate(pixels * views.size(), ctx));
  for (size_t i = 0; i < views.size(); ++i)
    VPR_RETURN_IF_ERROR(staged_upload(d_depth.get() + i * pixels, snapshots[i].depth.pixels.data(),
                                      pixels * sizeof(float), stream_of(ctx)));
  return view_visibility_on_device(vertices, n, sized, d_depth.get(), options, visibility, ctx);
}

}  // namespace vpr::cuda
