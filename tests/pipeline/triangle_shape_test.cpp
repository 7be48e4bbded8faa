// triangle_shape: known shapes (sphere, torus, disk, annulus, pieces, a
// bow-tie vertex, an edge of three faces, a face twice), and on thousands of
// broken face sets the answer of the plain count it replaced: every directed
// edge sorted, each vertex's links sorted.
#include "pipeline/triangle_shape.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

#include "test_meshes.h"

namespace vpr {
namespace {

using Faces = std::vector<std::array<uint32_t, 3>>;

Faces faces_of(const Mesh& m, uint32_t offset = 0) {
  Faces f(m.face_count());
  for (size_t i = 0; i < f.size(); ++i)
    f[i] = {m.indices[3 * i] + offset, m.indices[3 * i + 1] + offset, m.indices[3 * i + 2] + offset};
  return f;
}

// The plain count: directed edges sorted, links sorted by vertex.
TriangleShape reference(const Faces& faces) {
  TriangleShape s;
  if (faces.empty()) return s;
  std::vector<uint32_t> verts;
  for (const auto& f : faces) verts.insert(verts.end(), f.begin(), f.end());
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  auto local = [&](uint32_t v) { return uint32_t(std::lower_bound(verts.begin(), verts.end(), v) - verts.begin()); };
  std::vector<uint64_t> directed;
  for (const auto& f : faces)
    for (int k = 0; k < 3; ++k) directed.push_back(uint64_t(local(f[k])) << 32 | local(f[(k + 1) % 3]));
  std::sort(directed.begin(), directed.end());
  bool manifold = std::adjacent_find(directed.begin(), directed.end()) == directed.end();
  std::vector<uint64_t> border;
  for (uint64_t e : directed)
    if (!std::binary_search(directed.begin(), directed.end(), (e << 32) | (e >> 32))) border.push_back(e);
  std::vector<std::array<uint32_t, 3>> link;
  for (const auto& f : faces)
    for (int k = 0; k < 3; ++k) link.push_back({local(f[k]), local(f[(k + 1) % 3]), local(f[(k + 2) % 3])});
  std::sort(link.begin(), link.end());
  std::vector<uint32_t> parent(verts.size()), roots;
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x];
    return x;
  };
  for (size_t i = 0; i < link.size() && manifold;) {
    size_t j = i;
    while (j < link.size() && link[j][0] == link[i][0]) ++j;
    for (size_t k = i; k < j; ++k) parent[link[k][1]] = link[k][1], parent[link[k][2]] = link[k][2];
    for (size_t k = i; k < j; ++k)
      if (find(link[k][1]) != find(link[k][2])) parent[find(link[k][1])] = find(link[k][2]);
    roots.clear();
    for (size_t k = i; k < j; ++k) roots.push_back(find(link[k][1]));
    std::sort(roots.begin(), roots.end());
    manifold = std::unique(roots.begin(), roots.end()) - roots.begin() == 1;
    i = j;
  }
  std::iota(parent.begin(), parent.end(), 0u);
  for (const auto& f : faces)
    for (int k = 1; k < 3; ++k)
      if (find(local(f[0])) != find(local(f[k]))) parent[find(local(f[0]))] = find(local(f[k]));
  size_t pieces = 0;
  for (uint32_t v = 0; v < verts.size(); ++v) pieces += find(v) == v;
  std::iota(parent.begin(), parent.end(), 0u);
  std::vector<char> on_border(verts.size(), 0);
  for (uint64_t e : border) {
    const uint32_t a = uint32_t(e >> 32), b = uint32_t(e);
    on_border[a] = on_border[b] = 1;
    if (find(a) != find(b)) parent[find(a)] = find(b);
  }
  for (uint32_t v = 0; v < verts.size(); ++v) s.loops += on_border[v] && find(v) == v;
  s.manifold = manifold;
  s.closed_manifold = manifold && border.empty();
  s.one_piece = pieces == 1;
  s.euler = int64_t(verts.size()) - int64_t((directed.size() + border.size()) / 2) + int64_t(faces.size());
  return s;
}

void expect_same(const TriangleShape& a, const TriangleShape& b, const std::string& what) {
  EXPECT_EQ(a.manifold, b.manifold) << what;
  EXPECT_EQ(a.closed_manifold, b.closed_manifold) << what;
  EXPECT_EQ(a.one_piece, b.one_piece) << what;
  EXPECT_EQ(a.euler, b.euler) << what;
  EXPECT_EQ(a.loops, b.loops) << what;
}

