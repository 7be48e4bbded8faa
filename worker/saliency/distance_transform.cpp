// Distance transform (Eq. 4), CPU twin: the exact Euclidean distance transform
// of Felzenszwalb and Huttenlocher, "Distance Transforms of Sampled Functions"
// (Theory of Computing 8, 2012), Section 2-3. Pass 1 finds, per column, the
// distance to the nearest seed in that column (two sweeps); pass 2 takes, per
// row, the lower envelope of the parabolas (x - q)^2 + f(q). Squared distances
// are integers and are computed as int64; only the envelope's breakpoints are
// doubles, and the distance at x is evaluated exactly from the winning
// parabola, so the result is the true distance, identical at any thread count.
#include "saliency/distance_transform.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace vpr {

Status check_distance_transform_args(const Mask& seeds) {
  const int w = seeds.width, h = seeds.height;
  if (w <= 0 || h <= 0 || seeds.pixels.size() != size_t(w) * size_t(h)) {
    return invalid_argument("distance_transform: image is " + std::to_string(w) + " x " + std::to_string(h) + " with " +
                            std::to_string(seeds.pixels.size()) +
                            " pixels; need a non-empty image with width * height pixels");
  }
  return Status::Ok();
}

namespace cpu {
namespace {

constexpr int64_t kNoSeed = -1;  // column without any seed: f(q) = infinity

// Pass 1 over columns [x0, x1): col[y * w + x] = squared distance from (x, y) to
// the nearest seed in column x. Sweeps rows so that memory is read in order.
void column_pass(const uint8_t* seeds, int w, int h, int x0, int x1, int64_t* col) {
  std::vector<int> last(static_cast<size_t>(x1 - x0));
  for (int& y : last) y = std::numeric_limits<int>::min() / 2;
  for (int y = 0; y < h; ++y) {  // nearest seed above (or at) y
    for (int x = x0; x < x1; ++x) {
      if (seeds[size_t(y) * w + x]) last[x - x0] = y;
      col[size_t(y) * w + x] = (last[x - x0] < 0) ? kNoSeed : int64_t(y - last[x - x0]);
    }
  }
  for (int& y : last) y = std::numeric_limits<int>::max() / 2;
  for (int y = h - 1; y >= 0; --y) {  // nearest seed below, then square
    for (int x = x0; x < x1; ++x) {
      if (seeds[size_t(y) * w + x]) last[x - x0] = y;
      int64_t& d = col[size_t(y) * w + x];
      if (last[x - x0] < h) {
        const int64_t below = last[x - x0] - y;
        if (d == kNoSeed || below < d) d = below;
      }
      if (d != kNoSeed) d = d * d;
    }
  }
}

// Pass 2 on one row: d2[x] = min_q (x - q)^2 + f[q] over the q with a finite f.
// v: sites on the envelope; z: breakpoints (z[k], z[k+1]) where v[k] is lowest.
void row_pass(const int64_t* f, int w, int64_t* d2, std::vector<int>& v, std::vector<double>& z) {
  v.resize(size_t(w));
  z.resize(size_t(w) + 1);
  int k = -1;
  for (int q = 0; q < w; ++q) {
    if (f[q] == kNoSeed) continue;
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -std::numeric_limits<double>::infinity();
      z[1] = std::numeric_limits<double>::infinity();
      continue;
    }
    double s;
    while (true) {
      const int p = v[k];
      // Where parabola q crosses parabola p (FH12, Algorithm 1).
      s = double((f[q] + int64_t(q) * q) - (f[p] + int64_t(p) * p)) / double(2 * (q - p));
      if (s <= z[k]) {
        --k;  // z[0] = -infinity stops this before k < 0
        continue;
      }
      break;
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = std::numeric_limits<double>::infinity();
  }
  assert(k >= 0);  // the caller only calls rows that have a finite site
  k = 0;
  for (int x = 0; x < w; ++x) {
    while (z[k + 1] < double(x)) ++k;
    const int64_t dx = x - v[k];
    d2[x] = dx * dx + f[v[k]];
  }
}

}  // namespace

Status distance_transform(const Mask& seeds, FloatImage* dist, const ExecContext& /*ctx*/) {
  assert(dist != nullptr);
  VPR_RETURN_IF_ERROR(check_distance_transform_args(seeds));
  const int w = seeds.width, h = seeds.height;
  *dist = FloatImage(w, h, std::numeric_limits<float>::infinity());
  bool any_seed = false;
  for (uint8_t s : seeds.pixels) {
    if (s) {
      any_seed = true;
      break;
    }
  }
  if (!any_seed) return Status::Ok();

  std::vector<int64_t> col(size_t(w) * h);
  constexpr int kColumnBlock = 64;  // columns per task: long enough rows for the cache
  const int blocks = (w + kColumnBlock - 1) / kColumnBlock;
  tbb::parallel_for(tbb::blocked_range<int>(0, blocks), [&](const tbb::blocked_range<int>& range) {
    for (int b = range.begin(); b != range.end(); ++b) {
      const int x0 = b * kColumnBlock, x1 = std::min(w, x0 + kColumnBlock);
      column_pass(seeds.pixels.data(), w, h, x0, x1, col.data());
    }
  });
  // Every row now has a finite site: each column holding a seed is finite throughout.
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    std::vector<int> v;
    std::vector<double> z;
    std::vector<int64_t> d2(static_cast<size_t>(w));
    for (int y = rows.begin(); y != rows.end(); ++y) {
      row_pass(col.data() + size_t(y) * w, w, d2.data(), v, z);
      float* out = dist->pixels.data() + size_t(y) * w;
      for (int x = 0; x < w; ++x) out[x] = static_cast<float>(std::sqrt(double(d2[x])));
    }
  });
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
