// Stage 7: meshing. Every topological property is counted here from the
// returned index buffer, independently of CGAL: edge-face incidences, directed
// edges, vertex links, components, Euler characteristic, signed volume.
#include "surface/meshing.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <numeric>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/rng.h"
#include "core/vec3.h"

namespace vpr {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Fibonacci sphere (unit radius) with a tangential jitter of `jitter` times
// the mean spacing, keyed by Philox so the points are the same everywhere.
std::vector<float> fibonacci_sphere(size_t n, double jitter, uint64_t seed) {
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  const double spacing = std::sqrt(4.0 * kPi / double(n));
  std::vector<float> p(3 * n);
  for (size_t i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * double(i) + 1.0) / double(n);
    const double s = std::sqrt(1.0 - z * z);
    const Philox4 r = random4(seed, i, 0);
    Vec3d x{s * std::cos(golden * double(i)), s * std::sin(golden * double(i)), z};
    x = x + Vec3d{uniform01(r.v[0]) - 0.5, uniform01(r.v[1]) - 0.5, uniform01(r.v[2]) - 0.5} * (2 * jitter * spacing);
    x = x * (1.0 / norm(x));
    p[3 * i] = float(x.x);
    p[3 * i + 1] = float(x.y);
    p[3 * i + 2] = float(x.z);
  }
  return p;
}

// Torus (major radius 1, minor 0.35) on a staggered (u, v) grid with jitter.
std::vector<float> torus(size_t nu, size_t nv, uint64_t seed) {
  const double R = 1.0, r = 0.35;
  std::vector<float> p;
  for (size_t j = 0; j < nv; ++j)
    for (size_t i = 0; i < nu; ++i) {
      const Philox4 q = random4(seed, j * nu + i, 0);
      const double u = 2 * kPi * (double(i) + 0.5 * double(j % 2) + 0.2 * (uniform01(q.v[0]) - 0.5)) / double(nu);
      const double v = 2 * kPi * (double(j) + 0.2 * (uniform01(q.v[1]) - 0.5)) / double(nv);
      p.push_back(float((R + r * std::cos(v)) * std::cos(u)));
      p.push_back(float((R + r * std::cos(v)) * std::sin(u)));
      p.push_back(float(r * std::sin(v)));
    }
  return p;
}

struct Topology {
  size_t vertices = 0, edges = 0, faces = 0;
  size_t unreferenced_vertices = 0;
  size_t boundary_edges = 0;           // edges with one face
  size_t non_manifold_edges = 0;       // edges with three or more faces
  size_t repeated_directed_edges = 0;  // an oriented edge used twice: orientation flips
  size_t non_manifold_vertices = 0;    // link falls apart into several fans
  size_t components = 0;
  double signed_volume = 0;
  long euler() const { return long(vertices) - long(edges) + long(faces); }
};

size_t find(std::vector<size_t>& parent, size_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

Topology analyze(const Mesh& m) {
  Topology t;
  t.vertices = m.vertex_count();
  t.faces = m.face_count();
  std::map<std::pair<uint32_t, uint32_t>, int> undirected, directed;
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> link(t.vertices);
  std::vector<size_t> parent(t.vertices);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<bool> referenced(t.vertices, false);
  for (size_t f = 0; f < t.faces; ++f) {
    const uint32_t v[3] = {m.indices[3 * f], m.indices[3 * f + 1], m.indices[3 * f + 2]};
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = v[c], b = v[(c + 1) % 3], o = v[(c + 2) % 3];
      ++directed[{a, b}];
      ++undirected[{std::min(a, b), std::max(a, b)}];
      link[o].push_back({a, b});
      referenced[a] = true;
      parent[find(parent, a)] = find(parent, b);
    }
    const Vec3d a = load3d(m.positions.data(), v[0]), b = load3d(m.positions.data(), v[1]),
                c = load3d(m.positions.data(), v[2]);
    t.signed_volume += dot(a, cross(b, c)) / 6.0;
  }
  t.edges = undirected.size();
  for (const auto& [e, count] : undirected) {
    t.boundary_edges += count == 1;
    t.non_manifold_edges += count > 2;
  }
  for (const auto& [e, count] : directed) t.repeated_directed_edges += count > 1;
  for (size_t v = 0; v < t.vertices; ++v) {
    if (!referenced[v]) {
      ++t.unreferenced_vertices;
      continue;
    }
    t.components += find(parent, v) == v;
    // The faces around a manifold vertex form one fan: their opposite edges
    // chain into a single path or cycle.
    std::map<uint32_t, uint32_t> lp;
    std::function<uint32_t(uint32_t)> root = [&](uint32_t x) {
      if (!lp.count(x)) lp[x] = x;
      return lp[x] == x ? x : lp[x] = root(lp[x]);
    };
    for (const auto& [a, b] : link[v]) lp[root(a)] = root(b);
    size_t fans = 0;
    for (const auto& [x, p] : lp) fans += root(x) == x;
    t.non_manifold_vertices += fans != 1;
  }
  return t;
}