TriangleShape shape(const Faces& faces) {
  std::vector<uint32_t> rank;
  const TriangleShape s = triangle_shape(faces, &rank);
  EXPECT_TRUE(std::all_of(rank.begin(), rank.end(), [](uint32_t r) { return r == UINT32_MAX; }));
  return s;
}

// A grid of n x n quads (two triangles each) over (n + 1)^2 vertices.
Faces grid(uint32_t n) {
  Faces f;
  auto at = [n](uint32_t i, uint32_t j) { return i * (n + 1) + j; };
  for (uint32_t i = 0; i < n; ++i)
    for (uint32_t j = 0; j < n; ++j) {
      f.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      f.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  return f;
}

TEST(TriangleShape, KnownShapes) {
  const TriangleShape sphere = shape(faces_of(testing::icosphere(3)));
  EXPECT_TRUE(sphere.manifold && sphere.closed_manifold && sphere.one_piece);
  EXPECT_EQ(sphere.euler, 2);
  EXPECT_EQ(sphere.loops, 0u);

  const TriangleShape ring = shape(faces_of(testing::torus(1.0, 0.3, 24, 12)));
  EXPECT_TRUE(ring.closed_manifold && ring.one_piece);
  EXPECT_EQ(ring.euler, 0);

  const TriangleShape disk = shape(grid(6));
  EXPECT_TRUE(disk.manifold && !disk.closed_manifold && disk.one_piece);
  EXPECT_EQ(disk.euler, 1);
  EXPECT_EQ(disk.loops, 1u);

  // An annulus: the grid less its middle quad's two faces.
  Faces annulus = grid(3);
  annulus.erase(annulus.begin() + 8, annulus.begin() + 10);
  const TriangleShape a = shape(annulus);
  EXPECT_TRUE(a.manifold && a.one_piece);
  EXPECT_EQ(a.euler, 0);
  EXPECT_EQ(a.loops, 2u);

  // Two spheres, far apart in numbering (the rank table grows).
  Faces two = faces_of(testing::icosphere(1));
  const Faces other = faces_of(testing::icosphere(1), 1000000);
  two.insert(two.end(), other.begin(), other.end());
  const TriangleShape pair = shape(two);
  EXPECT_TRUE(pair.closed_manifold && !pair.one_piece);
  EXPECT_EQ(pair.euler, 4);

  // Two disks joined at one vertex: one piece, not a manifold (two fans).
  const Faces bow = {{0, 1, 2}, {0, 3, 4}};
  EXPECT_FALSE(shape(bow).manifold);
  EXPECT_TRUE(shape(bow).one_piece);
  // An edge of three faces, and a face twice.
  EXPECT_FALSE(shape({{0, 1, 2}, {1, 0, 3}, {0, 1, 4}}).manifold);
  EXPECT_FALSE(shape({{0, 1, 2}, {0, 1, 2}}).manifold);
  EXPECT_FALSE(shape({}).manifold);
}

// Thousands of broken face sets: pieces of a torus and a grid with faces
// dropped, turned over, repeated, welded and made degenerate.
TEST(TriangleShape, MatchesThePlainCountOnBrokenFaceSets) {
  std::mt19937 rng(7);
  const Faces torus = faces_of(testing::torus(1.0, 0.3, 12, 8));
  const Faces plate = grid(8);
  std::vector<uint32_t> rank;  // shared by the calls, as the part fallback shares it
  for (int trial = 0; trial < 3000; ++trial) {
    Faces f = trial % 2 ? torus : plate;
    const uint32_t nv = trial % 2 ? 12 * 8 : 81;
    std::shuffle(f.begin(), f.end(), rng);
    f.resize(std::uniform_int_distribution<size_t>(1, f.size())(rng));
    const int edits = std::uniform_int_distribution<int>(0, 6)(rng);
    for (int e = 0; e < edits; ++e) {
      auto& t = f[std::uniform_int_distribution<size_t>(0, f.size() - 1)(rng)];
      switch (std::uniform_int_distribution<int>(0, 3)(rng)) {
        case 0:
          std::swap(t[0], t[1]);
          break;  // turned over
        case 1:
          f.push_back(t);
          break;  // repeated
        case 2:
          t[2] = std::uniform_int_distribution<uint32_t>(0, nv - 1)(rng);
          break;  // welded elsewhere
        default:
          t[1] = t[0];
          break;  // degenerate
      }
    }
    const TriangleShape got = triangle_shape(f, &rank);
    expect_same(got, reference(f), "trial " + std::to_string(trial));
    if (::testing::Test::HasFailure()) break;
  }
  EXPECT_TRUE(std::all_of(rank.begin(), rank.end(), [](uint32_t r) { return r == UINT32_MAX; }));
}

}  // namespace
}  // namespace vpr
