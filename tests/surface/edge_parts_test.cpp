// Connected parts of an edge graph in parallel (surface/edge_parts.h): the
// serial walk's numbering on any thread count.
#include "surface/edge_parts.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <random>
#include <vector>

namespace vpr {
namespace {

// The walk edge_parts replaced: from each vertex not yet reached, in index
// order, a new part.
std::vector<uint32_t> walked_parts(const MeshEdges& edges) {
  std::vector<uint32_t> part(edges.vertex_count(), UINT32_MAX);
  uint32_t parts = 0;
  for (uint32_t s = 0; s < edges.vertex_count(); ++s) {
    if (part[s] != UINT32_MAX || edges.degree(s) == 0) continue;
    std::vector<uint32_t> stack = {s};
    part[s] = parts;
    while (!stack.empty()) {
      const uint32_t v = stack.back();
      stack.pop_back();
      for (const uint32_t* w = edges.begin(v); w != edges.end(v); ++w)
        if (part[*w] == UINT32_MAX) part[*w] = parts, stack.push_back(*w);
    }
    ++parts;
  }
  return part;
}

// Many small strips of triangles over shuffled vertex numbers, so that the
// parts interleave in index order and their lowest vertices lie anywhere;
// every tenth vertex is used by no face.
std::vector<uint32_t> shuffled_strips(uint32_t vertices, uint32_t seed, uint32_t* unused) {
  std::mt19937 rng(seed);
  std::vector<uint32_t> name(vertices);
  for (uint32_t v = 0; v < vertices; ++v) name[v] = v;
  std::shuffle(name.begin(), name.end(), rng);
  std::vector<uint32_t> indices;
  std::uniform_int_distribution<uint32_t> length(3, 60);
  uint32_t v = 0;
  *unused = 0;
  while (v + 3 <= vertices) {
    if (v % 10 == 0) {
      ++v;
      ++*unused;
      continue;
    }
    const uint32_t end = std::min(vertices, v + length(rng));
    for (uint32_t a = v; a + 2 < end; ++a) indices.insert(indices.end(), {name[a], name[a + 1], name[a + 2]});
    v = end;
  }
  *unused += vertices - v;
  return indices;
}

TEST(EdgeParts, ThePartsAndTheirNumbersAreTheSerialWalksOnAnyThreadCount) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    const uint32_t nv = 200000;
    uint32_t unused = 0;
    const MeshEdges edges = mesh_edges(shuffled_strips(nv, seed, &unused), nv);
    const std::vector<uint32_t> expected = walked_parts(edges);
    for (int threads : {1, 2, 4, 8}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      const EdgeParts got = edge_parts(edges);
      ASSERT_EQ(got.part, expected) << "seed " << seed << ", " << threads << " threads";
      size_t listed = 0;
      for (size_t p = 0; p < got.elements.size(); ++p) {
        EXPECT_TRUE(std::is_sorted(got.elements[p].begin(), got.elements[p].end()));
        for (uint32_t v : got.elements[p]) EXPECT_EQ(got.part[v], p);
        listed += got.elements[p].size();
      }
      EXPECT_EQ(listed + unused, nv) << "every vertex with an edge listed once, the unused in no part";
      EXPECT_GT(got.elements.size(), 1000u);
    }
  }
}

TEST(EdgeParts, OnePartWhenAChainJoinsEveryVertex) {
  // A strip whose vertices are numbered from both ends inward: the links meet
  // in the middle, and the root must still be vertex 0.
  const uint32_t nv = 50000;
  std::vector<uint32_t> name(nv), indices;
  for (uint32_t i = 0; i < nv; ++i) name[i] = i % 2 ? nv - 1 - i / 2 : i / 2;
  for (uint32_t a = 0; a + 2 < nv; ++a) indices.insert(indices.end(), {name[a], name[a + 1], name[a + 2]});
  const EdgeParts got = edge_parts(mesh_edges(indices, nv));
  ASSERT_EQ(got.elements.size(), 1u);
  EXPECT_EQ(got.elements[0].size(), nv);
  EXPECT_EQ(got.elements[0].front(), 0u);
}

}  // namespace
}  // namespace vpr
