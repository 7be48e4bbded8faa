// Stage 2 (Section III-A, III-B): image-space saliency of one snapshot, GPU
// twin. The same chain as the CPU twin, on device images from end to end:
// median and majority pre-filters, silhouette, inner features (Eq. 1-3) minus
// the silhouette, distance map (Eq. 4), skeleton (Eq. 5), thin features. Each
// step gives the CPU twin's pixels exactly (see the step's .cu file).
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "saliency/image_saliency.h"
#include "saliency/image_saliency_device.cuh"
#include "saliency/inner_feature.h"

namespace vpr::cuda {
namespace detail {

Status detect_features_device(const uint8_t* gray, const uint8_t* coverage, int w, int h,
                              const ImageSaliencyOptions& options, DeviceFeatures* out, const ExecContext& ctx) {
  const size_t n = size_t(w) * size_t(h);
  for (DeviceBuffer<uint8_t>* b :
       {&out->filtered, &out->foreground, &out->silhouette, &out->inner, &out->skeleton, &out->thin, &out->features}) {
    VPR_RETURN_IF_ERROR(b->allocate(n, ctx));
  }
  VPR_RETURN_IF_ERROR(out->silhouette_distance.allocate(n, ctx));
  const std::vector<int> weights = gaussian_weights_fixed(options.gaussian_size, options.gaussian_sigma);
  DeviceBuffer<int> device_weights;
  VPR_RETURN_IF_ERROR(device_weights.upload(weights.data(), weights.size(), ctx));

  // Section III-A: the median pre-filter removes shading noise; on the
  // coverage it is a majority vote, so one-pixel bumps grow no skeleton spurs.
  VPR_RETURN_IF_ERROR(launch_median(gray, w, h, options.median_size, out->filtered.get(), ctx));
  VPR_RETURN_IF_ERROR(launch_majority(coverage, w, h, options.median_size, out->foreground.get(), ctx));
  VPR_RETURN_IF_ERROR(launch_silhouette(out->foreground.get(), w, h, out->silhouette.get(), ctx));

  // Eq. (1)-(3); silhouette pixels are left to the silhouette filter.
  VPR_RETURN_IF_ERROR(launch_inner_features(out->filtered.get(), out->foreground.get(), out->silhouette.get(), w, h,
                                            device_weights.get(), options.gaussian_size, options.threshold_c,
                                            out->inner.get(), ctx));

  // Eq. (4) on the foreground only, 0 on the background: what the CPU twin
  // keeps, and already the masked map the skeleton kernel reads.
  VPR_RETURN_IF_ERROR(distance_transform_device(out->silhouette.get(), w, h, out->foreground.get(),
                                                out->silhouette_distance.get(), ctx));
  // Eq. (5): lambda / 2 pixels each way.
  VPR_RETURN_IF_ERROR(
      launch_skeleton(out->silhouette_distance.get(), w, h, options.skeleton_lambda / 2, out->skeleton.get(), ctx));

  // The feature-size threshold is given for 512 px views and scales with the
  // image (the CPU twin's expression, so the same float).
  const float threshold_px = options.thin_feature_px * float(std::max(w, h)) / 512.f;
  return thin_features_device(out->foreground.get(), out->silhouette.get(), out->skeleton.get(),
                              out->silhouette_distance.get(), w, h, threshold_px, out->thin.get(), out->inner.get(),
                              out->features.get(), ctx);
}

Status download_features(const DeviceFeatures& in, int w, int h, FeatureImages* out) {
  const size_t n = size_t(w) * size_t(h);
  out->filtered = GrayImage(w, h, 0);
  VPR_RETURN_IF_ERROR(in.filtered.download(out->filtered.pixels.data(), n));
  out->silhouette_distance = FloatImage(w, h, 0.f);
  VPR_RETURN_IF_ERROR(in.silhouette_distance.download(out->silhouette_distance.pixels.data(), n));
  const std::pair<const DeviceBuffer<uint8_t>*, Mask*> masks[] = {{&in.foreground, &out->foreground},
                                                                  {&in.silhouette, &out->silhouette},
                                                                  {&in.inner, &out->inner},
                                                                  {&in.skeleton, &out->skeleton},
                                                                  {&in.thin, &out->thin},
                                                                  {&in.features, &out->features}};
  for (const auto& [device, host] : masks) {
    *host = Mask(w, h, 0);
    VPR_RETURN_IF_ERROR(device->download(host->pixels.data(), n));
  }
  return Status::Ok();
}

}  // namespace detail

Status detect_features(const Snapshot& snapshot, const ImageSaliencyOptions& options, FeatureImages* out,
                       const ExecContext& ctx) {
  assert(out != nullptr);
  VPR_RETURN_IF_ERROR(check_detect_features_args(snapshot, options));
  const int w = snapshot.gray.width, h = snapshot.gray.height;
  VPR_RETURN_IF_ERROR(detail::require_stream(ctx, "detect_features"));
  const size_t n = snapshot.gray.pixels.size();
  DeviceBuffer<uint8_t> gray, cov;
  VPR_RETURN_IF_ERROR(gray.upload(snapshot.gray.pixels.data(), n, ctx));
  VPR_RETURN_IF_ERROR(cov.upload(snapshot.coverage.pixels.data(), n, ctx));
  detail::DeviceFeatures device;
  VPR_RETURN_IF_ERROR(detail::detect_features_device(gray.get(), cov.get(), w, h, options, &device, ctx));
  FeatureImages result;
  VPR_RETURN_IF_ERROR(detail::download_features(device, w, h, &result));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream_of(ctx)));
  *out = std::move(result);
  return Status::Ok();
}

}  // namespace vpr::cuda
