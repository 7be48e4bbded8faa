// A serial loop over sources (faces, corners, elements) that adds into items
// (vertices, cells, edge entries), run in parallel with the serial loop's
// bits: like in_vertex_ranges (vertex_ranges.h) the items are cut into one
// range per thread and each range's thread keeps only the updates of its own
// items, but each range's thread reads only the sources that touch its range
// (in source order), not every source, once there are kListedRanges ranges
// or more. It pays where skipping a source that is not the range's costs
// more than a read of its corners: the dual's cell faces (each face's three
// labels) took 16-17 ms of igea's 10,000-vertex job on an H200 with eight
// ranges, 11 ms listed. Where the skip is three compares of indices read in
// order (the vertex normals and areas, the CVT's cell sums) the listing
// measured no faster (the normals 10.3 ms before, 10.5 after), so those stay
// in_vertex_ranges.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/vertex_ranges.h"

namespace vpr {

// The sources one range reads, in ascending order: all of them, or a list.
class RangeSources {
 public:
  static RangeSources all(size_t count) { return RangeSources(nullptr, count); }
  static RangeSources listed(const std::vector<uint32_t>& list) { return RangeSources(list.data(), list.size()); }
  template <class Fn>
  void each(Fn&& fn) const {
    if (list_) {
      for (size_t i = 0; i < count_; ++i) fn(size_t(list_[i]));
    } else {
      for (size_t s = 0; s < count_; ++s) fn(s);
    }
  }

 private:
  RangeSources(const uint32_t* list, size_t count) : list_(list), count_(count) {}
  const uint32_t* list_;
  size_t count_;
};

// From this many ranges the sources are listed per range; with fewer each
// range reads every source, as in_vertex_ranges does: listing them costs a
// pass to mark and one to fill, about what two or three ranges' reading of
// every source costs (on 2 cores igea's job took 6 ms longer in its density
// stage, where the vertex areas are summed, with two listed ranges).
constexpr size_t kListedRanges = 4;

// items_of(s, emit): emit(item) for each item source s adds into (items at
// or past item_count are ignored). body(lo, hi, sources): the loop over
// `sources` (a RangeSources, each(fn) calling fn(s) in ascending order),
// applying only the updates of items in [lo, hi). The ranges are
// in_vertex_ranges': the same count and bounds.
template <class ItemsOf, class Body>
void in_item_ranges(size_t item_count, size_t source_count, ItemsOf&& items_of, Body&& body, size_t min_range = 16384) {
  const size_t ranges = vertex_range_count(item_count, min_range);
  if (ranges < kListedRanges || source_count >= UINT32_MAX) {
    tbb::parallel_for(size_t(0), ranges, [&](size_t r) {
      body(uint32_t(item_count * r / ranges), uint32_t(item_count * (r + 1) / ranges), RangeSources::all(source_count));
    });
    return;
  }
  auto bound = [&](size_t r) { return item_count * r / ranges; };
  // An item's range: how many of the ranges' starts past the first it is at
  // or beyond (compares, no division: this runs for every corner).
  size_t start[kMaxVertexRanges] = {};
  for (size_t r = 1; r < ranges; ++r) start[r] = bound(r);
  for (size_t r = ranges; r < kMaxVertexRanges; ++r) start[r] = SIZE_MAX;
  auto range_of = [&](uint32_t item) {
    size_t r = 0;
    for (size_t k = 1; k < kMaxVertexRanges; ++k) r += item >= start[k];
    return r;
  };
  // Each source's ranges (a bit each; kMaxVertexRanges <= 8), counted per
  // block of sources, then each range's list filled block by block.
  constexpr size_t kBlock = 16384;
  const size_t blocks = (source_count + kBlock - 1) / kBlock;
  std::vector<uint8_t> mask(source_count, 0);
  std::vector<uint32_t> at(blocks * ranges, 0);  // per block and range: its count, then its first slot
  tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
    uint32_t* count = &at[b * ranges];
    for (size_t s = b * kBlock, end = std::min(source_count, s + kBlock); s < end; ++s) {
      uint8_t m = 0;
      items_of(s, [&](uint32_t item) {
        if (item < item_count) m |= uint8_t(1u << range_of(item));
      });
      mask[s] = m;
      for (size_t r = 0; r < ranges; ++r) count[r] += m >> r & 1;
    }
  });
  std::vector<std::vector<uint32_t>> lists(ranges);
  for (size_t r = 0; r < ranges; ++r) {
    uint32_t total = 0;
    for (size_t b = 0; b < blocks; ++b) {
      const uint32_t n = at[b * ranges + r];
      at[b * ranges + r] = total;
      total += n;
    }
    lists[r].resize(total);
  }
  tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
    uint32_t* slot = &at[b * ranges];
    for (size_t s = b * kBlock, end = std::min(source_count, s + kBlock); s < end; ++s)
      for (size_t r = 0; r < ranges; ++r)
        if (mask[s] >> r & 1) lists[r][slot[r]++] = uint32_t(s);
  });
  tbb::parallel_for(size_t(0), ranges, [&](size_t r) {
    body(uint32_t(bound(r)), uint32_t(bound(r + 1)), RangeSources::listed(lists[r]));
  });
}

}  // namespace vpr
