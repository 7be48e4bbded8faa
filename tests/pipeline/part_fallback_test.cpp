// The part fallback: a part whose dual came out broken is replaced by a
// decimation that is whole (closed or with the part's boundary loops, one
// piece, the input's Euler characteristic); a part whose dual is whole is
// left bit for bit.
#include "pipeline/part_fallback.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include "surface/cluster_mesh.h"
#include "surface/mesh_edges.h"
#include "surface/surface_cvt.h"
#include "test_meshes.h"

namespace vpr {
namespace {

using testing::torus;

// Faces per edge (undirected).
std::map<std::pair<uint32_t, uint32_t>, int> edge_uses(const Mesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = m.indices[3 * f + k], b = m.indices[3 * f + (k + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  return uses;
}

// Edges in exactly two faces, and V - E + F.
std::pair<bool, long> closed_and_euler(const Mesh& m) {
  const auto uses = edge_uses(m);
  bool closed = !uses.empty();
  for (const auto& [e, n] : uses) closed = closed && n == 2;
  return {closed, long(m.vertex_count()) - long(uses.size()) + long(m.face_count())};
}

struct Dual {
  Mesh surface;
  MeshEdges edges;
  std::vector<uint32_t> label;
  uint32_t cells = 0;
  Mesh out;
  std::vector<uint32_t> cell;
};

// The CVT's cells on a surface and their dual, as the pipeline's meshing stage gets them.
Dual dual_of(const Mesh& surface, uint32_t count) {
  Dual d;
  d.surface = surface;
  d.edges = mesh_edges(d.surface);
  CvtStats stats;
  EXPECT_TRUE(surface_cvt(d.surface, d.edges, vertex_areas(d.surface), count, {}, &d.label, &stats).ok());
  d.cells = stats.clusters;
  ClusterMeshStats mesh_stats;
  EXPECT_TRUE(mesh_clusters(d.surface, d.edges, d.label, d.cells, &d.out, &d.cell, &mesh_stats).ok());
  return d;
}

Dual dual_of_torus(uint32_t count) { return dual_of(torus(1.0, 0.3, 48, 96), count); }

TEST(PartFallback, AWholeDualIsLeftAsItIs) {
  Dual d = dual_of_torus(300);
  ASSERT_EQ(closed_and_euler(d.out), std::make_pair(true, 0L));
  const Mesh before = d.out;
  PartFallbackStats stats;
  ASSERT_TRUE(replace_broken_parts(d.surface, d.edges, d.label, 300, &d.out, &d.cell, &stats).ok());
  EXPECT_EQ(stats.closed_parts, 1u);
  EXPECT_EQ(stats.parts_replaced, 0u);
  EXPECT_EQ(d.out.positions, before.positions);
  EXPECT_EQ(d.out.indices, before.indices);
}

TEST(PartFallback, ABrokenDualIsReplacedByAClosedTorusOfTheSameCount) {
  Dual d = dual_of_torus(300);
  // A hole in the dual: two faces gone.
  d.out.indices.erase(d.out.indices.begin(), d.out.indices.begin() + 6);
  ASSERT_FALSE(closed_and_euler(d.out).first);
  PartFallbackStats stats;
  ASSERT_TRUE(replace_broken_parts(d.surface, d.edges, d.label, 300, &d.out, &d.cell, &stats).ok());
  EXPECT_EQ(stats.parts_replaced, 1u);
  EXPECT_EQ(stats.parts_left, 0u);
  EXPECT_EQ(closed_and_euler(d.out), std::make_pair(true, 0L));  // closed, genus 1
  EXPECT_NEAR(double(d.out.vertex_count()), 300.0, 6.0);
  ASSERT_EQ(d.cell.size(), d.out.vertex_count());
  for (uint32_t c : d.cell) EXPECT_LT(c, d.cells);
  // On the torus: every vertex within 2% of the tube's radius of its surface.
  for (size_t v = 0; v < d.out.vertex_count(); ++v) {
    const double x = d.out.positions[3 * v], y = d.out.positions[3 * v + 1], z = d.out.positions[3 * v + 2];
    const double ring = std::hypot(x, y) - 1.0;
    EXPECT_NEAR(std::hypot(ring, z), 0.3, 0.3 * 0.1);
  }
}

// A curved open square, n x n quads: one boundary loop, Euler characteristic 1.
Mesh open_square(int n) {
  Mesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double x = double(i) / n, y = double(j) / n;
      m.positions.insert(m.positions.end(), {float(x), float(y), float(0.1 * std::sin(3 * x) * std::cos(2 * y))});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n) + 2, d = a + uint32_t(n) + 1;
      m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
    }
  return m;
}

// Boundary edges (in one face) and V - E + F.
std::pair<size_t, long> border_and_euler(const Mesh& m) {
  const auto uses = edge_uses(m);
  size_t border = 0;
  for (const auto& [e, n] : uses) border += n == 1;
  return {border, long(m.vertex_count()) - long(uses.size()) + long(m.face_count())};
}

TEST(PartFallback, AWholeOpenDualIsLeftAsItIs) {
  Dual d = dual_of(open_square(40), 200);
  ASSERT_GT(border_and_euler(d.out).first, 0u);
  ASSERT_EQ(border_and_euler(d.out).second, 1L);
  const Mesh before = d.out;
  PartFallbackStats stats;
  ASSERT_TRUE(replace_broken_parts(d.surface, d.edges, d.label, 200, &d.out, &d.cell, &stats).ok());
  EXPECT_EQ(stats.open_parts, 1u);
  EXPECT_EQ(stats.parts_replaced, 0u);
  EXPECT_EQ(d.out.indices, before.indices);
}

TEST(PartFallback, AnOpenPartWhoseDualIsGoneComesBackWithItsLoop) {
  // A small open part's few cells can leave no dual triangle (a fin on a box
  // at 100 vertices had four): the part, and its boundary loop, would be
  // lost. Here the whole dual is taken away.
  Dual d = dual_of(open_square(40), 50);
  d.out.indices.clear();
  PartFallbackStats stats;
  ASSERT_TRUE(replace_broken_parts(d.surface, d.edges, d.label, 50, &d.out, &d.cell, &stats).ok());
  EXPECT_EQ(stats.parts_replaced, 1u);
  ASSERT_GT(d.out.face_count(), 0u);
  const auto [border, euler] = border_and_euler(d.out);
  EXPECT_GT(border, 0u);
  EXPECT_EQ(euler, 1L);  // a disk again: one loop, no handle
  EXPECT_NEAR(double(d.out.vertex_count()), 50.0, 2.0);  // the part's share, every vertex in a face
  std::vector<char> in_face(d.out.vertex_count(), 0);
  for (uint32_t i : d.out.indices) in_face[i] = 1;
  EXPECT_EQ(std::count(in_face.begin(), in_face.end(), 1), long(d.out.vertex_count()));
  ASSERT_EQ(d.cell.size(), d.out.vertex_count());
  for (uint32_t c : d.cell) EXPECT_LT(c, d.cells);
}

TEST(PartFallback, APartTheCvtGaveNoCellIsLeftAlone) {
  // A target too small for every part leaves a part with no cell (its
  // elements unlabelled) and so no dual: by design, not broken. Replacing it
  // gave its vertices no cell to take (the pipeline fuzzer's input
  // part-with-no-cell-replaced read past the cells' sums).
  Dual d = dual_of_torus(300);
  const Mesh square = open_square(10);
  const uint32_t base = uint32_t(d.surface.vertex_count());
  d.surface.positions.insert(d.surface.positions.end(), square.positions.begin(), square.positions.end());
  for (uint32_t i : square.indices) d.surface.indices.push_back(base + i);
  d.label.resize(d.surface.vertex_count(), UINT32_MAX);
  d.edges = mesh_edges(d.surface);
  const Mesh before = d.out;
  PartFallbackStats stats;
  ASSERT_TRUE(replace_broken_parts(d.surface, d.edges, d.label, 300, &d.out, &d.cell, &stats).ok());
  EXPECT_EQ(stats.parts_replaced, 0u);
  EXPECT_EQ(d.out.indices, before.indices);
  for (uint32_t c : d.cell) EXPECT_LT(c, d.cells);
}

TEST(PartFallback, PartsJoinedInTheDualAreLeftTogether) {
  // Where input parts share vertices (a part that is not a manifold touching
  // another), a cell can span both and the dual joins them: a face has
  // corners in cells of two parts. Cutting one part out then split the fans
  // of the other's vertices around it (the pipeline fuzzer's input
  // nonmanifold-vertex-after-part-fallback). Here a vertex of square B's
  // dual takes a cell of square A, and B's dual is broken elsewhere.
  Mesh two = open_square(30);
  const Mesh b = open_square(30);
  const uint32_t base = uint32_t(two.vertex_count());
  for (size_t v = 0; v < b.vertex_count(); ++v)
    two.positions.insert(two.positions.end(), {b.positions[3 * v] + 2.0f, b.positions[3 * v + 1], b.positions[3 * v + 2]});
  for (uint32_t i : b.indices) two.indices.push_back(base + i);
  Dual d = dual_of(two, 200);
  // Each cell's square, by its surface vertices.
  std::vector<int> cell_square(d.cells, -1);
  for (size_t v = 0; v < d.surface.vertex_count(); ++v)
    if (d.label[v] < d.cells) cell_square[d.label[v]] = v < base ? 0 : 1;
  auto square_of = [&](uint32_t out_vertex) { return cell_square[d.cell[out_vertex]]; };
  // An output vertex of B used by at least three faces, none of which it leads.
  size_t face = d.out.face_count();
  for (size_t f = 0; f < d.out.face_count() && face == d.out.face_count(); ++f) {
    const uint32_t* t = &d.out.indices[3 * f];
    if (square_of(t[0]) != 1 || square_of(t[1]) != 1 || square_of(t[2]) != 1) continue;
    int uses = 0;
    for (uint32_t i : d.out.indices) uses += i == t[1];
    if (uses >= 3) face = f;
  }
  ASSERT_LT(face, d.out.face_count());
  const uint32_t moved = d.out.indices[3 * face + 1];
  uint32_t cell_in_a = 0;
  while (cell_square[cell_in_a] != 0) ++cell_in_a;
  d.cell[moved] = cell_in_a;
  // B broken away from that vertex: its last face (by first corner) removed.
  size_t last_b = d.out.face_count();
  for (size_t f = 0; f < d.out.face_count(); ++f) {
    const uint32_t* t = &d.out.indices[3 * f];
    if (square_of(t[0]) == 1 && t[0] != moved && t[1] != moved && t[2] != moved) last_b = f;
  }
  ASSERT_LT(last_b, d.out.face_count());
  d.out.indices.erase(d.out.indices.begin() + long(3 * last_b), d.out.indices.begin() + long(3 * last_b + 3));
  const Mesh before = d.out;
  PartFallbackStats stats;
  ASSERT_TRUE(replace_broken_parts(d.surface, d.edges, d.label, 200, &d.out, &d.cell, &stats).ok());
  EXPECT_EQ(stats.open_parts, 2u);
  EXPECT_EQ(stats.parts_replaced, 0u);
  EXPECT_EQ(stats.parts_left, 2u);  // joined: neither can be cut out alone
  EXPECT_EQ(d.out.indices, before.indices);
}

TEST(PartFallback, RefusesMismatchedInputs) {
  Dual d = dual_of_torus(100);
  d.cell.pop_back();
  PartFallbackStats stats;
  EXPECT_EQ(replace_broken_parts(d.surface, d.edges, d.label, 100, &d.out, &d.cell, &stats).code(),
            StatusCode::kInternal);
}

}  // namespace
}  // namespace vpr