// The unit octahedron: vertices +-x, +-y, +-z; faces counter-clockwise seen
// from outside; volume 4/3.
const std::vector<float> kOctahedron = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
std::vector<uint32_t> octahedron_faces() {
  std::vector<uint32_t> f;
  for (uint32_t x : {0u, 1u})
    for (uint32_t y : {2u, 3u})
      for (uint32_t z : {4u, 5u}) {
        const bool flip = (x + y + z) % 2 == 0;  // an odd number of negative axes flips the winding
        f.insert(f.end(), {x, flip ? z : y, flip ? y : z});
      }
  return f;
}

// Every face's normal points away from the origin (shapes centred there).
size_t inward_faces(const Mesh& m) {
  size_t inward = 0;
  for (size_t f = 0; f < m.face_count(); ++f) {
    const Vec3d a = load3d(m.positions.data(), m.indices[3 * f]), b = load3d(m.positions.data(), m.indices[3 * f + 1]),
                c = load3d(m.positions.data(), m.indices[3 * f + 2]);
    inward += dot(cross(b - a, c - a), a + b + c) <= 0;
  }
  return inward;
}

void expect_sources_match(const Mesh& m, const std::vector<uint32_t>& source, const std::vector<float>& points) {
  ASSERT_EQ(source.size(), m.vertex_count());
  for (size_t v = 0; v < source.size(); ++v)
    for (int c = 0; c < 3; ++c) ASSERT_EQ(m.positions[3 * v + c], points[3 * source[v] + c]) << v;
}

TEST(MeshingTest, SphereBecomesClosedOutwardGenusZeroSurface) {
  const size_t n = 2000;
  const std::vector<float> points = fibonacci_sphere(n, 0.15, 1);
  Mesh mesh;
  std::vector<uint32_t> source;
  MeshingStats stats;
  ASSERT_TRUE(mesh_points(points.data(), n, MeshingOptions{}, &mesh, &source, &stats).ok());

  const Topology t = analyze(mesh);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_EQ(t.non_manifold_edges, 0u);
  EXPECT_EQ(t.non_manifold_vertices, 0u);
  EXPECT_EQ(t.repeated_directed_edges, 0u);
  EXPECT_EQ(t.unreferenced_vertices, 0u);
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.euler(), 2);
  EXPECT_EQ(t.vertices, n);       // every particle is used once
  EXPECT_EQ(t.faces, 2 * n - 4);  // closed genus-0 triangle mesh
  const double sphere = 4.0 / 3.0 * kPi;
  EXPECT_GT(t.signed_volume, 0.0);                   // outward
  EXPECT_NEAR(t.signed_volume / sphere, 1.0, 0.02);  // measured 0.9970: chords cut inside
  EXPECT_EQ(inward_faces(mesh), 0u);

  ASSERT_EQ(source.size(), mesh.vertex_count());
  std::vector<bool> seen(n, false);
  for (size_t v = 0; v < source.size(); ++v) {
    ASSERT_LT(source[v], n);
    EXPECT_FALSE(seen[source[v]]);
    seen[source[v]] = true;
    for (int c = 0; c < 3; ++c) ASSERT_EQ(mesh.positions[3 * v + c], points[3 * source[v] + c]);
  }
  EXPECT_EQ(stats.points_in, n);
  EXPECT_EQ(stats.vertices_out, n);
  EXPECT_EQ(stats.points_dropped, 0u);
  EXPECT_EQ(stats.holes_left, 0u);
}

