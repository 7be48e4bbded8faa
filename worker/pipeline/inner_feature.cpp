// Inner-feature filter (Section III-A, Eq. 1-3), CPU twin.
// An adaptive threshold: a pixel is a feature when it is darker than the
// Gaussian-weighted mean of its n x n neighbourhood by more than C (the rule of
// OpenCV's ADAPTIVE_THRESH_GAUSSIAN_C with THRESH_BINARY_INV; sigma = 2 is what
// OpenCV picks for n = 11). Weights are fixed point, summing to 2^16, and the
// comparison is done on the weighted sum in int64, so the GPU twin
// (gaussian_sum_at and inner_feature_test in image_kernels.h) gives identical
// pixels.
#include "inner_feature.h"

#include <cassert>
#include <cmath>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "image_kernels.h"

namespace vpr {

std::vector<int> gaussian_weights_fixed(int n, float sigma) {
  assert(n >= 1 && n % 2 == 1 && sigma > 0.f);
  const int r = n / 2;
  // Eq. (1): G(i, j) = exp(-(i^2 + j^2) / (2 sigma^2)), normalized over the window.
  std::vector<double> g(size_t(n) * n);
  double total = 0.0;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double d2 = double(i - r) * (i - r) + double(j - r) * (j - r);
      g[size_t(j) * n + i] = std::exp(-d2 / (2.0 * double(sigma) * double(sigma)));
      total += g[size_t(j) * n + i];
    }
  }
  // Round every weight but the centre; the centre takes what is left so that the
  // sum is exactly 2^16. The rounded value depends only on i^2 + j^2, so the
  // weights keep the window's symmetries, and the centre (its own orbit) can
  // absorb the rounding error (at most (n^2 - 1) / 2 units, a few in practice)
  // without breaking them.
  std::vector<int> weights(size_t(n) * n);
  long long rest = 0;
  const size_t centre = size_t(r) * n + r;
  for (size_t k = 0; k < weights.size(); ++k) {
    if (k == centre) continue;
    weights[k] = static_cast<int>(std::lround(65536.0 * g[k] / total));
    rest += weights[k];
  }
  weights[centre] = static_cast<int>(65536 - rest);
  assert(weights[centre] > 0);
  return weights;
}

namespace cpu {

Status inner_features(const GrayImage& filtered, const Mask& foreground, int n, float sigma, int c,
                      Mask* features, const ExecContext& /*ctx*/) {
  assert(features != nullptr);
  const int w = filtered.width, h = filtered.height;
  if (w <= 0 || h <= 0 || filtered.pixels.size() != size_t(w) * size_t(h)) {
    return invalid_argument("inner_features: image is " + std::to_string(w) + " x " + std::to_string(h) +
                            " with " + std::to_string(filtered.pixels.size()) +
                            " pixels; need a non-empty image with width * height pixels");
  }
  if (foreground.width != w || foreground.height != h || foreground.pixels.size() != filtered.pixels.size()) {
    return invalid_argument("inner_features: foreground is " + std::to_string(foreground.width) + " x " +
                            std::to_string(foreground.height) + " but the image is " + std::to_string(w) +
                            " x " + std::to_string(h));
  }
  if (n < 1 || n % 2 == 0 || n > 63) {
    return invalid_argument("inner_features: window size n = " + std::to_string(n) +
                            " must be odd and in [1, 63] (Eq. 1)");
  }
  if (!(sigma > 0.f) || !std::isfinite(sigma)) {
    return invalid_argument("inner_features: sigma = " + std::to_string(sigma) +
                            " must be positive and finite (Eq. 1)");
  }
  if (c < -255 || c > 255) {
    return invalid_argument("inner_features: C = " + std::to_string(c) + " must be in [-255, 255] (Eq. 3)");
  }
  const std::vector<int> weights = gaussian_weights_fixed(n, sigma);
  *features = Mask(w, h, 0);
  const uint8_t* gray = filtered.pixels.data();
  const uint8_t* fg = foreground.pixels.data();
  uint8_t* out = features->pixels.data();
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = size_t(y) * w + x;
        if (!fg[i]) continue;  // only the object can carry features
        const int64_t sum = gaussian_sum_at(gray, w, h, x, y, weights.data(), n);
        out[i] = inner_feature_test(sum, gray[i], c) ? 1 : 0;
      }
    }
  });
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
