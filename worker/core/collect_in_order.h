// A serial loop's output list, made in parallel: `for i in [0, n): emit(i,
// &list)` where emit appends zero or more items. The range is cut into
// fixed blocks (their size never depends on the thread count), each block
// fills its own list, and the lists are joined in block order, so the
// result is the one the serial loop gives, item for item, on any thread
// count. For scans of every face or corner that keep few of them (the
// faces whose corners lie in three cells, the long edges of a refinement
// pass): the scan was a serial step of stages whose other steps run on
// every core.
#pragma once

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <vector>

namespace vpr {

template <class T, class Emit>
std::vector<T> collect_in_order(size_t n, Emit&& emit, size_t block = 16384) {
  const size_t blocks = (n + block - 1) / block;
  std::vector<std::vector<T>> part(blocks);
  tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
    const size_t end = std::min(n, (b + 1) * block);
    for (size_t i = b * block; i < end; ++i) emit(i, &part[b]);
  });
  std::vector<size_t> start(blocks + 1, 0);
  for (size_t b = 0; b < blocks; ++b) start[b + 1] = start[b] + part[b].size();
  std::vector<T> out(start[blocks]);
  tbb::parallel_for(size_t(0), blocks,
                    [&](size_t b) { std::copy(part[b].begin(), part[b].end(), out.begin() + start[b]); });
  return out;
}

}  // namespace vpr
