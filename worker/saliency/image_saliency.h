// Stage 2 (Section III-A, III-B): image-space saliency of one snapshot.
//   gray -> 7x7 median pre-filter -> inner features (Eq. 1-3) minus silhouette
//   pixels; coverage -> silhouette -> distance map (Eq. 4) -> skeleton by four
//   directional kernels (Eq. 5) -> distance map from the skeleton -> silhouette
//   pixels whose feature size is under the threshold ("thin features").
// The filters themselves live in median_filter.h, inner_feature.h,
// distance_transform.h and silhouette_feature.h.
#pragma once

#include "core/exec_context.h"
#include "core/image.h"
#include "render/snapshot.h"
#include "core/status.h"

namespace vpr {

struct ImageSaliencyOptions {
  int median_size = 7;           // median pre-filter window (Section III-A)
  int gaussian_size = 11;        // Eq. (1): n x n Gaussian window, n = 11
  float gaussian_sigma = 2.0f;   // Eq. (1): sigma of the Gaussian weights
  int threshold_c = 3;           // Eq. (3): a pixel is a feature when T > P, T = mean - C
  int skeleton_lambda = 8;       // Eq. (5): lambda of the directional skeleton kernels
  float thin_feature_px = 20.f;  // feature size threshold at 512 px; scaled by max(width, height) / 512
};

struct FeatureImages {
  GrayImage filtered;              // median-filtered gray image
  Mask foreground;                 // coverage after the same median (majority) filter; parts under 4 px wide vanish
  Mask silhouette;                 // foreground pixels with a background 4-neighbour
  Mask inner;                      // inner features (Eq. 1-3), silhouette pixels removed
  FloatImage silhouette_distance;  // Eq. (4): distance (px) of foreground pixels to the silhouette; 0 on background
  Mask skeleton;                   // Eq. (5)
  Mask thin;                       // silhouette pixels of thin features (thin_feature_px, see thin_features)
  Mask features;                   // inner | thin: the pixels that become saliency points
};

// Argument checks shared by the CPU and GPU twins, so both fail alike.
// The options in range (see ImageSaliencyOptions); the message names the field.
Status check_image_saliency_options(const ImageSaliencyOptions& options);
// detect_features: the options, then a non-empty gray image and a coverage mask of its size.
Status check_detect_features_args(const Snapshot& snapshot, const ImageSaliencyOptions& options);

namespace cpu {

// Fills every image of *out, each the size of the snapshot (gray and coverage
// are read; depth is not). INVALID_ARGUMENT when gray and coverage differ in
// size or an option is out of range. Identical output at any thread count.
Status detect_features(const Snapshot& snapshot, const ImageSaliencyOptions& options, FeatureImages* out,
                       const ExecContext& ctx);

}  // namespace cpu

// GPU twin, built when VPR_HAVE_CUDA (image_saliency.cu): same contract and
// identical images, on ctx's stream; returns once they are on the host. The
// pipeline's per-view path, which downloads only the points, is
// view_saliency_points (gpu_saliency.h).
namespace cuda {
Status detect_features(const Snapshot& snapshot, const ImageSaliencyOptions& options, FeatureImages* out,
                       const ExecContext& ctx);
}  // namespace cuda
}  // namespace vpr
