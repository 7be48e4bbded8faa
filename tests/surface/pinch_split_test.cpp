// Pinched vertices split per fan: counted from the returned index buffer.
#include "surface/pinch_split.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <set>
#include <vector>

#include "test_meshes.h"

namespace vpr {
namespace {

// Fans at each vertex: faces joined by an edge at it (union-find per vertex).
size_t most_fans(const std::vector<uint32_t>& indices, size_t vertex_count) {
  size_t most = 0;
  for (uint32_t v = 0; v < vertex_count; ++v) {
    std::vector<size_t> faces;
    for (size_t f = 0; f < indices.size() / 3; ++f)
      if (indices[3 * f] == v || indices[3 * f + 1] == v || indices[3 * f + 2] == v) faces.push_back(f);
    std::vector<size_t> parent(faces.size());
    std::iota(parent.begin(), parent.end(), size_t(0));
    auto find = [&](size_t a) {
      while (parent[a] != a) a = parent[a];
      return a;
    };
    for (size_t i = 0; i < faces.size(); ++i)
      for (size_t j = i + 1; j < faces.size(); ++j) {
        int shared = 0;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) shared += indices[3 * faces[i] + a] == indices[3 * faces[j] + b];
        if (shared >= 2) parent[find(i)] = find(j);  // v and one more: an edge at v
      }
    std::set<size_t> roots;
    for (size_t i = 0; i < faces.size(); ++i) roots.insert(find(i));
    most = std::max(most, roots.size());
  }
  return most;
}

// A tetrahedron (outward faces) whose first vertex is `apex` and the others new.
void add_tetrahedron(std::vector<uint32_t>* indices, uint32_t apex, uint32_t* next) {
  const uint32_t a = apex, b = (*next)++, c = (*next)++, d = (*next)++;
  indices->insert(indices->end(), {a, b, c, a, c, d, a, d, b, b, d, c});
}

TEST(PinchSplit, AManifoldMeshIsLeftAsItIs) {
  const Mesh sphere = testing::icosphere(2);
  std::vector<uint32_t> indices = sphere.indices;
  size_t count = sphere.vertex_count();
  EXPECT_TRUE(split_pinched_vertices(&indices, &count).empty());
  EXPECT_EQ(count, sphere.vertex_count());
  EXPECT_EQ(indices, sphere.indices);
}

TEST(PinchSplit, ThreeTetrahedraAtOneVertexGetTwoCopies) {
  std::vector<uint32_t> indices;
  uint32_t next = 1;
  for (int k = 0; k < 3; ++k) add_tetrahedron(&indices, 0, &next);
  size_t count = next;
  ASSERT_EQ(most_fans(indices, count), 3u);
  const std::vector<uint32_t> before = indices;
  const auto copies = split_pinched_vertices(&indices, &count);
  ASSERT_EQ(copies.size(), 2u);
  EXPECT_EQ(count, size_t(next) + 2);
  EXPECT_EQ(copies[0], std::make_pair(next, 0u));
  EXPECT_EQ(copies[1], std::make_pair(next + 1, 0u));
  EXPECT_EQ(most_fans(indices, count), 1u);
  // The first tetrahedron keeps vertex 0, the second and third take the
  // copies in order; nothing else changes.
  for (size_t c = 0; c < indices.size(); ++c) {
    const size_t tet = c / 12;
    const uint32_t want = before[c] != 0 ? before[c] : tet == 0 ? 0u : next + uint32_t(tet) - 1;
    EXPECT_EQ(indices[c], want) << c;
  }
}

TEST(PinchSplit, TwoSheetsMeetingAtACornerComeApart) {
  // A bowtie: two triangles sharing only vertex 0; and a degenerate face at
  // vertex 0 (a repeated corner), which joins nothing and is left alone.
  std::vector<uint32_t> indices = {0, 1, 2, 0, 3, 4, 0, 0, 5};
  size_t count = 6;
  const auto copies = split_pinched_vertices(&indices, &count);
  ASSERT_EQ(copies.size(), 1u);
  EXPECT_EQ(copies[0], std::make_pair(6u, 0u));
  EXPECT_EQ(indices, (std::vector<uint32_t>{0, 1, 2, 6, 3, 4, 0, 0, 5}));
}

TEST(PinchSplit, AVertexWhereFansJoinThroughAnotherVertexIsNotSplit) {
  // Four triangles round vertex 0, closed into one fan: no copy.
  std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1};
  size_t count = 5;
  EXPECT_TRUE(split_pinched_vertices(&indices, &count).empty());
  EXPECT_EQ(count, 5u);
}

}  // namespace
}  // namespace vpr
