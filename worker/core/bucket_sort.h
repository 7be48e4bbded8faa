// Counting sort of items into buckets, in parallel, in an order that does not
// depend on the schedule. Shared by the density's curvature (its corners and
// edges by vertex), the attention field's vertex grid and the dual's cell
// faces.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <vector>

namespace vpr {

// Counting sort of items into buckets, in parallel, where source i puts its
// item make_item(i) into a few buckets: buckets_of(i, add) calls add(b) for
// each of them (b < buckets). start gets buckets + 1 offsets, slot the items
// bucket by bucket, each bucket then sorted by `less` (so the order is the
// same on any thread count whatever order the atomics filled it in).
template <class Item, class BucketsOf, class MakeItem, class Less>
void bucket_sort_each(size_t n, size_t buckets, BucketsOf buckets_of, MakeItem make_item, Less less,
                      std::vector<uint32_t>* start, std::vector<Item>* slot) {
  std::vector<std::atomic<uint32_t>> count(buckets + 1);
  for (auto& c : count) c.store(0, std::memory_order_relaxed);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i)
      buckets_of(i, [&](size_t b) { count[b + 1].fetch_add(1, std::memory_order_relaxed); });
  });
  start->assign(buckets + 1, 0);
  for (size_t b = 1; b <= buckets; ++b) (*start)[b] = (*start)[b - 1] + count[b].load(std::memory_order_relaxed);
  for (size_t b = 0; b < buckets; ++b) count[b].store((*start)[b], std::memory_order_relaxed);
  slot->resize((*start)[buckets]);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i)
      buckets_of(i, [&](size_t b) { (*slot)[count[b].fetch_add(1, std::memory_order_relaxed)] = make_item(i); });
  });
  tbb::parallel_for(tbb::blocked_range<size_t>(0, buckets, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t b = r.begin(); b != r.end(); ++b)
      std::sort(slot->begin() + (*start)[b], slot->begin() + (*start)[b + 1], less);
  });
}

// The same with one bucket a source: bucket_of(i) for item i in [0, n).
template <class Item, class BucketOf, class MakeItem, class Less>
void bucket_sort(size_t n, size_t buckets, BucketOf bucket_of, MakeItem make_item, Less less,
                 std::vector<uint32_t>* start, std::vector<Item>* slot) {
  bucket_sort_each<Item>(
      n, buckets, [&](size_t i, auto&& add) { add(size_t(bucket_of(i))); }, make_item, less, start, slot);
}

}  // namespace vpr