TEST(MeshingTest, TorusHasEulerCharacteristicZero) {
  const std::vector<float> points = torus(100, 36, 2);
  const size_t n = points.size() / 3;
  Mesh mesh;
  MeshingStats stats;
  ASSERT_TRUE(mesh_points(points.data(), n, MeshingOptions{}, &mesh, nullptr, &stats).ok());
  const Topology t = analyze(mesh);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_EQ(t.non_manifold_edges, 0u);
  EXPECT_EQ(t.non_manifold_vertices, 0u);
  EXPECT_EQ(t.repeated_directed_edges, 0u);
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.euler(), 0);
  EXPECT_EQ(t.vertices, n);
  const double volume = 2 * kPi * kPi * 1.0 * 0.35 * 0.35;
  EXPECT_NEAR(t.signed_volume / volume, 1.0, 0.02);  // measured 0.9943
}

// Repeated points: the Delaunay triangulation keeps one of each; the rest are dropped.
TEST(MeshingTest, RepeatedPointsAreDroppedNotDuplicatedInTheSurface) {
  std::vector<float> points = fibonacci_sphere(2000, 0.15, 1);
  points.insert(points.end(), points.begin(), points.begin() + 3 * 10);
  Mesh mesh;
  std::vector<uint32_t> source;
  MeshingStats stats;
  ASSERT_TRUE(mesh_points(points.data(), 2010, MeshingOptions{}, &mesh, &source, &stats).ok());
  const Topology t = analyze(mesh);
  EXPECT_EQ(t.vertices, 2000u);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_EQ(t.euler(), 2);
  EXPECT_EQ(stats.points_dropped, 10u);
  expect_sources_match(mesh, source, points);
}

TEST(MeshingTest, RejectsDegenerateInput) {
  Mesh mesh;
  const std::vector<float> three = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  EXPECT_EQ(mesh_points(three.data(), 3, {}, &mesh, nullptr, nullptr).code(), StatusCode::kInvalidArgument);
  std::vector<float> grid;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) grid.insert(grid.end(), {float(i), float(j), 0.5f * float(i) + float(j)});
  EXPECT_EQ(mesh_points(grid.data(), 100, {}, &mesh, nullptr, nullptr).code(), StatusCode::kInvalidArgument);
  std::vector<float> line;
  for (int i = 0; i < 10; ++i) line.insert(line.end(), {float(i), 2.0f * float(i), 0});
  EXPECT_EQ(mesh_points(line.data(), 10, {}, &mesh, nullptr, nullptr).code(), StatusCode::kInvalidArgument);
  std::vector<float> sphere = fibonacci_sphere(100, 0.1, 3);
  sphere[5] = std::nanf("");
  EXPECT_EQ(mesh_points(sphere.data(), 100, {}, &mesh, nullptr, nullptr).code(), StatusCode::kInvalidArgument);
}

TEST(RepairSoupTest, OrientsFlippedFacesOutward) {
  std::vector<uint32_t> faces = octahedron_faces();
  for (size_t f : {1, 3, 6}) std::swap(faces[3 * f + 1], faces[3 * f + 2]);
  std::vector<uint32_t> inside_out = octahedron_faces();
  for (size_t f = 0; f < 8; ++f) std::swap(inside_out[3 * f + 1], inside_out[3 * f + 2]);
  for (const auto& soup : {faces, inside_out}) {
    Mesh mesh;
    std::vector<uint32_t> source;
    MeshingStats stats;
    ASSERT_TRUE(repair_triangle_soup(kOctahedron.data(), 6, soup.data(), 8, {}, &mesh, &source, &stats).ok());
    const Topology t = analyze(mesh);
    EXPECT_EQ(t.vertices, 6u);
    EXPECT_EQ(t.faces, 8u);
    EXPECT_EQ(t.boundary_edges, 0u);
    EXPECT_EQ(t.repeated_directed_edges, 0u);
    EXPECT_NEAR(t.signed_volume, 4.0 / 3.0, 1e-6);
    EXPECT_EQ(inward_faces(mesh), 0u);
    EXPECT_EQ(stats.vertices_split, 0u);
    expect_sources_match(mesh, source, kOctahedron);
  }
}

