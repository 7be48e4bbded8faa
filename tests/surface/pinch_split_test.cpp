// Pinched vertices split per fan: counted from the returned index buffer.
#include "surface/pinch_split.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
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

// A tetrahedron whose first vertex is `apex` and whose base is `dir` away
// along x (tetrahedra that meet at a vertex only: their faces' orientation
// does not matter here).
void add_tetrahedron(std::vector<uint32_t>* indices, std::vector<double>* positions, uint32_t apex, double dir) {
  const uint32_t a = apex, b = uint32_t(positions->size() / 3), c = b + 1, d = b + 2;
  const double x = (*positions)[3 * apex], y = (*positions)[3 * apex + 1], z = (*positions)[3 * apex + 2];
  positions->insert(positions->end(), {x + dir, y + 1, z, x + dir, y - 1, z + 1, x + dir, y - 1, z - 1});
  indices->insert(indices->end(), {a, b, c, a, c, d, a, d, b, b, d, c});
}

// Positions of a mesh as doubles.
std::vector<double> doubles(const std::vector<float>& p) { return std::vector<double>(p.begin(), p.end()); }

TEST(PinchSplit, AManifoldMeshIsLeftAsItIs) {
  const Mesh sphere = testing::icosphere(2);
  std::vector<uint32_t> indices = sphere.indices;
  size_t count = sphere.vertex_count();
  EXPECT_TRUE(split_pinched_vertices(&indices, &count, doubles(sphere.positions)).empty());
  EXPECT_EQ(count, sphere.vertex_count());
  EXPECT_EQ(indices, sphere.indices);
}

TEST(PinchSplit, ThreeTetrahedraAtOneVertexGetTwoCopies) {
  std::vector<uint32_t> indices;
  std::vector<double> positions = {0, 0, 0};
  for (double dir : {1.0, -1.0, 2.0}) add_tetrahedron(&indices, &positions, 0, dir);
  const uint32_t next = uint32_t(positions.size() / 3);
  size_t count = next;
  ASSERT_EQ(most_fans(indices, count), 3u);
  const std::vector<uint32_t> before = indices;
  const auto copies = split_pinched_vertices(&indices, &count, positions);
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

TEST(PinchSplit, ThousandsOfPinchesComeApartTheSameOnAnyThreadCount) {
  // The pinched vertices are found in parallel, then walked in order with
  // their neighbours: 3,000 vertices each where three tetrahedra meet (among
  // 30,000) give two copies each, numbered in vertex order, on any thread
  // count.
  std::vector<uint32_t> start;
  std::vector<double> positions;
  for (int k = 0; k < 3000; ++k) {
    const uint32_t apex = uint32_t(positions.size() / 3);
    positions.insert(positions.end(), {10.0 * (k % 60), 10.0 * (k / 60), 0});
    for (double dir : {1.0, -1.0, 2.0}) add_tetrahedron(&start, &positions, apex, dir);
  }
  const size_t vertices = positions.size() / 3;
  std::vector<uint32_t> reference;
  std::vector<std::pair<uint32_t, uint32_t>> reference_copies;
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<uint32_t> indices = start;
    size_t count = vertices;
    const auto copies = split_pinched_vertices(&indices, &count, positions);
    ASSERT_EQ(copies.size(), 6000u);
    EXPECT_EQ(count, vertices + 6000);
    for (size_t i = 0; i < copies.size(); ++i) {
      EXPECT_EQ(copies[i].first, uint32_t(vertices + i));
      EXPECT_EQ(copies[i].second, uint32_t(10 * (i / 2))) << "apex " << i / 2;  // each apex twice, in order
    }
    if (threads == 1) {
      reference = indices;
      reference_copies = copies;
      continue;
    }
    EXPECT_EQ(indices, reference) << threads << " threads";
    EXPECT_EQ(copies, reference_copies) << threads << " threads";
  }
}

