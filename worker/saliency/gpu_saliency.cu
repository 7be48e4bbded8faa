// Stages 2-3 (Section III) of one view, fused on the GPU: detect_features_device
// (image_saliency.cu) then unproject_device (unproject.cu), with the
// intermediate images kept on the device. Per 512^2 view this is a dozen
// kernels, two stream synchronizations (the point count, then the points) and
// 1.5 MB of upload from a host snapshot, none from a DeviceSnapshot.
#include <string>
#include <utility>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "saliency/gpu_saliency.h"
#include "saliency/image_saliency_device.cuh"

namespace vpr::cuda {

Status view_saliency_points(const DeviceSnapshot& snapshot, const View& view, const ImageSaliencyOptions& options,
                            std::vector<float>* points, FeatureImages* debug, const ExecContext& ctx) {
  assert(points != nullptr);
  VPR_RETURN_IF_ERROR(check_image_saliency_options(options));
  const int w = snapshot.width, h = snapshot.height;
  if (w <= 0 || h <= 0 || !snapshot.gray || !snapshot.coverage || !snapshot.depth) {
    return invalid_argument("view_saliency_points: device snapshot is " + std::to_string(w) + " x " +
                            std::to_string(h) + "; need a non-empty image with gray, coverage and depth");
  }
  if (view.width != 0 && (view.width != w || view.height != h)) {
    return invalid_argument("view " + view.name + " is " + std::to_string(view.width) + "x" +
                            std::to_string(view.height) + " but the depth image is " + std::to_string(w) + "x" +
                            std::to_string(h));
  }
  VPR_RETURN_IF_ERROR(detail::require_stream(ctx, "view_saliency_points"));
  detail::DeviceFeatures features;
  VPR_RETURN_IF_ERROR(detail::detect_features_device(snapshot.gray, snapshot.coverage, w, h, options, &features, ctx));
  FeatureImages images;
  if (debug) VPR_RETURN_IF_ERROR(detail::download_features(features, w, h, &images));
  // Synchronizes the stream, so the debug images have arrived too.
  VPR_RETURN_IF_ERROR(detail::unproject_device(features.features.get(), snapshot.depth, w, h, view, points, ctx));
  if (debug) {
    VPR_CUDA_TRY(cudaStreamSynchronize(stream_of(ctx)));  // unproject_device returns early with no point
    *debug = std::move(images);
  }
  return Status::Ok();
}

Status view_saliency_points(const Snapshot& snapshot, const View& view, const ImageSaliencyOptions& options,
                            std::vector<float>* points, FeatureImages* debug, const ExecContext& ctx) {
  assert(points != nullptr);
  // The CPU twins' checks: gray, coverage and depth share one size.
  VPR_RETURN_IF_ERROR(check_detect_features_args(snapshot, options));
  const int w = snapshot.gray.width, h = snapshot.gray.height;
  const size_t n = size_t(w) * size_t(h);
  const Mask& coverage = snapshot.coverage;
  const FloatImage& depth = snapshot.depth;
  if (depth.width != w || depth.height != h || depth.pixels.size() != n) {
    return invalid_argument("feature mask is " + std::to_string(w) + "x" + std::to_string(h) +
                            " but the depth image is " + std::to_string(depth.width) + "x" +
                            std::to_string(depth.height));
  }
  VPR_RETURN_IF_ERROR(detail::require_stream(ctx, "view_saliency_points"));
  DeviceBuffer<uint8_t> gray, cov;
  DeviceBuffer<float> device_depth;
  VPR_RETURN_IF_ERROR(gray.upload(snapshot.gray.pixels.data(), n, ctx));
  VPR_RETURN_IF_ERROR(cov.upload(coverage.pixels.data(), n, ctx));
  VPR_RETURN_IF_ERROR(device_depth.upload(depth.pixels.data(), n, ctx));
  const DeviceSnapshot on_device{w, h, gray.get(), cov.get(), device_depth.get()};
  return view_saliency_points(on_device, view, options, points, debug, ctx);
}

}  // namespace vpr::cuda
