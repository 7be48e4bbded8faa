// A serial scatter over faces run by item ranges that read only their own
// sources (core/range_lists.h): every vertex gets the serial loop's updates
// in its order, so sums in double are the serial loop's bit for bit, on any
// thread count and with up to eight ranges; each range reads only the faces
// that touch it, once each, in order.
#include "core/range_lists.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <set>
#include <vector>

#include "scatter_case.h"

namespace vpr {
namespace {

TEST(RangeLists, ScatteredSumsAreTheSerialLoopsOnAnyThreadCount) {
  // 300,000 "faces" of three pseudo-random vertices among 100,000 (and, in
  // every 97th face, an item past the end, which no range takes), each
  // adding a value whose rounding depends on the order of the additions.
  const size_t nv = 100000, nf = 300000;
  std::vector<uint32_t> corner = testing::random_corners(nv, nf);
  for (size_t i = 0; i < corner.size(); i += 291) corner[i] = uint32_t(nv + i % 5);
  auto value = testing::order_sensitive_value;
  std::vector<double> serial(nv, 0.0);
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      if (corner[3 * f + k] < nv) serial[corner[3 * f + k]] += value(f);
  auto corners = [&](size_t f, auto&& emit) {
    for (int k = 0; k < 3; ++k) emit(corner[3 * f + k]);
  };
  for (int threads : {1, 2, 3, 8, 16}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    tbb::task_arena arena(threads);
    std::vector<double> sum(nv, 0.0);
    std::vector<std::atomic<int>> covered(nv);
    std::mutex lock;
    std::set<std::pair<uint32_t, uint32_t>> ranges;
    bool ordered = true, complete = true, read_all = false;
    arena.execute([&] {
      in_item_ranges(nv, nf, corners, [&](uint32_t lo, uint32_t hi, const RangeSources& faces) {
        for (uint32_t v = lo; v < hi; ++v) ++covered[v];
        size_t last = SIZE_MAX, read = 0;
        bool in_order = true;
        faces.each([&](size_t f) {
          in_order = in_order && (last == SIZE_MAX || f > last);
          last = f;
          ++read;
          for (int k = 0; k < 3; ++k)
            if (corner[3 * f + k] >= lo && corner[3 * f + k] < hi) sum[corner[3 * f + k]] += value(f);
        });
        // Every face with a corner in [lo, hi) was read.
        size_t touching = 0;
        for (size_t f = 0; f < nf; ++f)
          touching += (corner[3 * f] >= lo && corner[3 * f] < hi) ||
                      (corner[3 * f + 1] >= lo && corner[3 * f + 1] < hi) ||
                      (corner[3 * f + 2] >= lo && corner[3 * f + 2] < hi);
        std::lock_guard<std::mutex> guard(lock);
        ranges.insert({lo, hi});
        ordered = ordered && in_order;
        complete = complete && (read == touching || read == nf);
        read_all = read_all || read == nf;
      });
    });
    const size_t expected = std::min<size_t>({size_t(threads), nv / 16384, kMaxVertexRanges});
    EXPECT_EQ(ranges.size(), std::max<size_t>(1, expected)) << threads << " threads";
    size_t once = 0;
    for (const auto& c : covered) once += c.load() == 1;
    EXPECT_EQ(once, nv) << "the ranges cover every vertex once";
    EXPECT_TRUE(ordered) << threads << " threads: each range's faces in ascending order";
    EXPECT_TRUE(complete) << threads << " threads: each range read the faces that touch it, or all";
    EXPECT_EQ(read_all, expected < kListedRanges) << threads << " threads: listed from kListedRanges ranges on";
    EXPECT_EQ(sum, serial) << threads << " threads";
  }
}

TEST(RangeLists, EmptyAndTinyLoops) {
  int calls = 0;
  in_item_ranges(
      0, 0, [](size_t, auto&&) {},
      [&](uint32_t lo, uint32_t hi, const RangeSources& s) {
        ++calls;
        EXPECT_EQ(lo, 0u);
        EXPECT_EQ(hi, 0u);
        s.each([](size_t) { ADD_FAILURE() << "no source to read"; });
      });
  EXPECT_EQ(calls, 1);
}

}  // namespace
}  // namespace vpr
