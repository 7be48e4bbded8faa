// Median pre-filter (Section III-A). CPU twin: Huang's sliding histogram
// (Huang, Yang, Tang 1979): one 256-bin histogram per row, updated by one
// column out and one column in per step, with the running median kept by the
// count of window values below it, so each pixel costs 2 * size updates and a
// few steps of the median pointer. The GPU twin uses median_at
// (image_kernels.h); both are exact, so they agree pixel for pixel.
#include "median_filter.h"

#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "image_kernels.h"

namespace vpr::cpu {

Status median_filter(const GrayImage& in, int size, GrayImage* out, const ExecContext& /*ctx*/) {
  assert(out != nullptr);
  if (in.width <= 0 || in.height <= 0 || in.pixels.size() != size_t(in.width) * size_t(in.height)) {
    return invalid_argument("median_filter: image is " + std::to_string(in.width) + " x " +
                            std::to_string(in.height) + " with " + std::to_string(in.pixels.size()) +
                            " pixels; need a non-empty image with width * height pixels");
  }
  if (size < 1 || size % 2 == 0 || size > 255) {
    return invalid_argument("median_filter: window size " + std::to_string(size) +
                            " must be odd and in [1, 255]");
  }
  const int w = in.width, h = in.height, r = size / 2;
  const int rank = size * size / 2;  // 0-based rank of the median in the sorted window
  *out = GrayImage(w, h);
  const uint8_t* src = in.pixels.data();
  uint8_t* dst = out->pixels.data();

  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    std::vector<const uint8_t*> window_rows(size);
    int hist[256];
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int j = 0; j < size; ++j) window_rows[j] = src + size_t(clamp_index(y + j - r, h)) * w;
      for (int& bin : hist) bin = 0;
      for (int j = 0; j < size; ++j) {
        for (int dx = -r; dx <= r; ++dx) ++hist[window_rows[j][clamp_index(dx, w)]];
      }
      // Invariant: below = number of window values < median, and
      // below <= rank < below + hist[median].
      int median = 0, below = 0;
      while (below + hist[median] <= rank) below += hist[median++];

      uint8_t* out_row = dst + size_t(y) * w;
      for (int x = 0; x < w; ++x) {
        out_row[x] = static_cast<uint8_t>(median);
        if (x + 1 == w) break;
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

}  // namespace vpr::cpu