TEST(PinchSplit, TwoSheetsMeetingAtACornerComeApart) {
  // A bowtie: two triangles sharing only vertex 0; and a degenerate face at
  // vertex 0 (a repeated corner), which joins nothing and is left alone.
  std::vector<uint32_t> indices = {0, 1, 2, 0, 3, 4, 0, 0, 5};
  size_t count = 6;
  const std::vector<double> positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0, -1, -1, 0, 0, 0, 1};
  const auto copies = split_pinched_vertices(&indices, &count, positions);
  ASSERT_EQ(copies.size(), 1u);
  EXPECT_EQ(copies[0], std::make_pair(6u, 0u));
  EXPECT_EQ(indices, (std::vector<uint32_t>{0, 1, 2, 6, 3, 4, 0, 0, 5}));
}

TEST(PinchSplit, AVertexWhereFansJoinThroughAnotherVertexIsNotSplit) {
  // Four triangles round vertex 0, closed into one fan: no copy.
  std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1};
  size_t count = 5;
  const std::vector<double> positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0};
  EXPECT_TRUE(split_pinched_vertices(&indices, &count, positions).empty());
  EXPECT_EQ(count, 5u);
}

// How many faces use each edge, counted from the index buffer.
std::map<std::pair<uint32_t, uint32_t>, int> edge_uses(const std::vector<uint32_t>& indices) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (size_t f = 0; f < indices.size() / 3; ++f)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = indices[3 * f + k], b = indices[3 * f + (k + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  return uses;
}

// Edges used by more than two faces.
size_t crowded_edges(const std::vector<uint32_t>& indices) {
  size_t n = 0;
  for (const auto& [e, u] : edge_uses(indices)) n += u > 2;
  return n;
}

// Closed pieces: every edge of each piece (faces joined by edges) in two faces.
bool every_edge_in_two_faces(const std::vector<uint32_t>& indices) {
  for (const auto& [e, u] : edge_uses(indices))
    if (u != 2) return false;
  return true;
}

// An axis-aligned cube [x, x + 1] x [y, y + 1] x [0, 1] from 12 triangles, outward.
void add_cube(std::vector<uint32_t>* indices, std::vector<double>* positions, double x, double y) {
  const uint32_t base = uint32_t(positions->size() / 3);
  for (int c = 0; c < 8; ++c)
    positions->insert(positions->end(), {x + (c & 1), y + ((c >> 1) & 1), double((c >> 2) & 1)});
  const uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads)
    indices->insert(indices->end(), {base + q[0], base + q[1], base + q[2], base + q[0], base + q[2], base + q[3]});
}

// The vertices at the same position as another: welds them, as refine_surface does.
void weld(std::vector<uint32_t>* indices, const std::vector<double>& positions) {
  std::map<std::array<double, 3>, uint32_t> first;
  std::vector<uint32_t> to(positions.size() / 3);
  for (uint32_t v = 0; v < to.size(); ++v)
    to[v] = first.emplace(std::array<double, 3>{positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]}, v)
                .first->second;
  for (uint32_t& i : *indices) i = to[i];
}

// Unit cubes at (0, 0) and (x, y), welded where they touch.
void two_welded_cubes(double x, double y, std::vector<uint32_t>* indices, std::vector<double>* positions) {
  add_cube(indices, positions, 0, 0);
  add_cube(indices, positions, x, y);
  weld(indices, *positions);
}

TEST(PinchSplit, TwoCubesSharingAnEdgeComeApartAsTwoClosedCubes) {
  // Cubes [0,1]^3 and [1,2] x [1,2] x [0,1]: the edge x = y = 1 is in four
  // faces. Paired by the solid each bounds, each cube keeps its own two.
  std::vector<uint32_t> indices;
  std::vector<double> positions;
  two_welded_cubes(1, 1, &indices, &positions);
  size_t count = positions.size() / 3;
  ASSERT_EQ(crowded_edges(indices), 1u);
  const auto copies = split_pinched_vertices(&indices, &count, positions);
  EXPECT_EQ(copies.size(), 2u);  // the edge's two ends
  EXPECT_EQ(crowded_edges(indices), 0u);
  EXPECT_TRUE(every_edge_in_two_faces(indices));  // both cubes still closed
  EXPECT_EQ(most_fans(indices, count), 1u);
}