TEST(RepairSoupTest, FillsSmallHolesOnlyAndDropsUnusedPoints) {
  std::vector<float> points = kOctahedron;
  points.insert(points.end(), {5, 5, 5});  // point 6: used by no triangle
  const std::vector<uint32_t> faces = octahedron_faces();
  Mesh mesh;
  MeshingStats stats;
  ASSERT_TRUE(repair_triangle_soup(points.data(), 7, faces.data(), 7, {}, &mesh, nullptr, &stats).ok());
  Topology t = analyze(mesh);
  EXPECT_EQ(stats.holes_filled, 1u);
  EXPECT_EQ(stats.holes_left, 0u);
  EXPECT_EQ(stats.points_dropped, 1u);
  EXPECT_EQ(t.vertices, 6u);
  EXPECT_EQ(t.faces, 8u);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_NEAR(t.signed_volume, 4.0 / 3.0, 1e-6);

  // Open and inside out: each open component is turned to face outward.
  std::vector<uint32_t> inside_out = faces;
  for (size_t f = 0; f < 8; ++f) std::swap(inside_out[3 * f + 1], inside_out[3 * f + 2]);
  MeshingOptions no_fill;
  no_fill.max_hole_edges = 2;  // the missing face leaves a 3-edge hole
  ASSERT_TRUE(repair_triangle_soup(points.data(), 7, inside_out.data(), 7, no_fill, &mesh, nullptr, &stats).ok());
  t = analyze(mesh);
  EXPECT_EQ(stats.holes_filled, 0u);
  EXPECT_EQ(stats.holes_left, 1u);
  EXPECT_EQ(t.faces, 7u);
  EXPECT_EQ(t.boundary_edges, 3u);
  EXPECT_EQ(t.repeated_directed_edges, 0u);
  EXPECT_EQ(inward_faces(mesh), 0u);
}

// A closed UV sphere (radius 1) as a soup: `rings` latitude rings of
// `segments` points between two poles, faces counter-clockwise from outside.
void append_uv_sphere(double cx, size_t segments, size_t rings, std::vector<float>* points,
                      std::vector<uint32_t>* faces) {
  const uint32_t base = uint32_t(points->size() / 3);
  auto add = [&](double x, double y, double z) { points->insert(points->end(), {float(cx + x), float(y), float(z)}); };
  add(0, 0, 1);  // north pole: base
  for (size_t r = 0; r < rings; ++r) {
    const double theta = kPi * double(r + 1) / double(rings + 1);
    for (size_t s = 0; s < segments; ++s) {
      const double phi = 2 * kPi * double(s) / double(segments);
      add(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    }
  }
  add(0, 0, -1);  // south pole
  const uint32_t south = base + 1 + uint32_t(rings * segments);
  auto ring = [&](size_t r, size_t s) { return base + 1 + uint32_t(r * segments + s % segments); };
  for (size_t s = 0; s < segments; ++s) faces->insert(faces->end(), {base, ring(0, s), ring(0, s + 1)});
  for (size_t r = 0; r + 1 < rings; ++r)
    for (size_t s = 0; s < segments; ++s) {
      faces->insert(faces->end(), {ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)});
      faces->insert(faces->end(), {ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)});
    }
  for (size_t s = 0; s < segments; ++s) faces->insert(faces->end(), {south, ring(rings - 1, s + 1), ring(rings - 1, s)});
}

