// Silhouette-feature filter (Section III-B, Eq. 4-5), CPU twin. The per-pixel
// rules are in image_kernels.h (silhouette_at, skeleton_at, near_thick_part)
// for the GPU twin.
#include "saliency/silhouette_feature.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "saliency/distance_transform.h"
#include "saliency/image_kernels.h"

namespace vpr {
namespace {

Status check_mask(const char* what, const Mask& m, int w, int h) {
  if (m.width != w || m.height != h || m.pixels.size() != size_t(w) * size_t(h)) {
    return invalid_argument(std::string(what) + " is " + std::to_string(m.width) + " x " + std::to_string(m.height) +
                            " with " + std::to_string(m.pixels.size()) + " pixels; expected " + std::to_string(w) +
                            " x " + std::to_string(h));
  }
  return Status::Ok();
}

Status check_size(const char* what, int w, int h) {
  if (w <= 0 || h <= 0) {
    return invalid_argument(std::string(what) + ": image is " + std::to_string(w) + " x " + std::to_string(h) +
                            "; need a non-empty image");
  }
  return Status::Ok();
}

}  // namespace

Status check_silhouette_pixels_args(const Mask& foreground) {
  const int w = foreground.width, h = foreground.height;
  VPR_RETURN_IF_ERROR(check_size("silhouette_pixels", w, h));
  VPR_RETURN_IF_ERROR(check_mask("silhouette_pixels: foreground", foreground, w, h));
  return Status::Ok();
}

Status check_skeleton_args(const FloatImage& silhouette_distance, const Mask& foreground, int lambda) {
  const int w = silhouette_distance.width, h = silhouette_distance.height;
  VPR_RETURN_IF_ERROR(check_size("skeleton", w, h));
  if (silhouette_distance.pixels.size() != size_t(w) * size_t(h)) {
    return invalid_argument("skeleton: distance map has " + std::to_string(silhouette_distance.pixels.size()) +
                            " pixels; expected " + std::to_string(w) + " x " + std::to_string(h));
  }
  VPR_RETURN_IF_ERROR(check_mask("skeleton: foreground", foreground, w, h));
  if (lambda < 2 || lambda % 2 != 0 || lambda > 64) {
    return invalid_argument("skeleton: lambda = " + std::to_string(lambda) + " must be even and in [2, 64] (Eq. 5)");
  }
  return Status::Ok();
}

Status check_thin_features_args(const Mask& foreground, const Mask& silhouette, const Mask& skeleton,
                                const FloatImage& silhouette_distance, float threshold_px) {
  const int w = foreground.width, h = foreground.height;
  VPR_RETURN_IF_ERROR(check_size("thin_features", w, h));
  VPR_RETURN_IF_ERROR(check_mask("thin_features: foreground", foreground, w, h));
  VPR_RETURN_IF_ERROR(check_mask("thin_features: silhouette", silhouette, w, h));
  VPR_RETURN_IF_ERROR(check_mask("thin_features: skeleton", skeleton, w, h));
  if (silhouette_distance.width != w || silhouette_distance.height != h ||
      silhouette_distance.pixels.size() != size_t(w) * size_t(h)) {
    return invalid_argument("thin_features: distance map is " + std::to_string(silhouette_distance.width) + " x " +
                            std::to_string(silhouette_distance.height) + "; expected " + std::to_string(w) + " x " +
                            std::to_string(h));
  }
  if (!(threshold_px >= 0.f) || !std::isfinite(threshold_px)) {
    return invalid_argument("thin_features: threshold " + std::to_string(threshold_px) + " px must be finite and >= 0");
  }
  return Status::Ok();
}

namespace cpu {
namespace {

template <class Fn>
void for_each_row(int h, Fn&& fn) {
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) fn(y);
  });
}

}  // namespace

Status silhouette_pixels(const Mask& foreground, Mask* silhouette, const ExecContext& /*ctx*/) {
  assert(silhouette != nullptr);
  VPR_RETURN_IF_ERROR(check_silhouette_pixels_args(foreground));
  const int w = foreground.width, h = foreground.height;
  *silhouette = Mask(w, h, 0);
  const uint8_t* fg = foreground.pixels.data();
  uint8_t* out = silhouette->pixels.data();
  for_each_row(h, [&](int y) {
    for (int x = 0; x < w; ++x) out[size_t(y) * w + x] = silhouette_at(fg, w, h, x, y) ? 1 : 0;
  });
  return Status::Ok();
}

Status skeleton(const FloatImage& silhouette_distance, const Mask& foreground, int lambda, Mask* skeleton,
                const ExecContext& /*ctx*/) {
  assert(skeleton != nullptr);
  VPR_RETURN_IF_ERROR(check_skeleton_args(silhouette_distance, foreground, lambda));
  const int w = silhouette_distance.width, h = silhouette_distance.height;
  const int m = lambda / 2;  // Eq. (5): the kernel spans lambda + 1 pixels, m each way
  // One array for the kernel: D on the foreground, 0 elsewhere.
  std::vector<float> masked(silhouette_distance.pixels.size());
  for (size_t i = 0; i < masked.size(); ++i) {
    masked[i] = foreground.pixels[i] ? silhouette_distance.pixels[i] : 0.f;
  }
  *skeleton = Mask(w, h, 0);
  uint8_t* out = skeleton->pixels.data();
  for_each_row(h, [&](int y) {
    const bool inside_rows = y >= m && y < h - m;
    for (int x = 0; x < w; ++x) {
      const bool inside = inside_rows && x >= m && x < w - m;
      out[size_t(y) * w + x] =
          (inside ? skeleton_at<false>(masked.data(), w, h, x, y, m) : skeleton_at<true>(masked.data(), w, h, x, y, m))
              ? 1
              : 0;
    }
  });
  return Status::Ok();
}

Status thin_features(const Mask& foreground, const Mask& silhouette, const Mask& skeleton,
                     const FloatImage& silhouette_distance, float threshold_px, Mask* thin, const ExecContext& ctx) {
  assert(thin != nullptr);
  VPR_RETURN_IF_ERROR(check_thin_features_args(foreground, silhouette, skeleton, silhouette_distance, threshold_px));
  const int w = foreground.width, h = foreground.height;

  // Feature size: distance from each silhouette pixel to the skeleton.
  FloatImage to_skeleton;
  VPR_RETURN_IF_ERROR(distance_transform(skeleton, &to_skeleton, ctx));

  float max_distance = 0.f;
  for (size_t i = 0; i < foreground.pixels.size(); ++i) {
    if (foreground.pixels[i]) max_distance = std::max(max_distance, silhouette_distance.pixels[i]);
  }
  // Parts thinner than about 5 px have no skeleton; they count when the
  // threshold is above their feature size (< kSkeletonMinDistance).
  const bool thin_parts_count = threshold_px > kSkeletonMinDistance;

  // With no skeleton at all (a tiny or very thin object) the largest distance
  // to the silhouette stands in for the feature size of the whole view.
  bool any_skeleton = false;
  for (uint8_t s : skeleton.pixels) any_skeleton = any_skeleton || s;
  const bool all_thin = !any_skeleton && max_distance < threshold_px;

  *thin = Mask(w, h, 0);
  const float* dist = silhouette_distance.pixels.data();
  const uint8_t* fg = foreground.pixels.data();
  for_each_row(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * w + x;
      if (!silhouette.pixels[i]) continue;
      thin->pixels[i] = all_thin || to_skeleton.pixels[i] < threshold_px ||
                        (thin_parts_count && !near_thick_part(dist, fg, w, h, x, y));
    }
  });
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
