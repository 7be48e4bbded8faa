// A mesh's edge rows (surface/mesh_edges.h): every edge once per end, rows
// ascending, each with the number of faces using it, whatever the face order
// or the thread count.
#include "surface/mesh_edges.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <map>
#include <random>
#include <utility>
#include <vector>

namespace vpr {
namespace {

// Random triangles over `vertices` vertices with what real meshes hold:
// faces repeated (edges of three or four faces), corners repeated (no edge),
// and vertices no face uses.
std::vector<uint32_t> messy_faces(uint32_t vertices, size_t faces, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<uint32_t> pick(0, vertices - 1);
  std::vector<uint32_t> idx;
  for (size_t f = 0; f < faces; ++f) {
    uint32_t a = pick(rng), b = pick(rng), c = pick(rng);
    if (f % 17 == 0) b = a;  // a degenerate corner
    if (a % 10 == 9 || b % 10 == 9 || c % 10 == 9) continue;  // every tenth vertex unused
    idx.insert(idx.end(), {a, b, c});
    if (f % 13 == 0) idx.insert(idx.end(), {c, b, a});  // the same face again, flipped
  }
  return idx;
}

// The rows from an ordered map of undirected edges, the plain way.
MeshEdges edges_by_map(const std::vector<uint32_t>& idx, size_t vertex_count) {
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> uses;
  for (size_t f = 0; f + 2 < idx.size(); f += 3)
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = idx[f + c], b = idx[f + (c + 1) % 3];
      if (a == b) continue;
      ++uses[{a, b}];
      ++uses[{b, a}];
    }
  MeshEdges e;
  e.offset.assign(vertex_count + 1, 0);
  for (const auto& [edge, n] : uses) {
    ++e.offset[edge.first + 1];
    e.neighbor.push_back(edge.second);
    e.faces.push_back(n);
  }
  for (size_t v = 0; v < vertex_count; ++v) e.offset[v + 1] += e.offset[v];
  return e;
}

void expect_same(const MeshEdges& a, const MeshEdges& b) {
  EXPECT_EQ(a.offset, b.offset);
  EXPECT_EQ(a.neighbor, b.neighbor);
  EXPECT_EQ(a.faces, b.faces);
}

TEST(MeshEdgesTest, RowsMatchAnOrderedMapOfEdges) {
  const uint32_t nv = 60000;
  const std::vector<uint32_t> idx = messy_faces(nv, 150000, 7);
  const MeshEdges e = mesh_edges(idx, nv);
  const MeshEdges want = edges_by_map(idx, nv);
  expect_same(e, want);
  // What the messy faces were for: edges of several faces, and empty rows.
  EXPECT_GT(*std::max_element(e.faces.begin(), e.faces.end()), 2u);
  EXPECT_EQ(e.degree(9), 0u);
  for (uint32_t v = 0; v < nv; ++v)
    ASSERT_TRUE(std::is_sorted(e.begin(v), e.end(v))) << "row " << v;
  // entry() finds an edge from either end, and nothing else.
  const uint32_t a = idx[0], b = idx[2];
  if (a != b) {
    ASSERT_NE(e.entry(a, b), UINT32_MAX);
    EXPECT_EQ(e.neighbor[e.entry(a, b)], b);
  }
  EXPECT_EQ(e.entry(9, 0), UINT32_MAX);
}

TEST(MeshEdgesTest, FaceOrderAndThreadCountDoNotMatter) {
  const uint32_t nv = 40000;
  std::vector<uint32_t> idx = messy_faces(nv, 120000, 11);
  const MeshEdges want = mesh_edges(idx, nv);
  // The faces shuffled (each face's corners kept together).
  std::vector<size_t> order(idx.size() / 3);
  for (size_t f = 0; f < order.size(); ++f) order[f] = f;
  std::shuffle(order.begin(), order.end(), std::mt19937(3));
  std::vector<uint32_t> shuffled;
  for (size_t f : order) shuffled.insert(shuffled.end(), idx.begin() + 3 * f, idx.begin() + 3 * f + 3);
  // 1-4 threads fill the rows by vertex ranges, 8 and 16 from the corners
  // (mesh_edges.cpp); an arena of that many threads, so that a machine of
  // fewer cores runs each way too.
  for (int threads : {1, 2, 4, 8, 16}) {
    SCOPED_TRACE(threads);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    tbb::task_arena(threads).execute([&] {
      expect_same(mesh_edges(idx, nv), want);
      expect_same(mesh_edges(shuffled, nv), want);
    });
  }
}

// On 8 threads the rows are made from each vertex's corners, which a caller
// may keep: every corner once, in its vertex's row, the rows ascending (the
// vertex's faces in face order, a face with the vertex twice twice in a
// row); the rows the same as without them. On fewer threads none are made.
TEST(MeshEdgesTest, CornersByVertexAreEveryCornerInOrder) {
  const uint32_t nv = 30000;
  std::vector<uint32_t> idx = messy_faces(nv, 90000, 5);
  idx.insert(idx.end(), {17, 17, 40, 41, 17, 17});  // faces holding a vertex twice
  const size_t holding_17_twice = idx.size() - 6;
  for (uint32_t k = 0; k < 40; ++k) idx.insert(idx.end(), {100 + k, 5, 101 + k});  // vertex 5: a fan of 40 more
  const MeshEdges want = edges_by_map(idx, nv);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 8);  // over the cores where fewer
  tbb::task_arena(8).execute([&] {
    VertexCorners corners;
    expect_same(mesh_edges(idx, nv, &corners), want);
    ASSERT_TRUE(corners.built(nv));
    ASSERT_EQ(corners.corner.size(), idx.size());
    std::vector<int> seen(idx.size(), 0);
    size_t misplaced = 0, unordered = 0;
    for (uint32_t v = 0; v < nv; ++v)
      for (uint32_t i = corners.offset[v]; i < corners.offset[v + 1]; ++i) {
        const uint32_t h = corners.corner[i];
        ++seen[h];
        misplaced += idx[h] != v;
        unordered += i > corners.offset[v] && corners.corner[i - 1] >= h;
      }
    EXPECT_EQ(misplaced, 0u);
    EXPECT_EQ(unordered, 0u);
    EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), std::ptrdiff_t(idx.size()));
    const size_t last = holding_17_twice;  // vertex 17's last four corners: both faces, in order
    EXPECT_TRUE(std::equal(
        corners.corner.begin() + corners.offset[18] - 4, corners.corner.begin() + corners.offset[18],
        std::vector<uint32_t>{uint32_t(last), uint32_t(last + 1), uint32_t(last + 4), uint32_t(last + 5)}.begin()));
  });
  tbb::task_arena(2).execute([&] {
    VertexCorners corners;
    corners.offset = {1, 2, 3};  // cleared: not made on 2 threads
    expect_same(mesh_edges(idx, nv, &corners), want);
    EXPECT_FALSE(corners.built(nv));
    EXPECT_TRUE(corners.offset.empty());
  });
  // vertex_corners alone: a counting sort on 2 threads, slots and sorted rows
  // on 8 (vertex 5's row of over 32 corners sorted the other way): the same.
  VertexCorners two, eight;
  tbb::task_arena(2).execute([&] { two = vertex_corners(idx, nv); });
  tbb::task_arena(8).execute([&] { eight = vertex_corners(idx, nv); });
  EXPECT_GT(two.offset[6] - two.offset[5], 32u);
  EXPECT_EQ(two.offset, eight.offset);
  EXPECT_EQ(two.corner, eight.corner);
}

TEST(MeshEdgesTest, EmptyAndDegenerateMeshesGiveEmptyRows) {
  const MeshEdges none = mesh_edges(std::vector<uint32_t>{}, 0);
  EXPECT_EQ(none.offset, std::vector<uint32_t>{0});
  const MeshEdges flat = mesh_edges(std::vector<uint32_t>{0, 0, 0, 1, 1, 1}, 3);
  EXPECT_EQ(flat.offset, (std::vector<uint32_t>{0, 0, 0, 0}));
  EXPECT_TRUE(flat.neighbor.empty());
}

}  // namespace
}  // namespace vpr
