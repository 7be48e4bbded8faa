// Inner-feature filter (Section III-A, Eq. 1-3), CPU twin.
// An adaptive threshold: a pixel is a feature when it is darker than the
// Gaussian-weighted mean of its n x n neighbourhood by more than C (the rule of
// OpenCV's ADAPTIVE_THRESH_GAUSSIAN_C with THRESH_BINARY_INV; sigma = 2 is what
// OpenCV picks for n = 11). Weights are fixed point, summing to 2^16, and the
// comparison is done on the weighted sum in int64, so the GPU twin
// (gaussian_sum_at and inner_feature_test in image_kernels.h) gives identical
// pixels.
#include "saliency/inner_feature.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

#include "saliency/image_kernels.h"

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
  // without breaking them. Near-flat windows (large n and sigma) can round up so
  // much that nothing is left for the centre; they round down instead, which
  // leaves the centre at least its own share.
  const size_t centre = size_t(r) * n + r;
  const double centre_share = 65536.0 * g[centre] / total;
  std::vector<int> weights(size_t(n) * n);
  for (bool round_down : {false, true}) {
    long long rest = 0;
    for (size_t k = 0; k < weights.size(); ++k) {
      if (k == centre) continue;
      const double share = 65536.0 * g[k] / total;
      weights[k] = static_cast<int>(round_down ? std::floor(share) : std::lround(share));
      rest += weights[k];
    }
    weights[centre] = static_cast<int>(65536 - rest);
    if (weights[centre] >= centre_share / 2) break;
  }
  assert(weights[centre] > 0);
  return weights;
}

Status check_inner_features_args(const GrayImage& filtered, const Mask& foreground, int n, float sigma, int c) {
  const int w = filtered.width, h = filtered.height;
  if (w <= 0 || h <= 0 || filtered.pixels.size() != size_t(w) * size_t(h)) {
    return invalid_argument("inner_features: image is " + std::to_string(w) + " x " + std::to_string(h) + " with " +
                            std::to_string(filtered.pixels.size()) +
                            " pixels; need a non-empty image with width * height pixels");
  }
  if (foreground.width != w || foreground.height != h || foreground.pixels.size() != filtered.pixels.size()) {
    return invalid_argument("inner_features: foreground is " + std::to_string(foreground.width) + " x " +
                            std::to_string(foreground.height) + " but the image is " + std::to_string(w) + " x " +
                            std::to_string(h));
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
  return Status::Ok();
}

namespace cpu {
namespace {

// sum[x] += weight * (a[x] + b[x]) for x < count. Blocks of 8 with a fixed trip
// count: -O2's cheap vectorizer takes those, not loops that need a remainder.
inline void add_weighted(float* __restrict sum, const float* __restrict a, const float* __restrict b, float weight,
                         int count) {
  int x = 0;
  for (; x + 8 <= count; x += 8)
    for (int k = 0; k < 8; ++k) sum[x + k] += weight * (a[x + k] + b[x + k]);
  for (; x < count; ++x) sum[x] += weight * (a[x] + b[x]);
}

inline void add_weighted(float* __restrict sum, const float* __restrict a, float weight, int count) {
  int x = 0;
  for (; x + 8 <= count; x += 8)
    for (int k = 0; k < 8; ++k) sum[x + k] += weight * a[x + k];
  for (; x < count; ++x) sum[x] += weight * a[x];
}

}  // namespace

Status inner_features(const GrayImage& filtered, const Mask& foreground, int n, float sigma, int c, Mask* features,
                      const ExecContext& /*ctx*/) {
  assert(features != nullptr);
  VPR_RETURN_IF_ERROR(check_inner_features_args(filtered, foreground, n, sigma, c));
  const int w = filtered.width, h = filtered.height;
  const std::vector<int> weights = gaussian_weights_fixed(n, sigma);
  const int r = n / 2;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      assert(weights[size_t(j) * n + i] == weights[size_t(n - 1 - j) * n + i]);
      assert(weights[size_t(j) * n + i] == weights[size_t(j) * n + (n - 1 - i)]);
    }
  }
  *features = Mask(w, h, 0);
  const uint8_t* gray = filtered.pixels.data();
  const uint8_t* fg = foreground.pixels.data();
  uint8_t* out = features->pixels.data();
  // The same sum as gaussian_sum_at, a row at a time and folded by the weights'
  // mirror symmetry: rows y - r + k and y + r - k are added first (folded[k]),
  // then columns x - r + i and x + r - i, so each pixel costs (r + 1)^2
  // multiply-adds instead of n^2, in loops over x that the compiler vectorizes.
  // In float, yet exact: every term and every partial sum is an integer no
  // larger than the full sum, at most 255 * 2^16 < 2^24, and float holds every
  // integer below 2^24, so no operation rounds.
  const int padded = w + 2 * r;
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    // Locals and __restrict pointers: with -O2's cheap vectorizer, loops whose
    // bound or pointers might alias the stores are left scalar.
    const int width = w, height = h, reach = r, stride = padded;
    std::vector<float> folded_rows(size_t(reach + 1) * stride);
    std::vector<float> sum_row(static_cast<size_t>(width));
    float* __restrict sum = sum_row.data();
    for (int y = rows.begin(); y != rows.end(); ++y) {
      const uint8_t* fg_row = fg + size_t(y) * width;
      bool any = false;
      for (int x = 0; x < width && !any; ++x) any = fg_row[x] != 0;
      if (!any) continue;  // only the object can carry features
      for (int k = 0; k <= reach; ++k) {
        // folded[k][p] = gray(p - r, y - r + k) + gray(p - r, y + r - k), x
        // clamped; the middle row (k = r) once.
        const uint8_t* __restrict above = gray + size_t(clamp_index(y - reach + k, height)) * width;
        const uint8_t* __restrict below = gray + size_t(clamp_index(y + reach - k, height)) * width;
        float* __restrict f = folded_rows.data() + size_t(k) * stride;
        const int times = (k < reach) ? 1 : 0;
        for (int p = 0; p < reach; ++p) f[p] = float(above[0] + times * below[0]);
        for (int x = 0; x < width; ++x) f[reach + x] = float(above[x] + times * below[x]);
        for (int p = 0; p < reach; ++p) f[reach + width + p] = float(above[width - 1] + times * below[width - 1]);
      }
      for (int x = 0; x < width; ++x) sum[x] = 0.f;
      for (int k = 0; k <= reach; ++k) {
        const float* __restrict f = folded_rows.data() + size_t(k) * stride;
        for (int i = 0; i < reach; ++i) {  // columns x - r + i and x + r - i
          add_weighted(sum, f + i, f + 2 * reach - i, float(weights[size_t(k) * n + i]), width);
        }
        add_weighted(sum, f + reach, float(weights[size_t(k) * n + reach]), width);
      }
      const uint8_t* gray_row = gray + size_t(y) * width;
      uint8_t* out_row = out + size_t(y) * width;
      for (int x = 0; x < width; ++x) out_row[x] = fg_row[x] && inner_feature_test(int64_t(sum[x]), gray_row[x], c);
    }
  });
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