// A soup that is already one outward fan per vertex skips the orientation
// passes (repair_soup's fast path): its faces come back as they were. Two
// nested shells still go through them: the inner one turns inward.
TEST(RepairSoupTest, OrientedSoupKeepsItsFacesAndNestedShellsStillTurn) {
  std::vector<float> points;
  std::vector<uint32_t> faces;
  append_uv_sphere(0, 16, 10, &points, &faces);
  auto canonical = [](const uint32_t* t) {  // the rotation that starts at the smallest index
    const int k = t[0] < t[1] ? (t[0] < t[2] ? 0 : 2) : (t[1] < t[2] ? 1 : 2);
    return std::array<uint32_t, 3>{t[k], t[(k + 1) % 3], t[(k + 2) % 3]};
  };
  Mesh mesh;
  std::vector<uint32_t> source;
  ASSERT_TRUE(repair_triangle_soup(points.data(), points.size() / 3, faces.data(), faces.size() / 3, {}, &mesh,
                                   &source, nullptr)
                  .ok());
  std::set<std::array<uint32_t, 3>> in, out;
  for (size_t f = 0; f < faces.size() / 3; ++f) in.insert(canonical(&faces[3 * f]));
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    const uint32_t t[3] = {source[mesh.indices[3 * f]], source[mesh.indices[3 * f + 1]], source[mesh.indices[3 * f + 2]]};
    out.insert(canonical(t));
  }
  EXPECT_EQ(in, out);
  const double outer = analyze(mesh).signed_volume;
  EXPECT_GT(outer, 3.0);  // a UV sphere of radius 1: a little under 4.19

  const size_t first_inner = points.size();
  append_uv_sphere(0, 16, 10, &points, &faces);
  for (size_t i = first_inner; i < points.size(); ++i) points[i] *= 0.5f;  // radius 0.5, inside, also outward
  ASSERT_TRUE(repair_triangle_soup(points.data(), points.size() / 3, faces.data(), faces.size() / 3, {}, &mesh,
                                   nullptr, nullptr)
                  .ok());
  EXPECT_NEAR(analyze(mesh).signed_volume, outer * (1 - 0.125), 1e-3 * outer);  // the inner shell faces inward
}

// A shell whose faces all wind inward (a dual made from an input that winds
// inward) is turned whole, without the self-intersection test and ray casts:
// each face comes back reversed, none other changes, and the volume is the
// outward shell's. A UV sphere squashed flat across one axis (a closed
// surface that crosses no face) and a round one.
TEST(RepairSoupTest, AnInsideOutShellComesBackWithEveryFaceReversed) {
  for (const float squash : {1.0f, 0.05f}) {
    std::vector<float> points;
    std::vector<uint32_t> faces;
    append_uv_sphere(0, 24, 14, &points, &faces);
    for (size_t i = 2; i < points.size(); i += 3) points[i] *= squash;
    std::vector<uint32_t> inside_out = faces;
    for (size_t f = 0; f < faces.size() / 3; ++f) std::swap(inside_out[3 * f + 1], inside_out[3 * f + 2]);
    auto canonical = [](const uint32_t* t) {
      const int k = t[0] < t[1] ? (t[0] < t[2] ? 0 : 2) : (t[1] < t[2] ? 1 : 2);
      return std::array<uint32_t, 3>{t[k], t[(k + 1) % 3], t[(k + 2) % 3]};
    };
    Mesh outward, turned;
    std::vector<uint32_t> source_outward, source_turned;
    ASSERT_TRUE(repair_triangle_soup(points.data(), points.size() / 3, faces.data(), faces.size() / 3, {}, &outward,
                                     &source_outward, nullptr)
                    .ok());
    ASSERT_TRUE(repair_triangle_soup(points.data(), points.size() / 3, inside_out.data(), inside_out.size() / 3, {},
                                     &turned, &source_turned, nullptr)
                    .ok());
    std::set<std::array<uint32_t, 3>> in, out;
    for (size_t f = 0; f < faces.size() / 3; ++f) in.insert(canonical(&faces[3 * f]));
    for (size_t f = 0; f < turned.face_count(); ++f) {
      const uint32_t t[3] = {source_turned[turned.indices[3 * f]], source_turned[turned.indices[3 * f + 1]],
                             source_turned[turned.indices[3 * f + 2]]};
      out.insert(canonical(t));
    }
    EXPECT_EQ(in, out) << "squash " << squash;
    EXPECT_EQ(turned.positions, outward.positions) << "squash " << squash;
    EXPECT_EQ(turned.indices, outward.indices) << "squash " << squash;
    EXPECT_GT(analyze(turned).signed_volume, 3.0 * squash) << "squash " << squash;
    EXPECT_EQ(inward_faces(turned), 0u) << "squash " << squash;
  }
}