TEST(PinchSplit, ADoubleSidedSheetStaysJoined) {
  // A square drawn both ways round (a double-sided card, as game assets have
  // them): its diagonal is in four faces, two on top of two, with no sector
  // between them to pair by. It stays as it was.
  std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3, 0, 2, 1, 0, 3, 2};
  const std::vector<double> positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  const std::vector<uint32_t> before = indices;
  size_t count = 4;
  EXPECT_TRUE(split_pinched_vertices(&indices, &count, positions).empty());
  EXPECT_EQ(indices, before);
}

TEST(PinchSplit, TwoCubesSharingAFaceComeApartAsTwoClosedCubes) {
  // Cubes [0,1]^3 and [1,2] x [0,1] x [0,1], welded: their walls on x = 1 lie
  // on top of each other, drawn both ways round, and the wall's edges are in
  // four faces. The sector of no width between the two walls is outside
  // both: each cube keeps its own wall and comes back closed.
  std::vector<uint32_t> indices;
  std::vector<double> positions;
  two_welded_cubes(1, 0, &indices, &positions);
  size_t count = positions.size() / 3;
  ASSERT_EQ(crowded_edges(indices), 5u);  // the wall's four sides and its diagonal
  const auto copies = split_pinched_vertices(&indices, &count, positions);
  EXPECT_EQ(copies.size(), 4u);  // the wall's corners
  EXPECT_EQ(crowded_edges(indices), 0u);
  EXPECT_TRUE(every_edge_in_two_faces(indices));
  EXPECT_EQ(most_fans(indices, count), 1u);
  const std::vector<uint32_t> first(indices.begin(), indices.begin() + 36);  // the first cube's faces
  EXPECT_TRUE(every_edge_in_two_faces(first));
}

TEST(PinchSplit, ADoubleSidedCardBecomesAClosedPillow) {
  // A 3 x 3 grid of vertices drawn both ways round: at its middle vertex the
  // front's faces and the back's meet only across edges of four faces. The
  // front and the back come apart there (one copy) and stay joined along the
  // rim: one closed sheet of no thickness. (Only vertices are split: an edge
  // of four faces between two rim vertices, a quad's diagonal, stays so.)
  std::vector<double> positions;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) positions.insert(positions.end(), {double(i), double(j), 0.0});
  std::vector<uint32_t> indices;
  for (uint32_t j = 0; j < 2; ++j)
    for (uint32_t i = 0; i < 2; ++i) {
      const uint32_t a = 3 * j + i, b = a + 1, c = a + 4, d = a + 3;
      indices.insert(indices.end(), {a, b, c, a, c, d});  // front
      indices.insert(indices.end(), {a, c, b, a, d, c});  // back
    }
  size_t count = 9;
  const auto copies = split_pinched_vertices(&indices, &count, positions);
  ASSERT_EQ(copies.size(), 1u);
  EXPECT_EQ(copies[0].second, 4u);  // the middle vertex
  for (size_t f = 0; f < indices.size() / 3; ++f) {
    const bool front = f % 4 < 2;  // faces in fours per quad: two front, two back
    for (int k = 0; k < 3; ++k) {
      if (front) EXPECT_NE(indices[3 * f + k], 9u) << "front face " << f;
      if (!front) EXPECT_NE(indices[3 * f + k], 4u) << "back face " << f;  // the back has the copy
    }
  }
  for (const auto& [e, uses] : edge_uses(indices))
    if (e.first == 4 || e.second == 4 || e.first == 9 || e.second == 9) EXPECT_EQ(uses, 2) << e.first << "-" << e.second;
  EXPECT_EQ(crowded_edges(indices), 2u);  // the diagonals 1-5 and 3-7, between rim vertices
}

