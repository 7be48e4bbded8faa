// Stage 2 (Section III-A, III-B): image-space saliency of one snapshot, CPU twin.
// Each step is one call into median_filter.h, inner_feature.h,
// distance_transform.h or silhouette_feature.h; this file chains them and
// checks the snapshot and the options.
#include "saliency/image_saliency.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "saliency/distance_transform.h"
#include "saliency/inner_feature.h"
#include "saliency/median_filter.h"
#include "saliency/silhouette_feature.h"

namespace vpr {

Status check_image_saliency_options(const ImageSaliencyOptions& o) {
  if (o.median_size < 1 || o.median_size % 2 == 0 || o.median_size > 255) {
    return invalid_argument("median_size = " + std::to_string(o.median_size) + " must be odd and in [1, 255]");
  }
  if (o.gaussian_size < 1 || o.gaussian_size % 2 == 0 || o.gaussian_size > 63) {
    return invalid_argument("gaussian_size = " + std::to_string(o.gaussian_size) +
                            " must be odd and in [1, 63] (Eq. 1)");
  }
  if (!(o.gaussian_sigma > 0.f) || !std::isfinite(o.gaussian_sigma)) {
    return invalid_argument("gaussian_sigma = " + std::to_string(o.gaussian_sigma) +
                            " must be positive and finite (Eq. 1)");
  }
  if (o.threshold_c < -255 || o.threshold_c > 255) {
    return invalid_argument("threshold_c = " + std::to_string(o.threshold_c) + " must be in [-255, 255] (Eq. 3)");
  }
  if (o.skeleton_lambda < 2 || o.skeleton_lambda % 2 != 0 || o.skeleton_lambda > 64) {
    return invalid_argument("skeleton_lambda = " + std::to_string(o.skeleton_lambda) +
                            " must be even and in [2, 64] (Eq. 5)");
  }
  if (!(o.thin_feature_px >= 0.f) || !std::isfinite(o.thin_feature_px)) {
    return invalid_argument("thin_feature_px = " + std::to_string(o.thin_feature_px) + " must be finite and >= 0");
  }
  return Status::Ok();
}

Status check_detect_features_args(const Snapshot& snapshot, const ImageSaliencyOptions& options) {
  VPR_RETURN_IF_ERROR(check_image_saliency_options(options));
  const int w = snapshot.gray.width, h = snapshot.gray.height;
  if (w <= 0 || h <= 0 || snapshot.gray.pixels.size() != size_t(w) * size_t(h)) {
    return invalid_argument("detect_features: gray image is " + std::to_string(w) + " x " + std::to_string(h) +
                            " with " + std::to_string(snapshot.gray.pixels.size()) +
                            " pixels; need a non-empty image with width * height pixels");
  }
  const Mask& coverage = snapshot.coverage;
  if (coverage.width != w || coverage.height != h || coverage.pixels.size() != snapshot.gray.pixels.size()) {
    return invalid_argument("detect_features: coverage is " + std::to_string(coverage.width) + " x " +
                            std::to_string(coverage.height) + " but the gray image is " + std::to_string(w) + " x " +
                            std::to_string(h));
  }
  return Status::Ok();
}

namespace cpu {

Status detect_features(const Snapshot& snapshot, const ImageSaliencyOptions& options, FeatureImages* out,
                       const ExecContext& ctx) {
  assert(out != nullptr);
  VPR_RETURN_IF_ERROR(check_detect_features_args(snapshot, options));
  const int w = snapshot.gray.width, h = snapshot.gray.height;

  // Section III-A: the median pre-filter removes shading noise.
  VPR_RETURN_IF_ERROR(median_filter(snapshot.gray, options.median_size, &out->filtered, ctx));

  // The same window on the coverage is a majority vote (the median of a 0/1
  // image), so one-pixel bumps and notches of scanned silhouettes do not grow
  // skeleton spurs.
  VPR_RETURN_IF_ERROR(majority_filter(snapshot.coverage, options.median_size, &out->foreground, ctx));

  VPR_RETURN_IF_ERROR(silhouette_pixels(out->foreground, &out->silhouette, ctx));

  // Eq. (1)-(3) on the filtered image. The background is 0, so near the
  // silhouette the mean is dark and the object's rim is not marked; the
  // silhouette pixels themselves are left to the silhouette filter.
  VPR_RETURN_IF_ERROR(inner_features(out->filtered, out->foreground, options.gaussian_size, options.gaussian_sigma,
                                     options.threshold_c, &out->inner, ctx));
  for (size_t i = 0; i < out->inner.pixels.size(); ++i) out->inner.pixels[i] &= !out->silhouette.pixels[i];

  // Eq. (4), kept on the foreground only (0 on the background, for the debug images).
  VPR_RETURN_IF_ERROR(distance_transform(out->silhouette, &out->silhouette_distance, ctx));
  for (size_t i = 0; i < out->silhouette_distance.pixels.size(); ++i) {
    if (!out->foreground.pixels[i]) out->silhouette_distance.pixels[i] = 0.f;
  }

  // Eq. (5).
  VPR_RETURN_IF_ERROR(
      skeleton(out->silhouette_distance, out->foreground, options.skeleton_lambda, &out->skeleton, ctx));

  // The feature-size threshold is given for 512 px views and scales with the image.
  const float threshold_px = options.thin_feature_px * float(std::max(w, h)) / 512.f;
  VPR_RETURN_IF_ERROR(thin_features(out->foreground, out->silhouette, out->skeleton, out->silhouette_distance,
                                    threshold_px, &out->thin, ctx));

  out->features = Mask(w, h, 0);
  for (size_t i = 0; i < out->features.pixels.size(); ++i) {
    out->features.pixels[i] = out->inner.pixels[i] | out->thin.pixels[i];
  }
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