// A soup that needs no repair is flattened without CGAL
// (MeshingOptions::clean_soup_shortcut): the same vertices in the same
// order, faces, sources and stats as CGAL's way gives, on soups the shortcut
// takes (closed, inward, open with its hole left, points unused in between
// and at the end) and on ones it leaves to CGAL (a hole to fill, two parts).
TEST(RepairSoupTest, ACleanSoupGivesWhatCgalsWayGives) {
  struct Case {
    const char* name;
    std::vector<float> points;
    std::vector<uint32_t> faces;
    MeshingOptions options;
  };
  std::vector<Case> cases;
  {
    // A sphere over points renumbered at random, with unused points between
    // and after them (collect_garbage fills gaps from the end).
    std::vector<float> p;
    std::vector<uint32_t> f;
    append_uv_sphere(0, 20, 12, &p, &f);
    const size_t n = p.size() / 3, spare = n / 5 + 12;
    std::vector<uint32_t> to(n);  // a random renumbering
    std::iota(to.begin(), to.end(), 0);
    for (size_t i = n - 1; i > 0; --i) std::swap(to[i], to[random4(5, i, 0).v[0] % (i + 1)]);
    // Every fifth number moved up past the unused ones: gaps inside and after.
    std::vector<uint32_t> slot(n);
    for (size_t v = 0; v < n; ++v) slot[v] = to[v] % 5 == 0 ? uint32_t(n + spare - 1 - to[v] / 5) : to[v];
    std::vector<float> r(3 * (n + spare), 0.5f);
    for (size_t v = 0; v < n; ++v)
      for (int k = 0; k < 3; ++k) r[3 * slot[v] + k] = p[3 * v + k];
    std::vector<uint32_t> g(f.size());
    for (size_t i = 0; i < f.size(); ++i) g[i] = slot[f[i]];
    cases.push_back({"closed, renumbered, unused points", r, g, {}});
    std::vector<uint32_t> inward = g;
    for (size_t t = 0; t < inward.size() / 3; ++t) std::swap(inward[3 * t + 1], inward[3 * t + 2]);
    cases.push_back({"inward", r, inward, {}});
    // Open: the faces round the north pole left out (a hole of 20 edges).
    std::vector<uint32_t> open(g.begin() + 3 * 20, g.end());
    MeshingOptions keep_holes;
    keep_holes.max_hole_edges = 0;
    cases.push_back({"open, hole kept", r, open, keep_holes});
    cases.push_back({"open, hole filled", r, open, {}});
  }
  {
    std::vector<float> p;
    std::vector<uint32_t> f;
    append_uv_sphere(0, 16, 10, &p, &f);
    append_uv_sphere(3, 16, 10, &p, &f);
    cases.push_back({"two parts", p, f, {}});
  }
  for (const Case& c : cases) {
    const size_t n = c.points.size() / 3;
    Mesh cgal, shortcut;
    std::vector<uint32_t> cgal_source, shortcut_source;
    MeshingStats cgal_stats, shortcut_stats;
    MeshingOptions by_cgal = c.options;
    by_cgal.clean_soup_shortcut = false;
    ASSERT_TRUE(repair_triangle_soup(c.points.data(), n, c.faces.data(), c.faces.size() / 3, by_cgal, &cgal,
                                     &cgal_source, &cgal_stats)
                    .ok())
        << c.name;
    ASSERT_TRUE(repair_triangle_soup(c.points.data(), n, c.faces.data(), c.faces.size() / 3, c.options, &shortcut,
                                     &shortcut_source, &shortcut_stats)
                    .ok())
        << c.name;
    EXPECT_EQ(shortcut.positions, cgal.positions) << c.name;
    EXPECT_EQ(shortcut.indices, cgal.indices) << c.name;
    EXPECT_EQ(shortcut_source, cgal_source) << c.name;
    EXPECT_EQ(shortcut_stats.vertices_out, cgal_stats.vertices_out) << c.name;
    EXPECT_EQ(shortcut_stats.points_dropped, cgal_stats.points_dropped) << c.name;
    EXPECT_EQ(shortcut_stats.holes_left, cgal_stats.holes_left) << c.name;
    EXPECT_EQ(shortcut_stats.holes_filled, cgal_stats.holes_filled) << c.name;
    if (std::string(c.name) != "two parts")
      EXPECT_EQ(inward_faces(shortcut), 0u) << c.name;  // outward about the centre (one part)
  }
}

