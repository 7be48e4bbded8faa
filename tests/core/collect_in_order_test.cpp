// The parallel scan that keeps a serial loop's output order (core/collect_in_order.h).
#include "core/collect_in_order.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cstdint>
#include <utility>
#include <vector>

namespace vpr {
namespace {

// Items i of [0, n) kept by an irregular rule, each emitted 0, 1 or 2 times.
void emit(size_t i, std::vector<std::pair<uint32_t, int>>* out) {
  const uint32_t h = uint32_t(i * 2654435761u) >> 27;  // 0..31, scattered
  if (h < 12) return;
  out->push_back({uint32_t(i), 0});
  if (h > 27) out->push_back({uint32_t(i), 1});
}

std::vector<std::pair<uint32_t, int>> serial(size_t n) {
  std::vector<std::pair<uint32_t, int>> out;
  for (size_t i = 0; i < n; ++i) emit(i, &out);
  return out;
}

TEST(CollectInOrder, GivesTheSerialLoopsListOnAnyThreadCount) {
  const size_t n = 100003;  // not a multiple of the block
  const std::vector<std::pair<uint32_t, int>> expected = serial(n);
  ASSERT_GT(expected.size(), n / 2);
  for (int threads : {1, 2}) {
    tbb::task_arena arena(threads);
    arena.execute([&] {
      for (size_t block : {size_t(1), size_t(7), size_t(16384)}) {
        const auto got = collect_in_order<std::pair<uint32_t, int>>(n, emit, block);
        EXPECT_EQ(got, expected) << threads << " threads, blocks of " << block;
      }
    });
  }
}

TEST(CollectInOrder, EmptyRangeAndNothingKept) {
  EXPECT_TRUE(collect_in_order<int>(0, [](size_t, std::vector<int>* out) { out->push_back(1); }).empty());
  EXPECT_TRUE(collect_in_order<int>(50000, [](size_t, std::vector<int>*) {}).empty());
}

}  // namespace
}  // namespace vpr