// The welded unit cube with a triangle standing on its top edge y = 0, z = 1
// (three faces on that edge), the fin's face last.
void add_cube_with_fin(std::vector<uint32_t>* indices, std::vector<double>* positions) {
  add_cube(indices, positions, 0, 0);
  weld(indices, *positions);
  const uint32_t tip = uint32_t(positions->size() / 3);
  positions->insert(positions->end(), {0.5, -0.5, 1.5});
  indices->insert(indices->end(), {4, 5, tip});  // corners 4 = (0,0,1), 5 = (1,0,1)
}

TEST(PinchSplit, AFinOnACubeLeavesTheCubeClosed) {
  // The cube's two faces on the fin's edge are one sheet, the fin its own.
  std::vector<uint32_t> indices;
  std::vector<double> positions;
  add_cube_with_fin(&indices, &positions);
  size_t count = positions.size() / 3;
  ASSERT_EQ(crowded_edges(indices), 1u);
  const auto copies = split_pinched_vertices(&indices, &count, positions);
  EXPECT_EQ(copies.size(), 2u);
  EXPECT_EQ(crowded_edges(indices), 0u);
  std::vector<uint32_t> cube(indices.begin(), indices.end() - 3);
  EXPECT_TRUE(every_edge_in_two_faces(cube));  // the cube closed without the fin's face
  const uint32_t* fin = &indices[indices.size() - 3];
  EXPECT_GE(fin[0], 9u);  // the fin's base corners are the copies
  EXPECT_GE(fin[1], 9u);
}

// The open edges (one face, or more than two), against a count of each
// edge's faces, as the mesh came: none on a closed sphere; the fin's foot
// (three faces) and its two free sides (one each) on the cube with a fin;
// the rim of an open fan. The same list on any thread count.
std::vector<std::pair<uint32_t, uint32_t>> open_by_count(const std::vector<uint32_t>& indices) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (size_t f = 0; f < indices.size() / 3; ++f)
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = indices[3 * f + c], b = indices[3 * f + (c + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  std::vector<std::pair<uint32_t, uint32_t>> open;
  for (const auto& [edge, n] : uses)
    if (n != 2) open.push_back(edge);
  return open;
}

TEST(PinchSplit, OpenEdgesAreTheEdgesOfOneFaceOrOfMoreThanTwo) {
  {
    const Mesh sphere = testing::icosphere(2);
    std::vector<uint32_t> indices = sphere.indices;
    size_t count = sphere.vertex_count();
    std::vector<std::pair<uint32_t, uint32_t>> open{{1, 2}};
    split_pinched_vertices(&indices, &count, doubles(sphere.positions), &open);
    EXPECT_TRUE(open.empty());
  }
  std::vector<uint32_t> indices;
  std::vector<double> positions;
  add_cube_with_fin(&indices, &positions);
  // An open fan of four faces round a centre, beside the cube.
  const uint32_t c = uint32_t(positions.size() / 3);
  positions.insert(positions.end(), {5, 0, 0, 6, 0, 0, 5, 1, 0, 4, 0, 0, 5, -1, 0});
  indices.insert(indices.end(), {c, c + 1, c + 2, c, c + 2, c + 3, c, c + 3, c + 4, c, c + 4, c + 1});
  const std::vector<std::pair<uint32_t, uint32_t>> expected = open_by_count(indices);
  ASSERT_EQ(expected.size(), 3u + 4u);  // the fin's foot and sides, the fan's rim
  for (int threads : {1, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<uint32_t> split = indices;
    size_t count = positions.size() / 3;
    std::vector<std::pair<uint32_t, uint32_t>> open;
    split_pinched_vertices(&split, &count, positions, &open);
    EXPECT_EQ(open, expected) << threads << " threads";
  }
}

}  // namespace
}  // namespace vpr
