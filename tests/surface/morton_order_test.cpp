// The Morton order that spreads the CVT's seeds (surface/morton_order.h).
#include "surface/morton_order.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <set>
#include <vector>

namespace vpr {
namespace {

// The points of an n x n x n grid in [0, 1]^3, x fastest.
std::vector<Vec3d> grid(int n) {
  std::vector<Vec3d> x;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) x.push_back({double(i) / (n - 1), double(j) / (n - 1), double(k) / (n - 1)});
  return x;
}

TEST(MortonOrder, EachOctantIsOneRunOfTheOrder) {
  const std::vector<Vec3d> x = grid(8);
  std::vector<uint32_t> all(x.size());
  std::iota(all.begin(), all.end(), 0u);
  std::reverse(all.begin(), all.end());  // the order must not come from the input's
  const std::vector<uint32_t> order = morton_order(x, all, {0, 0, 0}, 1.0);
  ASSERT_EQ(order.size(), x.size());
  EXPECT_EQ(std::set<uint32_t>(order.begin(), order.end()).size(), x.size());  // a permutation
  // Blocks of 4 x 4 x 4 and of 2 x 2 x 2 points, each consecutive in the order.
  for (int side : {4, 2}) {
    const size_t run = size_t(side) * side * side;
    for (size_t start = 0; start < order.size(); start += run) {
      std::set<int> blocks;
      for (size_t i = start; i < start + run; ++i) {
        const Vec3d& p = x[order[i]];
        const int bi = int(p.x * 7 + 0.5) / side, bj = int(p.y * 7 + 0.5) / side, bk = int(p.z * 7 + 0.5) / side;
        blocks.insert((bk * 8 + bj) * 8 + bi);
      }
      EXPECT_EQ(blocks.size(), 1u) << "block side " << side << ", run from " << start;
    }
  }
}

TEST(MortonOrder, TiesGoByIndexAndOnlyTheGivenElementsAreOrdered) {
  // Three points in one grid cell and one far away; only some elements given.
  const std::vector<Vec3d> x = {{0.5, 0.5, 0.5}, {1, 1, 1}, {0.5, 0.5, 0.5}, {0, 0, 0}, {0.5, 0.5, 0.5}};
  EXPECT_EQ(morton_order(x, {4, 1, 2, 0}, {0, 0, 0}, 1.0), (std::vector<uint32_t>{0, 2, 4, 1}));
  EXPECT_TRUE(morton_order(x, {}, {0, 0, 0}, 1.0).empty());
  // A flat box (zero extent) still gives an order: by index.
  EXPECT_EQ(morton_order(x, {2, 0}, {0.5, 0.5, 0.5}, 0.0), (std::vector<uint32_t>{0, 2}));
}

}  // namespace
}  // namespace vpr