// Regression (heap overflow seen on real models): removing the long "bridge"
// faces leaves removed halfedges inside the mesh, so the halfedge indices of
// the parts after them run past number_of_halfedges(). The hole of the last
// part must still be found and filled, and nothing may be written out of
// bounds (the sanitizer build runs this test).
TEST(RepairSoupTest, FillsHolesAfterBridgesAreRemoved) {
  std::vector<float> points;
  std::vector<uint32_t> faces;
  append_uv_sphere(0, 12, 8, &points, &faces);
  // Twenty isolated triangles with edges 100x the spheres': each is removed
  // as a bridge, and with it its three edges.
  for (int b = 0; b < 20; ++b) {
    const uint32_t v = uint32_t(points.size() / 3);
    const float x = 200.0f + 150.0f * float(b);
    points.insert(points.end(), {x, 0, 0, x + 100, 0, 0, x, 100, 0});
    faces.insert(faces.end(), {v, v + 1, v + 2});
  }
  std::vector<uint32_t> last;
  append_uv_sphere(5, 12, 8, &points, &last);
  last.erase(last.begin() + 3 * 40, last.begin() + 3 * 41);  // a 3-edge hole in the last part
  faces.insert(faces.end(), last.begin(), last.end());

  Mesh mesh;
  MeshingStats stats;
  ASSERT_TRUE(repair_triangle_soup(points.data(), points.size() / 3, faces.data(), faces.size() / 3, {}, &mesh,
                                   nullptr, &stats)
                  .ok());
  const Topology t = analyze(mesh);
  EXPECT_EQ(stats.bridges_removed, 20u);
  EXPECT_EQ(stats.holes_filled, 1u);
  EXPECT_EQ(stats.holes_left, 0u);
  EXPECT_EQ(stats.points_dropped, 60u);
  EXPECT_EQ(t.components, 2u);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_EQ(t.non_manifold_edges, 0u);
  EXPECT_EQ(t.euler(), 4);  // two spheres
  EXPECT_EQ(t.faces, 2 * (2 * 12 * 8u));
}

TEST(RepairSoupTest, SplitsNonManifoldVertexAndEdge) {
  // Bowtie: two triangles meeting only at point 0.
  const std::vector<float> points = {0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0.5f, -1, 1, 0.5f};
  const std::vector<uint32_t> bowtie = {0, 1, 2, 0, 3, 4};
  MeshingOptions no_fill;
  no_fill.max_hole_edges = 0;
  Mesh mesh;
  std::vector<uint32_t> source;
  MeshingStats stats;
  ASSERT_TRUE(repair_triangle_soup(points.data(), 5, bowtie.data(), 2, no_fill, &mesh, &source, &stats).ok());
  Topology t = analyze(mesh);
  EXPECT_EQ(t.vertices, 6u);
  EXPECT_EQ(stats.vertices_split, 1u);
  EXPECT_EQ(t.non_manifold_vertices, 0u);
  EXPECT_EQ(t.components, 2u);
  EXPECT_EQ(std::count(source.begin(), source.end(), 0u), 2);  // both copies are point 0
  expect_sources_match(mesh, source, points);

  // Fin: three triangles on the edge (0, 1).
  const std::vector<float> fin_points = {0, 0, 0, 0, 0, 1, 1, 0, 0.5f, -1, 0, 0.5f, 0, 1, 0.5f};
  const std::vector<uint32_t> fin = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  ASSERT_TRUE(repair_triangle_soup(fin_points.data(), 5, fin.data(), 3, no_fill, &mesh, &source, &stats).ok());
  t = analyze(mesh);
  EXPECT_EQ(t.faces, 3u);
  EXPECT_EQ(t.non_manifold_edges, 0u);
  EXPECT_EQ(t.non_manifold_vertices, 0u);
  EXPECT_EQ(t.repeated_directed_edges, 0u);
  EXPECT_EQ(t.vertices, 5u + stats.vertices_split);
  EXPECT_GE(stats.vertices_split, 2u);  // one copy of the edge (0, 1) at least
  expect_sources_match(mesh, source, fin_points);
}

