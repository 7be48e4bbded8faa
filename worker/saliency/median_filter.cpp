// Median pre-filter (Section III-A). CPU twin: Huang's sliding histogram
// (Huang, Yang, Tang 1979): one 256-bin histogram per row, updated by one
// column out and one column in per step, with the running median kept by the
// count of window values below it, so each pixel costs 2 * size updates and a
// few steps of the median pointer. The GPU twin uses median_at
// (image_kernels.h); both are exact, so they agree pixel for pixel.
#include "saliency/median_filter.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <string>
#include <vector>

#include "saliency/image_kernels.h"

namespace vpr {

Status check_median_filter_args(const char* what, const Image<uint8_t>& in, int size) {
  const int w = in.width, h = in.height;
  const size_t pixels = in.pixels.size();
  if (w <= 0 || h <= 0 || pixels != size_t(w) * size_t(h)) {
    return invalid_argument(std::string(what) + ": image is " + std::to_string(w) + " x " + std::to_string(h) +
                            " with " + std::to_string(pixels) +
                            " pixels; need a non-empty image with width * height pixels");
  }
  if (size < 1 || size % 2 == 0 || size > 255) {
    return invalid_argument(std::string(what) + ": window size " + std::to_string(size) +
                            " must be odd and in [1, 255]");
  }
  return Status::Ok();
}

namespace cpu {

Status median_filter(const GrayImage& in, int size, GrayImage* out, const ExecContext& /*ctx*/) {
  assert(out != nullptr);
  VPR_RETURN_IF_ERROR(check_median_filter_args("median_filter", in, size));
  const int w = in.width, h = in.height, r = size / 2;
  const int rank = size * size / 2;  // 0-based rank of the median in the sorted window
  *out = GrayImage(w, h, 0);
  const uint8_t* src = in.pixels.data();
  uint8_t* dst = out->pixels.data();

  // Snapshots are mostly background (0), and a window holding only zeros has
  // median 0: per row, only the span within r of a nonzero pixel of its band
  // of rows is filtered; the rest keeps the 0 it was given. Exact for any image.
  std::vector<int> first_nonzero(h), last_nonzero(h);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      const uint8_t* row = src + size_t(y) * w;
      int first = w, last = -1;
      for (int x = 0; x < w; ++x) {
        if (row[x]) {
          first = std::min(first, x);
          last = x;
        }
      }
      first_nonzero[y] = first;
      last_nonzero[y] = last;
    }
  });

  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    std::vector<const uint8_t*> window_rows(size);
    int hist[256];
    for (int y = rows.begin(); y != rows.end(); ++y) {
      int first = w, last = -1;
      for (int j = 0; j < size; ++j) {
        const int source_row = clamp_index(y + j - r, h);
        window_rows[j] = src + size_t(source_row) * w;
        first = std::min(first, first_nonzero[source_row]);
        last = std::max(last, last_nonzero[source_row]);
      }
      if (last < 0) continue;  // the whole band is 0
      const int x_begin = std::max(0, first - r), x_end = std::min(w, last + r + 1);

      for (int& bin : hist) bin = 0;
      for (int j = 0; j < size; ++j) {
        for (int dx = -r; dx <= r; ++dx) ++hist[window_rows[j][clamp_index(x_begin + dx, w)]];
      }
      // Invariant: below = number of window values < median, and
      // below <= rank < below + hist[median].
      int median = 0, below = 0;
      while (below + hist[median] <= rank) below += hist[median++];

      uint8_t* out_row = dst + size_t(y) * w;
      for (int x = x_begin; x < x_end; ++x) {
        out_row[x] = static_cast<uint8_t>(median);
        if (x + 1 == x_end) break;
        const int leaving = clamp_index(x - r, w), entering = clamp_index(x + r + 1, w);
        if (leaving == entering) continue;  // both clamped to the same edge column
        for (int j = 0; j < size; ++j) {
          const int out_value = window_rows[j][leaving], in_value = window_rows[j][entering];
          --hist[out_value];
          below -= out_value < median;
          ++hist[in_value];
          below += in_value < median;
        }
        while (below > rank) below -= hist[--median];
        while (below + hist[median] <= rank) below += hist[median++];
      }
    }
  });
  return Status::Ok();
}

Status majority_filter(const Mask& in, int size, Mask* out, const ExecContext& /*ctx*/) {
  assert(out != nullptr);
  VPR_RETURN_IF_ERROR(check_median_filter_args("majority_filter", in, size));
  const int w = in.width, h = in.height, r = size / 2;
  const int rank = size * size / 2;
  // Vertical counts per column (clamped rows), then a horizontal window over them.
  std::vector<int> column_count(size_t(w) * h);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      int* counts = column_count.data() + size_t(y) * w;
      for (int x = 0; x < w; ++x) counts[x] = 0;
      for (int dy = -r; dy <= r; ++dy) {
        const uint8_t* row = in.pixels.data() + size_t(clamp_index(y + dy, h)) * w;
        for (int x = 0; x < w; ++x) counts[x] += row[x] != 0;
      }
    }
  });
  *out = Mask(w, h, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      const int* counts = column_count.data() + size_t(y) * w;
      uint8_t* out_row = out->pixels.data() + size_t(y) * w;
      int ones = 0;
      for (int dx = -r; dx <= r; ++dx) ones += counts[clamp_index(dx, w)];
      for (int x = 0; x < w; ++x) {
        out_row[x] = ones > rank;  // the sorted window's middle element is 1
        ones += counts[clamp_index(x + r + 1, w)] - counts[clamp_index(x - r, w)];
      }
    }
  });
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
