// Per-pixel kernels of stage 2 (Section III-A, III-B), shared by the CPU twins
// (*.cpp, TBB over rows) and the GPU twins (one thread per pixel). Each function
// reads a whole row-major image through a raw pointer and writes nothing, so a
// .cu file can call it unchanged. Integer kernels give bit-identical results on
// either device; the skeleton kernel uses float but no operation whose rounding
// differs between host and device (see skeleton_response_at).
#pragma once

#include <cstdint>

#include "core/vec3.h"  // VPR_HD

namespace vpr {

// Eq. (5) interpretation, see skeleton_at: a pixel must lie at least this far
// from the silhouette to be a skeleton pixel, so that the one-pixel ring next to
// the silhouette, whose distance values are too coarse to show a ridge, never
// fires.
constexpr float kSkeletonMinDistance = 2.0f;
// Eq. (5): minimum kernel response, as a fraction of the response of an ideal
// ridge of unit slope (a tent), for a pixel to be a skeleton pixel.
constexpr float kSkeletonMinResponse = 0.5f;

VPR_HD inline int clamp_index(int i, int n) {
  return i < 0 ? 0 : (i >= n ? n - 1 : i);
}

// Median of the (2r+1) x (2r+1) window around (x, y), edges clamped.
// Bitwise binary search for the value of rank k/2 (0-based, k = window size):
// the median is the largest v with count(window < v) <= k/2, found one bit at a
// time from the top, 8 passes over the window and no per-thread histogram, which
// suits a GPU thread. The CPU twin uses a sliding histogram for speed; both are
// exact, so they agree pixel for pixel.
VPR_HD inline uint8_t median_at(const uint8_t* img, int w, int h, int x, int y, int r) {
  const int side = 2 * r + 1;
  const int rank = side * side / 2;
  int result = 0;
  for (int bit = 128; bit != 0; bit >>= 1) {
    const int candidate = result | bit;
    int below = 0;
    for (int dy = -r; dy <= r; ++dy) {
      const uint8_t* row = img + static_cast<long long>(clamp_index(y + dy, h)) * w;
      for (int dx = -r; dx <= r; ++dx) below += row[clamp_index(x + dx, w)] < candidate;
    }
    if (below <= rank) result = candidate;
  }
  return static_cast<uint8_t>(result);
}

// Eq. (1)-(2) in fixed point: sum of weights(i, j) * gray over the n x n window
// centred on (x, y), edges clamped. weights: n*n integers summing to 2^16, so the
// weighted mean is the returned sum / 2^16, exactly. The sum is at most
// 255 * 2^16 < 2^31, so int32 accumulation is exact. kClamped = false skips the
// edge clamping and is for windows known to lie inside the image.
template <bool kClamped = true>
VPR_HD inline int64_t gaussian_sum_at(const uint8_t* gray, int w, int h, int x, int y, const int* weights, int n) {
  const int r = n / 2;
  int32_t sum = 0;
  for (int j = 0; j < n; ++j) {
    const int* wrow = weights + j * n;
    if constexpr (kClamped) {
      const uint8_t* row = gray + static_cast<long long>(clamp_index(y + j - r, h)) * w;
      for (int i = 0; i < n; ++i) sum += wrow[i] * row[clamp_index(x + i - r, w)];
    } else {
      const uint8_t* row = gray + static_cast<long long>(y + j - r) * w + (x - r);
      for (int i = 0; i < n; ++i) sum += wrow[i] * row[i];
    }
  }
  return sum;
}

// Eq. (3): T > P with T = sum / 2^16 - C, P the pixel's own value; multiplied by
// 2^16 so that it is an exact integer comparison.
VPR_HD inline bool inner_feature_test(int64_t weighted_sum, int pixel, int c) {
  return weighted_sum > (static_cast<int64_t>(pixel) + c) * 65536;
}

// Eq. (5), our reading of the paper's four directional kernels. For direction d
// in {(1,0), (0,1), (1,1), (1,-1)} and half-reach m = lambda / 2:
//   R_d(p) = sum_{t=1..m} [2 D(p) - D(p + t d) - D(p - t d)],
// a second difference of the distance map D summed over growing steps; samples
// outside the image or the foreground count as D = 0. R_d is divided by the
// response of an ideal ridge of unit slope, sum_{t=1..m} 2 t |d| = m (m + 1) |d|,
// so the result is scale free:
//  - the centre line of a strip, a tent of slope 1, gives 1 (0.8 for a strip of
//    even width, whose ridge is two pixels wide);
//  - the 45-degree bisector of a square corner, D = min(x, y), gives 0.5 across
//    the axes and 0.71 across the other diagonal;
//  - a plane slope (the flank of any part) gives 0;
//  - across a disc of radius rho at distance s from its centre the curvature of
//    D gives about 1.5 / s, so only the disc's central few pixels fire.
// masked: D on the foreground, 0 elsewhere. Returns max_d R_d(p) / norm_d.
// kChecked = false skips the image-bounds tests and is for pixels at least m
// pixels inside the image; the arithmetic is the same.
template <bool kChecked = true>
VPR_HD inline float skeleton_response_at(const float* masked, int w, int h, int x, int y, int m) {
  const long long here = static_cast<long long>(y) * w + x;
  const float twice = 2.f * masked[here];  // exact, so a fused multiply-add rounds the same
  const int dxs[4] = {1, 0, 1, 1};
  const int dys[4] = {0, 1, 1, -1};
  float best = 0.f;
  for (int k = 0; k < 4; ++k) {
    const long long step = static_cast<long long>(dys[k]) * w + dxs[k];
    float response = 0.f;
    for (int t = 1; t <= m; ++t) {
      float da = 0.f, db = 0.f;
      if constexpr (kChecked) {
        const int xa = x + t * dxs[k], ya = y + t * dys[k];
        const int xb = x - t * dxs[k], yb = y - t * dys[k];
        if (xa >= 0 && ya >= 0 && xa < w && ya < h) da = masked[here + t * step];
        if (xb >= 0 && yb >= 0 && xb < w && yb < h) db = masked[here - t * step];
      } else {
        da = masked[here + t * step];
        db = masked[here - t * step];
      }
      response += (twice - da) - db;
    }
    const float length = (k < 2) ? 1.f : 1.41421356237f;  // |d|
    const float norm = static_cast<float>(m * (m + 1)) * length;
    const float ratio = response / norm;
    if (ratio > best) best = ratio;
  }
  return best;
}

// masked as above; D >= kSkeletonMinDistance implies the pixel is foreground.
template <bool kChecked = true>
VPR_HD inline bool skeleton_at(const float* masked, int w, int h, int x, int y, int m) {
  if (!(masked[static_cast<long long>(y) * w + x] >= kSkeletonMinDistance)) return false;
  return skeleton_response_at<kChecked>(masked, w, h, x, y, m) >= kSkeletonMinResponse;
}

// Majority of the (2r+1) x (2r+1) window (edges clamped) of a mask: the median
// of a 0/1 image.
VPR_HD inline uint8_t majority_at(const uint8_t* mask, int w, int h, int x, int y, int r) {
  int ones = 0;
  for (int dy = -r; dy <= r; ++dy) {
    const uint8_t* row = mask + static_cast<long long>(clamp_index(y + dy, h)) * w;
    for (int dx = -r; dx <= r; ++dx) ones += row[clamp_index(x + dx, w)] != 0;
  }
  return ones > (2 * r + 1) * (2 * r + 1) / 2 ? 1 : 0;
}

// Eq. (5)'s kernels cannot see a ridge lower than kSkeletonMinDistance, so a
// part thinner than about 5 px (a strip 4 px wide has distance <= 1 throughout)
// has no skeleton of its own. Its silhouette pixels are told apart by having no
// foreground pixel with distance >= kSkeletonMinDistance within
// kThinPartReach px. On thick parts every silhouette pixel has one within 3 px:
// 2 sqrt 2 at a square corner, exactly 3 on some digitized slanted edges; we
// measured the maximum, 3, on rotated rectangles, ellipses and discs of radius
// 6 to 140 after the majority filter. Distances are square roots of integers,
// so the next value up is sqrt 10 and nothing lies between.
constexpr int kThinPartReach = 3;

VPR_HD inline bool near_thick_part(const float* dist, const uint8_t* foreground, int w, int h, int x, int y) {
  for (int dy = -kThinPartReach; dy <= kThinPartReach; ++dy) {
    for (int dx = -kThinPartReach; dx <= kThinPartReach; ++dx) {
      const int xx = x + dx, yy = y + dy;
      if (dx * dx + dy * dy > kThinPartReach * kThinPartReach || xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
      const long long j = static_cast<long long>(yy) * w + xx;
      if (foreground[j] && dist[j] >= kSkeletonMinDistance) return true;
    }
  }
  return false;
}

// Foreground pixel with a background 4-neighbour, or on the image border.
VPR_HD inline bool silhouette_at(const uint8_t* foreground, int w, int h, int x, int y) {
  const long long here = static_cast<long long>(y) * w + x;
  if (!foreground[here]) return false;
  if (x == 0 || y == 0 || x == w - 1 || y == h - 1) return true;
  return !foreground[here - 1] || !foreground[here + 1] || !foreground[here - w] || !foreground[here + w];
}

}  // namespace vpr