TEST(RepairSoupTest, RejectsBadTriangles) {
  Mesh mesh;
  const std::vector<uint32_t> out_of_range = {0, 1, 6};
  EXPECT_EQ(repair_triangle_soup(kOctahedron.data(), 6, out_of_range.data(), 1, {}, &mesh, nullptr, nullptr).code(),
            StatusCode::kInvalidArgument);
  const std::vector<uint32_t> repeated = {0, 1, 1};
  EXPECT_EQ(repair_triangle_soup(kOctahedron.data(), 6, repeated.data(), 1, {}, &mesh, nullptr, nullptr).code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(repair_triangle_soup(kOctahedron.data(), 6, nullptr, 0, {}, &mesh, nullptr, nullptr).code(),
            StatusCode::kInvalidArgument);
}

// Points on a bumpy sphere (or its upper half), jittered Fibonacci spiral:
// evenly spread like AWLOP's output. Returns the spacing.
double bumpy_sphere_points(int n, bool upper_half_only, std::vector<float>* out) {
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double y = 1 - 2.0 * (i + 0.5) / n, r = std::sqrt(1 - y * y);
    const double t = golden * i + 0.1 * std::sin(7.0 * i) / std::sqrt(double(n));
    if (upper_half_only && y < 0) continue;
    const double s = 1 + 0.15 * std::sin(5 * y) * std::cos(3 * t);
    for (double c : {std::cos(t) * r * s, y * s, std::sin(t) * r * s}) out->push_back(float(c));
  }
  return std::sqrt(4 * M_PI / n);
}

size_t boundary_edges(const Mesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = m.indices[3 * f + c], b = m.indices[3 * f + (c + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  return size_t(std::count_if(uses.begin(), uses.end(), [](const auto& e) { return e.second != 2; }));
}

TEST(MeshingTest, ParallelSlabsCloseTheirSeamsOnAClosedSurface) {
  std::vector<float> points;
  MeshingOptions slabs;
  slabs.spacing = bumpy_sphere_points(12000, false, &points);
  slabs.points_per_slab = 3000;
  const size_t n = points.size() / 3;
  Mesh whole, parallel, again;
  MeshingStats whole_stats, parallel_stats;
  ASSERT_TRUE(mesh_points(points.data(), n, MeshingOptions{}, &whole, nullptr, &whole_stats).ok());
  ASSERT_TRUE(mesh_points(points.data(), n, slabs, &parallel, nullptr, &parallel_stats).ok());
  ASSERT_TRUE(mesh_points(points.data(), n, slabs, &again, nullptr, nullptr).ok());
  EXPECT_EQ(whole_stats.slabs, 1u);
  EXPECT_EQ(parallel_stats.slabs, 4u) << parallel_stats.seam_defects << " seam defects";
  EXPECT_EQ(parallel_stats.seam_defects, 0u);
  EXPECT_EQ(boundary_edges(parallel), 0u) << "the slabs' seams must close";
  EXPECT_EQ(parallel.vertex_count(), whole.vertex_count());
  // A closed genus-0 triangulation of V vertices has 2V - 4 faces.
  EXPECT_EQ(parallel.face_count(), 2 * parallel.vertex_count() - 4);
  EXPECT_EQ(again.indices, parallel.indices) << "slabs must be reproducible";
}

// An open surface crosses the cuts with its boundary: the seam check fails and
// the points are reconstructed whole, giving exactly the serial result.
TEST(MeshingTest, OpenSurfaceFallsBackToTheWholeReconstruction) {
  std::vector<float> points;
  MeshingOptions slabs;
  slabs.spacing = bumpy_sphere_points(16000, true, &points);
  slabs.points_per_slab = 2000;
  const size_t n = points.size() / 3;
  Mesh whole, attempted;
  MeshingStats stats;
  ASSERT_TRUE(mesh_points(points.data(), n, MeshingOptions{}, &whole, nullptr, nullptr).ok());
  ASSERT_TRUE(mesh_points(points.data(), n, slabs, &attempted, nullptr, &stats).ok());
  EXPECT_EQ(stats.slabs, 1u);
  EXPECT_GT(stats.seam_defects, 0u);
  EXPECT_EQ(attempted.indices, whole.indices);
}

}  // namespace
}  // namespace vpr
