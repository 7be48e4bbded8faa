// The surface back half: refinement, the CVT on the input surface, its dual.
// Shapes are generated here; every property is counted from the returned
// index buffer: boundary loops, non-manifold edges, closedness, distances.
#include "surface/surface_cvt.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "core/vec3.h"
#include "surface/cluster_mesh.h"
#include "surface/edge_smoothing.h"
#include "surface/surface_density.h"
#include "surface/surface_refine.h"
#include "test_meshes.h"

namespace vpr {
namespace {

using testing::torus;

constexpr double kPi = 3.14159265358979323846;

// A box centred at the origin, each face an n x n grid (two triangles per
// cell, counter-clockwise from outside); faces share their border vertices
// by exact position (refine_surface welds them). skip(face, i, j): leave a cell out.
template <class Skip>
Mesh box(double sx, double sy, double sz, int n, Skip skip) {
  Mesh m;
  const double half[3] = {sx / 2, sy / 2, sz / 2};
  for (int axis = 0; axis < 3; ++axis)
    for (int side = -1; side <= 1; side += 2) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const uint32_t base = uint32_t(m.vertex_count());
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
          double p[3];
          p[axis] = side * half[axis];
          p[u] = -half[u] + 2 * half[u] * i / n;
          p[v] = -half[v] + 2 * half[v] * j / n;
          m.positions.insert(m.positions.end(), {float(p[0]), float(p[1]), float(p[2])});
        }
      const int face = axis * 2 + (side > 0);
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          if (skip(face, i, j)) continue;
          const uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + (n + 1), d = c + 1;
          // (u, v, axis) is right-handed: counter-clockwise seen from +axis.
          if (side > 0) m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
          else m.indices.insert(m.indices.end(), {a, d, b, a, c, d});
        }
    }
  return m;
}

Mesh box(double sx, double sy, double sz, int n) {
  return box(sx, sy, sz, n, [](int, int, int) { return false; });
}

// An open tube: radius r, height h, seg x rings grid, no caps.
Mesh tube(double r, double h, int seg, int rings) {
  Mesh m;
  for (int j = 0; j <= rings; ++j)
    for (int i = 0; i < seg; ++i) {
      const double a = 2 * kPi * i / seg;
      m.positions.insert(m.positions.end(), {float(r * std::cos(a)), float(r * std::sin(a)), float(-h / 2 + h * j / rings)});
    }
  for (int j = 0; j < rings; ++j)
    for (int i = 0; i < seg; ++i) {
      const uint32_t a = j * seg + i, b = j * seg + (i + 1) % seg, c = a + seg, d = b + seg;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
    }
  return m;
}

struct Counts {
  size_t boundary_edges = 0, non_manifold_edges = 0, loops = 0;
};


Counts count(const Mesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = m.indices[3 * f + c], b = m.indices[3 * f + (c + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  Counts k;
  std::map<uint32_t, std::vector<uint32_t>> link;
  for (const auto& [e, n] : uses) {
    k.boundary_edges += n == 1;
    k.non_manifold_edges += n > 2;
    if (n == 1) {
      link[e.first].push_back(e.second);
      link[e.second].push_back(e.first);
    }
  }
  std::set<uint32_t> seen;  // boundary loops: components of the boundary edges
  for (const auto& [v, _] : link) {
    if (seen.count(v)) continue;
    ++k.loops;
    std::vector<uint32_t> stack = {v};
    seen.insert(v);
    while (!stack.empty()) {
      const uint32_t x = stack.back();
      stack.pop_back();
      for (uint32_t y : link[x])
        if (seen.insert(y).second) stack.push_back(y);
    }
  }
  return k;
}

double volume(const Mesh& m) {
  double v = 0;
  for (size_t f = 0; f < m.face_count(); ++f) {
    const Vec3d a = load3d(m.positions.data(), m.indices[3 * f]), b = load3d(m.positions.data(), m.indices[3 * f + 1]),
                c = load3d(m.positions.data(), m.indices[3 * f + 2]);
    v += dot(a, cross(b, c)) / 6;
  }
  return v;
}

double diagonal(const Mesh& m) {
  Vec3d lo = load3d(m.positions.data(), 0), hi = lo;
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    const Vec3d p = load3d(m.positions.data(), v);
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return norm(hi - lo);
}

// The pipeline's default anisotropy (PipelineOptions::anisotropy), a share of
// the diagonal: the shapes below are remeshed as a job would remesh them.
constexpr double kDefaultAnisotropy = 0.04;

// The whole back half on `input` (uniform or curvature density), with the
// CVT's anisotropy a share `anisotropy` of the input's diagonal.
Mesh remesh(const Mesh& input, uint32_t target, DensityMode mode, CvtStats* cvt = nullptr,
            const ClusterMeshOptions& options = {}, ClusterMeshStats* mesh_stats = nullptr,
            double anisotropy = kDefaultAnisotropy) {
  const std::vector<float> ones(input.vertex_count(), 1.0f);
  const std::vector<float> d = vertex_density(input, ones, mode);
  double area = 0;
  for (double a : face_areas(input)) area += a;
  const double spacing = std::sqrt(2 * area / (std::sqrt(3.0) * target));
  auto refined = refine_surface(input, d, 1, spacing / 4, 10'000'000);
  EXPECT_TRUE(refined.ok()) << refined.status().to_string();
  std::vector<double> mass = vertex_areas(refined->mesh);
  for (size_t v = 0; v < mass.size(); ++v) mass[v] *= double(refined->value[v]) * refined->value[v];
  std::vector<uint32_t> label;
  CvtStats stats;
  CvtOptions cvt_options;
  cvt_options.anisotropy = anisotropy * diagonal(input);
  cvt_options.joined_elements = refined->pinch_copies;  // as the pipeline does
  EXPECT_TRUE(surface_cvt(refined->mesh, mass, target, cvt_options, &label, &stats).ok());
  if (cvt) *cvt = stats;
  Mesh out;
  std::vector<uint32_t> cell;
  const Status s = mesh_clusters(refined->mesh, label, stats.clusters, &out, &cell, mesh_stats, options);
  EXPECT_TRUE(s.ok()) << s.to_string();
  return out;
}

TEST(SurfaceRefineTest, SplitsLongEdgesAndKeepsTheShape) {
  const Mesh cube = box(1, 1, 1, 1);  // 12 triangles, welded at the corners
  std::vector<float> value(cube.vertex_count());
  for (size_t v = 0; v < value.size(); ++v) value[v] = cube.positions[3 * v];
  auto r = refine_surface(cube, value, 1, 0.1, 1'000'000);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(count(r->mesh).boundary_edges, 0u);  // welded and conforming
  EXPECT_NEAR(volume(r->mesh), 1.0, 1e-6);
  for (size_t f = 0; f < r->mesh.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Vec3d a = load3d(r->mesh.positions.data(), r->mesh.indices[3 * f + c]);
      const Vec3d b = load3d(r->mesh.positions.data(), r->mesh.indices[3 * f + (c + 1) % 3]);
      ASSERT_LE(norm(a - b), 0.1 + 1e-9);
    }
  for (size_t v = 0; v < r->mesh.vertex_count(); ++v)  // the value is linear in x: interpolated exactly
    ASSERT_NEAR(r->value[v], r->mesh.positions[3 * v], 1e-6);
}

// The geometry made first (a job makes it beside its front half), then two
// different value sets carried onto it: each the bits refine_surface gives
// for that set, on a surface with a pinch copy (two cubes sharing a corner)
// and an unused vertex.
TEST(SurfaceRefineTest, MidpointsAreNumberedInTheOrderTheFacesMeetTheirEdges) {
  // Two unit triangles far apart, the first face on the higher vertex
  // numbers: every edge is split in the first pass, and the new vertices
  // follow the faces (face 0's edges first, corner by corner), not the
  // edges' own order (which would put (0, 1) first).
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 0, 0, 6, 0, 0, 5, 1, 0};
  m.indices = {3, 4, 5, 0, 1, 2};
  auto r = refine_geometry(m, 0.9, 1000);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_GE(r->pass_end.size(), 1u);
  ASSERT_EQ(r->pass_end[0], 6u);  // six edges, all longer than 0.9 (the legs are 1)
  EXPECT_EQ(std::vector<uint32_t>(r->midpoint_ends.begin(), r->midpoint_ends.begin() + 12),
            (std::vector<uint32_t>{3, 4, 4, 5, 5, 3, 0, 1, 1, 2, 2, 0}));
  // Each triangle split 1:4 and no edge left longer than 0.9.
  EXPECT_EQ(r->mesh.face_count(), 8u);
  for (size_t f = 0; f < r->mesh.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Vec3d a = load3d(r->mesh.positions.data(), r->mesh.indices[3 * f + c]);
      const Vec3d b = load3d(r->mesh.positions.data(), r->mesh.indices[3 * f + (c + 1) % 3]);
      EXPECT_LE(norm(a - b), 0.9);
    }
}

TEST(SurfaceRefineTest, GeometryFirstThenValuesGivesRefineSurfaceBits) {
  Mesh m = box(1, 1, 1, 1);
  const Mesh other = box(1, 1, 1, 1);
  const uint32_t base = uint32_t(m.vertex_count());
  for (size_t i = 0; i < other.positions.size(); ++i) m.positions.push_back(other.positions[i] + 1.0f);  // corner (1,1,1) shared
  for (uint32_t i : other.indices) m.indices.push_back(base + i);
  m.positions.insert(m.positions.end(), {5.0f, 5.0f, 5.0f});  // unused
  std::vector<float> a(2 * m.vertex_count()), b(2 * m.vertex_count());
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    a[2 * v] = m.positions[3 * v];
    a[2 * v + 1] = float(v % 7);
    b[2 * v] = m.positions[3 * v + 2] * 3.0f;
    b[2 * v + 1] = 1.0f / float(v + 1);
  }
  auto geometry = refine_geometry(m, 0.15, 1'000'000);
  ASSERT_TRUE(geometry.ok()) << geometry.status().to_string();
  EXPECT_TRUE(geometry->value.empty());
  EXPECT_FALSE(geometry->pinch_copies.empty());
  for (const std::vector<float>* value : {&a, &b}) {
    auto whole = refine_surface(m, *value, 2, 0.15, 1'000'000);
    ASSERT_TRUE(whole.ok());
    RefinedSurface carried = *geometry;
    ASSERT_TRUE(carry_values(*value, 2, &carried).ok());
    EXPECT_EQ(carried.mesh.indices, whole->mesh.indices);
    EXPECT_EQ(carried.mesh.positions, whole->mesh.positions);
    ASSERT_EQ(carried.value.size(), whole->value.size());
    EXPECT_EQ(std::memcmp(carried.value.data(), whole->value.data(), carried.value.size() * sizeof(float)), 0);
  }
  RefinedSurface wrong = *geometry;
  EXPECT_EQ(carry_values(std::vector<float>(3), 2, &wrong).code(), StatusCode::kInvalidArgument);
}

// Every face edge both ways, with the number of faces that use it: the
// reference the edge rows are checked against.
std::map<std::pair<uint32_t, uint32_t>, uint32_t> edge_uses(const Mesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> uses;
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = m.indices[3 * f + c], b = m.indices[3 * f + (c + 1) % 3];
      ++uses[{a, b}];
      ++uses[{b, a}];
    }
  return uses;
}

TEST(MeshEdgesTest, RowsMatchTheFacesEdges) {
  // Against a map of every face edge: each row holds the vertex's distinct
  // neighbours in ascending order, each with the number of faces that use
  // the edge; an open tube has boundary edges (one face) at both ends.
  const Mesh m = tube(1.0, 2.0, 17, 5);
  const auto uses = edge_uses(m);
  const MeshEdges e = mesh_edges(m);
  ASSERT_EQ(e.vertex_count(), m.vertex_count());
  ASSERT_EQ(e.neighbor.size(), uses.size());
  size_t i = 0, boundary = 0;
  for (const auto& [edge, n] : uses) {  // the map's order is the rows' order
    ASSERT_GE(i, e.offset[edge.first]);
    ASSERT_LT(i, e.offset[edge.first + 1]);
    EXPECT_EQ(e.neighbor[i], edge.second);
    EXPECT_EQ(e.faces[i], n);
    EXPECT_EQ(e.entry(edge.first, edge.second), i);
    boundary += n == 1;
    ++i;
  }
  EXPECT_EQ(boundary, 2u * 2 * 17);  // two loops of 17 edges, each edge in both rows
  EXPECT_EQ(e.entry(0, 0), UINT32_MAX);
}

TEST(MeshEdgesTest, RowsMatchTheFacesEdgesOnAnyThreadCount) {
  // Large enough that the rows are counted and filled in several vertex
  // ranges at once (one per thread, 16,384 vertices or more each): the rows
  // must still be the map's, on any thread count.
  const Mesh m = tube(1.0, 2.0, 400, 250);
  ASSERT_GT(m.vertex_count(), 4u * 16384);
  const auto uses = edge_uses(m);
  std::vector<uint32_t> neighbor, faces;
  std::vector<uint32_t> offset(m.vertex_count() + 1, 0);
  for (const auto& [edge, n] : uses) {  // the map's order is the rows' order
    neighbor.push_back(edge.second);
    faces.push_back(n);
    ++offset[edge.first + 1];
  }
  std::partial_sum(offset.begin(), offset.end(), offset.begin());
  for (int threads : {1, 2, 3, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const MeshEdges e = mesh_edges(m);
    EXPECT_EQ(e.offset, offset) << threads << " threads";
    EXPECT_EQ(e.neighbor, neighbor) << threads << " threads";
    EXPECT_EQ(e.faces, faces) << threads << " threads";
  }
}

// Later passes look only at the faces the pass before made, and write the
// faces that split in place among the rest: on a sphere stretched 40-fold
// along x (long thin faces, so that splits beget splits for several passes,
// the last ones leaving most faces whole), every edge ends at most max_edge long, the surface
// stays closed and conforming (every edge in two faces), keeps its area and
// its faces' input order, and the same on any thread count.
TEST(SurfaceRefineTest, LaterPassesSplitOnlyNewFacesAndKeepTheSurfaceClosed) {
  Mesh input = testing::icosphere(3);
  for (size_t v = 0; v < input.vertex_count(); ++v) input.positions[3 * v] *= 40.0f;
  auto area = [](const Mesh& m) {
    double a = 0;
    for (size_t f = 0; f < m.face_count(); ++f) {
      const uint32_t* t = &m.indices[3 * f];
      const Vec3d p = load3d(m.positions.data(), t[0]);
      a += 0.5 * norm(cross(load3d(m.positions.data(), t[1]) - p, load3d(m.positions.data(), t[2]) - p));
    }
    return a;
  };
  const double max_edge = 0.35;
  RefinedSurface reference;
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    auto r = refine_geometry(input, max_edge, 10'000'000);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    if (threads == 1) {
      reference = *r;
      ASSERT_GE(r->pass_end.size(), 4u) << "the stretched sphere should take several passes";
      const size_t last = r->pass_end.back() - r->pass_end[r->pass_end.size() - 2];
      EXPECT_LT(4 * last, r->mesh.face_count()) << "the last pass leaves most faces whole";
      for (size_t f = 0; f < r->mesh.face_count(); ++f)
        for (int c = 0; c < 3; ++c) {
          const Vec3d a = load3d(r->mesh.positions.data(), r->mesh.indices[3 * f + c]);
          const Vec3d b = load3d(r->mesh.positions.data(), r->mesh.indices[3 * f + (c + 1) % 3]);
          ASSERT_LE(norm(a - b), max_edge) << "face " << f;
        }
      EXPECT_EQ(std::count_if(r->edges.faces.begin(), r->edges.faces.end(), [](uint32_t n) { return n != 2; }), 0);
      EXPECT_TRUE(std::is_sorted(r->face.begin(), r->face.end()));
      EXPECT_NEAR(area(r->mesh), area(input), 1e-9 * area(input));
      const MeshEdges e = mesh_edges(r->mesh);
      EXPECT_EQ(r->edges.neighbor, e.neighbor);
    } else {
      EXPECT_EQ(r->mesh.indices, reference.mesh.indices) << threads << " threads";
      EXPECT_EQ(r->mesh.positions, reference.mesh.positions) << threads << " threads";
      EXPECT_EQ(r->face, reference.face) << threads << " threads";
      EXPECT_EQ(r->midpoint_ends, reference.midpoint_ends) << threads << " threads";
    }
  }
}

// The edge rows' twin (the GPU's in the pipeline): its rows and corners are
// the surface's when it answers; when it fails, the host's rows, and why.
TEST(SurfaceRefineTest, AnEdgeRowsTwinsRowsAreKeptAndAFailingOneLeavesTheHostsRows) {
  const Mesh m = testing::torus(1.0, 0.3, 30, 40);
  int calls = 0;
  const MeshEdgesTwin answering = [&calls](const std::vector<uint32_t>& indices, size_t n, MeshEdges* e,
                                           VertexCorners* c) {
    ++calls;
    *e = mesh_edges(indices, n);
    *c = vertex_corners(indices, n);
    e->faces.back() = 99;  // a mark: the twin's rows, not rows made again
    return Status::Ok();
  };
  auto kept = refine_geometry(m, EdgeBounds{0.05, 0, 0}, 1'000'000, answering);
  ASSERT_TRUE(kept.ok()) << kept.status().to_string();
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(kept->edges_twin, "gpu");
  EXPECT_EQ(kept->edges.faces.back(), 99u);
  ASSERT_TRUE(kept->corners.built(kept->mesh.vertex_count()));
  EXPECT_GT(kept->mesh.vertex_count(), m.vertex_count());

  const MeshEdgesTwin failing = [](const std::vector<uint32_t>&, size_t, MeshEdges*, VertexCorners*) {
    return resource_exhausted("no room on the device");
  };
  auto host = refine_geometry(m, EdgeBounds{0.05, 0, 0}, 1'000'000, failing);
  ASSERT_TRUE(host.ok()) << host.status().to_string();
  EXPECT_NE(host->edges_twin.find("no room on the device"), std::string::npos) << host->edges_twin;
  EXPECT_EQ(host->mesh.indices, kept->mesh.indices);
  const MeshEdges rows = mesh_edges(host->mesh.indices, host->mesh.vertex_count());
  EXPECT_EQ(host->edges.neighbor, rows.neighbor);
  EXPECT_EQ(host->edges.faces, rows.faces);
  EXPECT_EQ(refine_geometry(m, 0.05, 1'000'000)->edges_twin, "");
}

// The weld over many blocks of its scans: an icosphere as a soup (each face
// its own three vertices, 245,760 in all, shuffled so that a position's
// copies lie far apart) welds back to the sphere's vertices, each kept by
// its lowest index, numbered in index order, on any thread count.
TEST(SurfaceRefineTest, WeldKeepsEachPositionsLowestIndexOverManyBlocks) {
  const Mesh sphere = testing::icosphere(6);
  Mesh soup;
  std::vector<uint32_t> order(sphere.indices.size());
  std::iota(order.begin(), order.end(), 0u);
  std::mt19937 rng(5);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<uint32_t> slot(order.size());  // corner -> its soup vertex
  for (size_t i = 0; i < order.size(); ++i) slot[order[i]] = uint32_t(i);
  soup.positions.resize(3 * order.size());
  for (size_t c = 0; c < order.size(); ++c)
    for (int k = 0; k < 3; ++k)
      soup.positions[3 * size_t(slot[c]) + k] = sphere.positions[3 * size_t(sphere.indices[c]) + k];
  soup.indices = slot;
  // Per sphere vertex, the lowest soup index holding it: the keepers in order.
  std::vector<uint32_t> lowest(sphere.vertex_count(), UINT32_MAX);
  for (size_t c = 0; c < order.size(); ++c) lowest[sphere.indices[c]] = std::min(lowest[sphere.indices[c]], slot[c]);
  std::vector<uint32_t> want(lowest);
  std::sort(want.begin(), want.end());
  std::vector<uint32_t> first;
  for (int threads : {1, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    auto r = refine_geometry(soup, 10.0, 10'000'000);  // no edge is long: the weld alone
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    EXPECT_EQ(r->mesh.vertex_count(), sphere.vertex_count());
    EXPECT_EQ(r->source, want) << threads << " threads";
    for (size_t k = 0; k < want.size() && k < r->mesh.vertex_count(); ++k)
      for (int a = 0; a < 3; ++a) ASSERT_EQ(r->mesh.positions[3 * k + a], soup.positions[3 * size_t(want[k]) + a]);
    EXPECT_EQ(count(r->mesh).boundary_edges, 0u);
    if (first.empty())
      first = r->mesh.indices;
    else
      EXPECT_EQ(r->mesh.indices, first) << threads << " threads";
  }
}

TEST(SurfaceRefineTest, WeldsDuplicatesAndSmoothsTheSameOnAnyThreadCount) {
  // Refinement and density smoothing run in parallel: positions, faces,
  // values and the smoothed channel must not depend on the thread count. The
  // box's faces are separate grids sharing border positions, so the weld
  // (lowest index first) is exercised too: a closed, welded result.
  const Mesh input = box(1, 0.7, 0.4, 9);
  std::vector<float> value(2 * input.vertex_count());
  for (size_t v = 0; v < input.vertex_count(); ++v) {
    value[2 * v] = input.positions[3 * v + 1];
    value[2 * v + 1] = input.positions[3 * v] > 0.2f ? 3.0f : 0.5f;  // a jump for the smoothing to spread
  }
  RefinedSurface reference;
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    auto r = refine_surface(input, value, 2, 0.03, 10'000'000);
    ASSERT_TRUE(r.ok());
    auto between = [&](const std::vector<float>& values) {  // vertices the jump's spread has reached
      size_t n = 0;
      for (size_t v = 0; v < r->mesh.vertex_count(); ++v) {
        EXPECT_GE(values[2 * v + 1], 0.5f);
        EXPECT_LE(values[2 * v + 1], 3.0f);
        n += values[2 * v + 1] > 0.5f && values[2 * v + 1] < 3.0f;
      }
      return n;
    };
    const size_t before = between(r->value);
    smooth_over_edges(r->edges, 16, 2, 1, &r->value);
    if (threads == 1) {
      reference = *r;
      EXPECT_EQ(count(r->mesh).boundary_edges, 0u);
      EXPECT_GT(r->mesh.vertex_count(), 4 * input.vertex_count());
      const MeshEdges e = mesh_edges(r->mesh);  // the by-product is the refined mesh's edges
      EXPECT_EQ(r->edges.offset, e.offset);
      EXPECT_EQ(r->edges.neighbor, e.neighbor);
      EXPECT_EQ(r->edges.faces, e.faces);
      EXPECT_GT(between(r->value), 4 * before);  // 16 passes spread the jump over several edges
      continue;
    }
    EXPECT_EQ(r->mesh.positions, reference.mesh.positions) << threads << " threads";
    EXPECT_EQ(r->mesh.indices, reference.mesh.indices) << threads << " threads";
    EXPECT_EQ(r->face, reference.face) << threads << " threads";
    EXPECT_EQ(r->value, reference.value) << threads << " threads";
  }
}

// The areas from the corners by vertex are the face-order sums, bit for bit:
// on a torus with an unused vertex and a face that holds one vertex twice.
TEST(SurfaceCvtTest, VertexAreasFromCornersAreTheSameSums) {
  Mesh mesh = torus(1.0, 0.3, 40, 24);
  const uint32_t unused = uint32_t(mesh.vertex_count());
  mesh.positions.insert(mesh.positions.end(), {5.0f, 5.0f, 5.0f});
  mesh.indices.insert(mesh.indices.end(), {3, 3, 7});  // a degenerate face: vertex 3 twice, no area
  mesh.indices.insert(mesh.indices.end(), {3, 11, 90});
  const std::vector<double> plain = vertex_areas(mesh);
  const VertexCorners corners = vertex_corners(mesh.indices, mesh.vertex_count());
  ASSERT_TRUE(corners.built(mesh.vertex_count()));
  const std::vector<double> from_corners = vertex_areas(mesh, &corners);
  ASSERT_EQ(from_corners.size(), plain.size());
  EXPECT_EQ(std::memcmp(from_corners.data(), plain.data(), plain.size() * sizeof(double)), 0);
  EXPECT_EQ(plain[unused], 0.0);
  EXPECT_GT(plain[90], 0.0);
  // Corners of another mesh are not used: the plain sums.
  const VertexCorners other = vertex_corners({0, 1, 2}, 3);
  const std::vector<double> ignored = vertex_areas(mesh, &other);
  EXPECT_EQ(std::memcmp(ignored.data(), plain.data(), plain.size() * sizeof(double)), 0);
}

TEST(SurfaceCvtTest, EnergyFallsEverySweepAndStopsOnItsTolerance) {
  CvtStats stats;
  const Mesh out = remesh(box(1, 0.7, 0.4, 12), 400, DensityMode::kUniform, &stats);
  ASSERT_GE(stats.energy.size(), 2u);
  for (size_t i = 1; i < stats.energy.size(); ++i) EXPECT_LE(stats.energy[i], stats.energy[i - 1]) << i;
  EXPECT_TRUE(stats.converged);
  EXPECT_LT(stats.sweeps, CvtOptions{}.max_sweeps);
  EXPECT_LT(stats.energy.back(), 0.9 * stats.energy.front());
  EXPECT_NEAR(double(out.vertex_count()), 400.0, 8.0);  // +-2%
}

// A sphere's surface as the CVT takes it (2,562 elements), and a check
// that a run gives `expected` on 1 and 3 threads too.
struct CvtSurface {
  Mesh mesh = testing::icosphere(4);
  MeshEdges edges = mesh_edges(mesh);
  std::vector<double> mass = vertex_areas(mesh);
};

void expect_same_on_threads(const CvtSurface& s, uint32_t count, const CvtOptions& options,
                            const std::vector<uint32_t>& expected) {
  for (int threads : {1, 3}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<uint32_t> again;
    CvtStats again_stats;
    ASSERT_TRUE(surface_cvt(s.mesh, s.edges, s.mass, count, options, &again, &again_stats).ok());
    EXPECT_EQ(again, expected) << threads << " threads";
  }
}

// Cold runs at `from` and at `to`, and a run at `to` started from the
// first's cells (CvtOptions::start_label); c->options gives it again.
struct WarmCase {
  std::vector<uint32_t> source, cold, warm;
  CvtStats cold_stats, warm_stats;
  CvtOptions options;
};

void run_warm_case(const CvtSurface& s, uint32_t from, uint32_t to, WarmCase* c) {
  CvtStats source_stats;
  ASSERT_TRUE(surface_cvt(s.mesh, s.edges, s.mass, from, CvtOptions{}, &c->source, &source_stats).ok());
  ASSERT_TRUE(surface_cvt(s.mesh, s.edges, s.mass, to, CvtOptions{}, &c->cold, &c->cold_stats).ok());
  c->options.start_label = &c->source;
  ASSERT_TRUE(surface_cvt(s.mesh, s.edges, s.mass, to, c->options, &c->warm, &c->warm_stats).ok());
}

// A warm start (CvtOptions::start_label, a visual target's try below a
// passing one): the cells of a run at 10% more are merged down to the count
// and the sweeps go on. It must reach the count exactly, end at about the
// energy a cold start reaches (lower or within 2%), in fewer sweeps, with
// the same labels on any thread count.
TEST(SurfaceCvtTest, WarmStartFromMoreCellsMergesDownToTheCount) {
  const CvtSurface surface;
  WarmCase c;
  run_warm_case(surface, 330, 300, &c);
  const std::vector<uint32_t>& warm = c.warm;
  const CvtStats &cold_stats = c.cold_stats, &warm_stats = c.warm_stats;
  EXPECT_EQ(warm_stats.clusters, 300u);
  EXPECT_EQ(warm_stats.warm_merged, 30u);
  EXPECT_EQ(*std::max_element(warm.begin(), warm.end()), 299u);
  EXPECT_EQ(std::set<uint32_t>(warm.begin(), warm.end()).size(), 300u);  // no cell left empty
  EXPECT_LT(warm_stats.sweeps, cold_stats.sweeps);
  EXPECT_LT(warm_stats.energy.back(), 1.02 * cold_stats.energy.back())
      << warm_stats.energy.back() / cold_stats.energy.back();
  expect_same_on_threads(surface, 300, c.options, warm);
  // Labels of another surface are refused.
  std::vector<uint32_t> wrong(c.source.begin(), c.source.end() - 1);
  CvtOptions bad;
  bad.start_label = &wrong;
  std::vector<uint32_t> out;
  CvtStats out_stats;
  EXPECT_FALSE(surface_cvt(surface.mesh, surface.edges, surface.mass, 300, bad, &out, &out_stats).ok());
}

// The other way (a visual target's try above one that failed): the cells of
// a run at 10% fewer, the largest cut in two until the count is reached.
// Exactly the count, every cell one connected piece, about the energy a
// cold start reaches (within 2%), in fewer sweeps, the same labels on any
// thread count; and from far fewer cells (a third), in rounds.
TEST(SurfaceCvtTest, WarmStartFromFewerCellsCutsTheLargestInTwo) {
  const CvtSurface surface;
  WarmCase c;
  run_warm_case(surface, 300, 330, &c);
  const std::vector<uint32_t>& warm = c.warm;
  const CvtStats &cold_stats = c.cold_stats, &warm_stats = c.warm_stats;
  EXPECT_EQ(warm_stats.clusters, 330u);
  EXPECT_EQ(warm_stats.warm_split, 30u);
  EXPECT_EQ(warm_stats.warm_merged, 0u);
  EXPECT_EQ(*std::max_element(warm.begin(), warm.end()), 329u);
  // Each cell connected: a walk over the edges within the cell from its
  // first element reaches all of its elements.
  std::vector<size_t> size(330, 0), reached(330, 0);
  for (uint32_t l : warm) ++size[l];
  std::vector<char> seen(warm.size(), 0);
  for (uint32_t v = 0; v < warm.size(); ++v) {
    if (seen[v] || reached[warm[v]] > 0) continue;  // only each cell's first element starts a walk
    std::vector<uint32_t> stack = {v};
    seen[v] = 1;
    while (!stack.empty()) {
      const uint32_t u = stack.back();
      stack.pop_back();
      ++reached[warm[u]];
      for (const uint32_t* w = surface.edges.begin(u); w != surface.edges.end(u); ++w)
        if (!seen[*w] && warm[*w] == warm[u]) seen[*w] = 1, stack.push_back(*w);
    }
  }
  for (uint32_t cell = 0; cell < 330; ++cell) {
    EXPECT_GT(size[cell], 0u) << cell;
    EXPECT_EQ(reached[cell], size[cell]) << "cell " << cell << " is in pieces";
  }
  EXPECT_LT(warm_stats.sweeps, cold_stats.sweeps);
  EXPECT_LT(warm_stats.energy.back(), 1.02 * cold_stats.energy.back())
      << warm_stats.energy.back() / cold_stats.energy.back();
  expect_same_on_threads(surface, 330, c.options, warm);
  WarmCase third;
  run_warm_case(surface, 100, 330, &third);
  EXPECT_EQ(third.warm_stats.clusters, 330u);
  EXPECT_EQ(third.warm_stats.warm_split, 230u);
  EXPECT_EQ(std::set<uint32_t>(third.warm.begin(), third.warm.end()).size(), 330u);
  EXPECT_LT(third.warm_stats.energy.back(), 1.02 * cold_stats.energy.back())
      << third.warm_stats.energy.back() / cold_stats.energy.back();
}

// The surface's normals and anisotropic offsets kept by one run
// (CvtOptions::surface_cache) and read by the next, a warm start at a
// nearby count as a visual target makes: the same labels as runs without
// the cache, and the cache filled once, for the counts' shared (passes,
// taper).
TEST(SurfaceCvtTest, SurfaceCacheGivesTheSameCells) {
  const CvtSurface surface;
  const Mesh& sphere = surface.mesh;
  const MeshEdges& edges = surface.edges;
  const std::vector<double>& mass = surface.mass;
  CvtOptions plain;
  plain.anisotropy = 0.04;
  std::vector<uint32_t> first, second, first_cached, second_cached;
  CvtStats stats;
  ASSERT_TRUE(surface_cvt(sphere, edges, mass, 320, plain, &first, &stats).ok());
  CvtOptions from = plain;
  from.start_label = &first;
  ASSERT_TRUE(surface_cvt(sphere, edges, mass, 300, from, &second, &stats).ok());

  CvtSurfaceCache cache;
  CvtOptions cached = plain;
  cached.surface_cache = &cache;
  ASSERT_TRUE(surface_cvt(sphere, edges, mass, 320, cached, &first_cached, &stats).ok());
  EXPECT_EQ(first_cached, first);
  ASSERT_EQ(cache.normal.size(), sphere.vertex_count());
  ASSERT_EQ(cache.offsets.size(), sphere.vertex_count());
  const int passes = cache.passes, taper = cache.taper;
  EXPECT_GT(passes, 0);
  auto flat = [](const std::vector<Vec3d>& v) {
    std::vector<double> out;
    for (const Vec3d& p : v) out.insert(out.end(), {p.x, p.y, p.z});
    return out;
  };
  const std::vector<double> kept_offsets = flat(cache.offsets);
  cached.start_label = &first_cached;
  ASSERT_TRUE(surface_cvt(sphere, edges, mass, 300, cached, &second_cached, &stats).ok());
  EXPECT_EQ(second_cached, second);
  EXPECT_EQ(cache.passes, passes);
  EXPECT_EQ(cache.taper, taper);
  EXPECT_EQ(flat(cache.offsets), kept_offsets);
  // Poisoned: a run that reads the cache instead of making them again shows it.
  for (size_t v = 0; v < cache.offsets.size(); ++v) cache.offsets[v] = Vec3d{0.1 * double(v % 7), 0, 0};
  std::vector<uint32_t> poisoned;
  ASSERT_TRUE(surface_cvt(sphere, edges, mass, 300, cached, &poisoned, &stats).ok());
  EXPECT_NE(poisoned, second) << "the cached offsets were not read";
}

TEST(SurfaceCvtTest, SeedsStartSpreadEvenly) {
  // The seeds are stratified by mass along a space-filling curve (surface_cvt.cpp):
  // the cells grown from them start near the converged energy (here 1.21
  // times it). Independent draws (Poisson seeds, the code before) started
  // 1.45 times above it here, 1.5-1.75 times on 10 shared models, which
  // this bound catches.
  CvtStats stats;
  remesh(box(1, 1, 1, 24), 600, DensityMode::kUniform, &stats);
  ASSERT_GE(stats.energy.size(), 2u);
  EXPECT_LT(stats.energy.front(), 1.33 * stats.energy.back()) << "start over end: " << stats.energy.front() / stats.energy.back();
  EXPECT_GT(stats.energy.front(), stats.energy.back());  // and the sweeps still have work to do
}

// The mean distance of a mesh to the sphere of radius r about the origin,
// over its area: 6 x 6 barycentric points per triangle (midpoint rule).
double mean_distance_to_sphere(const Mesh& m, double r) {
  double sum = 0, area = 0;
  constexpr int n = 6;
  for (size_t f = 0; f < m.face_count(); ++f) {
    const Vec3d a = load3d(m.positions.data(), m.indices[3 * f]), b = load3d(m.positions.data(), m.indices[3 * f + 1]),
                c = load3d(m.positions.data(), m.indices[3 * f + 2]);
    const double w = 0.5 * norm(cross(b - a, c - a));
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j)
        for (int up = 0; up < 2 && i + j + up < n; ++up) {  // the n^2 small triangles, each at its centroid
          const double u = (i + (up ? 2.0 : 1.0) / 3) / n, v = (j + (up ? 2.0 : 1.0) / 3) / n;
          sum += w * std::abs(norm(a + (b - a) * u + (c - a) * v) - r);
          area += w;
        }
  }
  return sum / area;
}

TEST(SurfaceCvtTest, OffsetFitHalvesTheMeanDistanceOnASphere) {
  // Vertices on the sphere make every triangle a chord, inside it by up to
  // the sagitta. Across one chord of depth s(1 - x^2), the mean distance is
  // 2s/3; moved out by its L2-optimal offset (the mean depth), it is
  // 0.26 s, 0.39 of the chord's. Triangles are not exact chords (the CVT
  // places vertices at projected centroids) and the samples come from a
  // faceted input, so the test asks for less than 0.6.
  const Mesh sphere = testing::icosphere(5);  // 10,242 vertices, inscribed within 1.2e-4 of the unit sphere
  ClusterMeshOptions off;
  off.offset.enabled = false;
  const Mesh chords = remesh(sphere, 500, DensityMode::kUniform, nullptr, off);
  ClusterMeshStats stats;
  const Mesh fitted = remesh(sphere, 500, DensityMode::kUniform, nullptr, {}, &stats);
  const double before = mean_distance_to_sphere(chords, 1.0), after = mean_distance_to_sphere(fitted, 1.0);
  EXPECT_LT(after, 0.6 * before) << before << " -> " << after;
  std::printf("mean distance to the sphere: %.3g -> %.3g (%.2fx)\n", before, after, after / before);
  EXPECT_LT(stats.offset.rms_after, stats.offset.rms_before);
  EXPECT_EQ(stats.offset.held_vertices, 0u);  // no crease, corner or boundary on a sphere
  EXPECT_EQ(count(fitted).boundary_edges, 0u);
  EXPECT_EQ(count(fitted).non_manifold_edges, 0u);
  EXPECT_EQ(fitted.indices, chords.indices);  // the fit moves vertices only
  // Every vertex moved outwards, by at most its bound (0.1 of its mean edge).
  double longest = 0;
  for (size_t f = 0; f < fitted.face_count(); ++f)
    for (int c = 0; c < 3; ++c)
      longest = std::max(longest, norm(load3d(fitted.positions.data(), fitted.indices[3 * f + c]) -
                                       load3d(fitted.positions.data(), fitted.indices[3 * f + (c + 1) % 3])));
  for (size_t v = 0; v < fitted.vertex_count(); ++v) {
    const double r = norm(load3d(fitted.positions.data(), v));
    EXPECT_GT(r, norm(load3d(chords.positions.data(), v)) - 1e-6) << v;
    EXPECT_LT(r, 1.0 + OffsetFitOptions{}.max_offset_per_edge * longest) << v;
  }
}

// The share of a mesh's triangle angles under `degrees`.
double share_of_angles_below(const Mesh& m, double degrees) {
  const std::vector<double> angles = testing::triangle_angles_deg(m);
  return double(std::count_if(angles.begin(), angles.end(), [&](double a) { return a < degrees; })) /
         double(angles.size());
}

TEST(SurfaceCvtTest, RelaxationRemovesSmallAnglesAndKeepsTheCreases) {
  // A box with curvature density crowds vertices towards its 12 edges,
  // where the dual of the CVT leaves thin triangles beside the crease
  // vertices; relaxing the free vertices in their tangent planes and the
  // crease vertices along their edges must remove at least 40% of them
  // (two rounds measured 47%, three 57%; none would leave them all), and the
  // box must keep its corners, edges and volume (a rounded edge loses it).
  const Mesh input = box(1, 0.7, 0.4, 12);
  ClusterMeshOptions none;
  none.relax_rounds = 0;
  const Mesh raw = remesh(input, 600, DensityMode::kCurvature, nullptr, none);
  const Mesh relaxed = remesh(input, 600, DensityMode::kCurvature);
  const double before = share_of_angles_below(raw, 30), after = share_of_angles_below(relaxed, 30);
  std::printf("angles under 30 degrees: %.2f%% -> %.2f%%\n", 100 * before, 100 * after);
  EXPECT_GT(before, 0.0);
  EXPECT_LT(after, 0.6 * before);
  EXPECT_EQ(relaxed.vertex_count(), raw.vertex_count());
  EXPECT_EQ(count(relaxed).boundary_edges, 0u);
  EXPECT_EQ(count(relaxed).non_manifold_edges, 0u);
  EXPECT_NEAR(volume(relaxed), 1 * 0.7 * 0.4, 1e-4);
  for (size_t v = 0; v < relaxed.vertex_count(); ++v) {  // on the box's surface
    const Vec3d p = load3d(relaxed.positions.data(), v);
    EXPECT_NEAR(std::max({std::abs(p.x) / 0.5, std::abs(p.y) / 0.35, std::abs(p.z) / 0.2}), 1.0, 1e-4) << v;
  }
}

TEST(SurfaceCvtTest, CubeKeepsItsCornersAndEdges) {
  const Mesh out = remesh(box(1, 1, 1, 10), 600, DensityMode::kCurvature);
  const double diag = std::sqrt(3.0);
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3d c{(corner & 1) ? 0.5 : -0.5, (corner & 2) ? 0.5 : -0.5, (corner & 4) ? 0.5 : -0.5};
    double best = INFINITY;
    for (size_t v = 0; v < out.vertex_count(); ++v) best = std::min(best, norm(load3d(out.positions.data(), v) - c));
    EXPECT_LT(best, 1e-4 * diag) << "corner " << corner;
  }
  // Every vertex on the cube's surface, and the edges: every output edge
  // between two vertices on one cube edge lies on it (no chamfer), and each
  // cube edge is covered end to end by such output edges.
  size_t on_edges = 0;
  for (size_t v = 0; v < out.vertex_count(); ++v) {
    const Vec3d p = load3d(out.positions.data(), v);
    const double m = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    EXPECT_NEAR(m, 0.5, 1e-5);
    int at_face = (std::abs(std::abs(p.x) - 0.5) < 1e-5) + (std::abs(std::abs(p.y) - 0.5) < 1e-5) +
                  (std::abs(std::abs(p.z) - 0.5) < 1e-5);
    on_edges += at_face >= 2;
  }
  EXPECT_GE(on_edges, 12u * 3);  // several vertices along each edge, not only the corners
  const Counts k = count(out);
  EXPECT_EQ(k.boundary_edges, 0u);
  EXPECT_EQ(k.non_manifold_edges, 0u);
  EXPECT_NEAR(volume(out), 1.0, 0.01);  // a chamfered cube of this size would lose several percent
}

TEST(SurfaceCvtTest, ThinPlateStaysClosedWithBothFacesApart) {
  const Mesh plate = box(1, 1, 0.01, 40);  // thickness 1% of its length
  const Mesh out = remesh(plate, 2000, DensityMode::kUniform);
  const Counts k = count(out);
  EXPECT_EQ(k.boundary_edges, 0u);
  EXPECT_EQ(k.non_manifold_edges, 0u);
  EXPECT_NEAR(double(out.vertex_count()), 2000.0, 40.0);
  // Both sheets keep their vertices, and the volume between them survives
  // (collapsed sheets would give none).
  size_t top = 0, bottom = 0;
  for (size_t v = 0; v < out.vertex_count(); ++v) {
    top += out.positions[3 * v + 2] > 0.0049f;
    bottom += out.positions[3 * v + 2] < -0.0049f;
  }
  EXPECT_GT(top, 500u);
  EXPECT_GT(bottom, 500u);
  EXPECT_NEAR(volume(out), 0.01, 0.001);
}

TEST(SurfaceCvtTest, WindowAndOpenEndsStayOpen) {
  // A box with a square window through its +x side: one boundary loop.
  const Mesh window = box(1, 1, 1, 12, [](int face, int i, int j) { return face == 1 && i >= 4 && i < 8 && j >= 4 && j < 8; });
  const Mesh w = remesh(window, 800, DensityMode::kUniform);
  EXPECT_EQ(count(w).loops, 1u);
  EXPECT_EQ(count(w).non_manifold_edges, 0u);
  // An open cylinder keeps both rims.
  const Mesh t = remesh(tube(0.5, 1.0, 48, 24), 600, DensityMode::kUniform);
  EXPECT_EQ(count(t).loops, 2u);
  EXPECT_EQ(count(t).non_manifold_edges, 0u);
  // Rim vertices lie on the rims.
  size_t rim = 0;
  for (size_t v = 0; v < t.vertex_count(); ++v) rim += std::abs(std::abs(t.positions[3 * v + 2]) - 0.5f) < 1e-5f;
  EXPECT_GE(rim, 2u * 10);
}

// The dual's quadrics and centroids summed per cell in parallel give the
// bits of the one loop over the faces (boundary planes and creases included:
// a box with a window, and an open tube), on one thread and on three (the
// cells' faces then gathered by three ranges of cells).
TEST(SurfaceCvtTest, PerCellSumsGiveTheOneLoopsBits) {
  const Mesh window = box(1, 1, 1, 12, [](int face, int i, int j) { return face == 1 && i >= 4 && i < 8 && j >= 4 && j < 8; });
  for (const Mesh& input : {window, tube(0.5, 1.0, 48, 24)}) {
    ClusterMeshOptions loop, per_cell;
    loop.per_cell_sums = 0;
    per_cell.per_cell_sums = 1;
    const Mesh a = remesh(input, 900, DensityMode::kCurvature, nullptr, loop);
    ASSERT_GT(a.vertex_count(), 800u);
    for (int threads : {1, 3}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      const Mesh b = remesh(input, 900, DensityMode::kCurvature, nullptr, per_cell);
      EXPECT_EQ(a.positions, b.positions) << threads << " threads";
      EXPECT_EQ(a.indices, b.indices) << threads << " threads";
    }
  }
}

// Each vertex's third of its faces' areas, summed in face order, the same
// bits on any thread count (the sums run by vertex ranges).
TEST(SurfaceCvtTest, VertexAreasAreTheFaceLoopsSumsOnAnyThreadCount) {
  const Mesh input = torus(1.0, 0.3, 240, 240);  // 57,600 vertices: up to three ranges
  std::vector<double> reference(input.vertex_count(), 0.0);
  for (size_t f = 0; f < input.face_count(); ++f) {
    const uint32_t* t = &input.indices[3 * f];
    const Vec3d a = load3d(input.positions.data(), t[0]), b = load3d(input.positions.data(), t[1]),
                c = load3d(input.positions.data(), t[2]);
    for (int k = 0; k < 3; ++k) reference[t[k]] += norm(cross(b - a, c - a)) / 6.0;
  }
  for (int threads : {1, 2, 3, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    EXPECT_EQ(vertex_areas(input), reference) << threads << " threads";
  }
}

// Edge length along the z axis over edge length across it, summed over the
// mesh's edges.
double axial_over_across(const Mesh& m) {
  double axial = 0, across = 0;
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Vec3d d = load3d(m.positions.data(), m.indices[3 * f + c]) -
                      load3d(m.positions.data(), m.indices[3 * f + (c + 1) % 3]);
      axial += std::abs(d.z);
      across += std::sqrt(d.x * d.x + d.y * d.y);
    }
  return axial / across;
}

TEST(SurfaceCvtTest, AnisotropicCellsStretchAlongACylinder) {
  // A long thin tube: its normal turns around the axis and not along it, so
  // in R^6 the cells are shorter across (at most by sqrt(1 + (a / r)^2), 2.2
  // here, less once the normals are smoothed) and the triangles longer along
  // the axis. Isotropic cells give edges of about equal length both ways
  // (ratio 0.99); anisotropic ones measured 1.26, which the edges running
  // on the diagonal dilute. Both keep the two rims.
  const Mesh t = tube(0.1, 2.0, 64, 320);
  const double diag = diagonal(t);
  CvtStats iso_stats, aniso_stats;
  const Mesh iso = remesh(t, 800, DensityMode::kUniform, &iso_stats, {}, nullptr, 0.0);
  const Mesh aniso = remesh(t, 800, DensityMode::kUniform, &aniso_stats, {}, nullptr, 0.2 / diag);
  const double r_iso = axial_over_across(iso), r_aniso = axial_over_across(aniso);
  EXPECT_GT(r_aniso, 1.15 * r_iso) << "isotropic " << r_iso << ", anisotropic " << r_aniso;
  for (const Mesh* m : {&iso, &aniso}) {
    EXPECT_EQ(count(*m).loops, 2u);
    EXPECT_EQ(count(*m).non_manifold_edges, 0u);
    EXPECT_NEAR(double(m->vertex_count()), 800.0, 16.0);
  }
  // The energy in R^6 still falls every sweep.
  for (size_t i = 1; i < aniso_stats.energy.size(); ++i)
    EXPECT_LE(aniso_stats.energy[i], aniso_stats.energy[i - 1]) << i;
  EXPECT_TRUE(aniso_stats.converged);
}

TEST(SurfaceCvtTest, CellsBesideCreasesStayWholeAtFineSpacing) {
  // Beside a sharp vertex the anisotropic offset ramps up from zero (see
  // anisotropic_offsets); over elements far smaller than the offset, the
  // ramps round a scan's scattered sharp vertices squeezed the cells into
  // slivers whose dual vertex is not a manifold, and the topology step then
  // split and merged hundreds of cells (igea at 50,000, horse at 20,000). A
  // sphere with small spikes has no thin part and no handle: no cell should
  // need splitting.
  Mesh s = testing::icosphere(4);
  for (size_t v = 0; v < s.vertex_count(); v += 7)
    for (int k = 0; k < 3; ++k) s.positions[3 * v + k] *= 1.03f;
  // An offset of 0.12 of the diagonal at 3,000 vertices: the ramp's slope
  // (offset per hop over the hop's length) as a scan's at 50,000 with the
  // default 0.04; before the ramp was bounded, 251 cells were split here and
  // the sweeps ran 147 times instead of about 20.
  CvtStats stats;
  const Mesh out = remesh(s, 3000, DensityMode::kUniform, &stats, {}, nullptr, 0.12);
  EXPECT_EQ(stats.cells_split, 0u);
  EXPECT_EQ(stats.defective_cells, 0u);
  EXPECT_LT(stats.sweeps, 60);
  EXPECT_EQ(count(out).boundary_edges, 0u);
  EXPECT_EQ(count(out).non_manifold_edges, 0u);
}

// Faces joined by edges: how many pieces.
size_t pieces(const Mesh& m) {
  std::vector<uint32_t> parent(m.vertex_count());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int k = 1; k < 3; ++k) parent[find(m.indices[3 * f + k])] = find(m.indices[3 * f]);
  std::set<uint32_t> roots;
  for (size_t f = 0; f < m.face_count(); ++f) roots.insert(find(m.indices[3 * f]));
  return roots.size();
}

// A closed octagonal rod along z from z0 down to z1 = z0 - length at (x, y):
// nu facets, nl rings, each cap a fan round its centre vertex.
Mesh rod(double x, double y, double z0, double length, double r, int nu, int nl) {
  Mesh m;
  for (int i = 0; i <= nl; ++i)
    for (int j = 0; j < nu; ++j) {
      const double w = 2 * kPi * j / nu;
      m.positions.insert(m.positions.end(), {float(x + r * std::cos(w)), float(y + r * std::sin(w)), float(z0 - length * i / nl)});
    }
  for (int i = 0; i < nl; ++i)
    for (int j = 0; j < nu; ++j) {
      const uint32_t a = i * nu + j, b = i * nu + (j + 1) % nu, c = a + nu, d = b + nu;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});  // outward: z falls with i
    }
  const uint32_t top = uint32_t(m.vertex_count()), bottom = top + 1;
  m.positions.insert(m.positions.end(), {float(x), float(y), float(z0), float(x), float(y), float(z0 - length)});
  for (int j = 0; j < nu; ++j) {
    const uint32_t a = j, b = (j + 1) % nu;
    m.indices.insert(m.indices.end(), {top, b, a});
    m.indices.insert(m.indices.end(), {bottom, uint32_t(nl * nu) + a, uint32_t(nl * nu) + b});
  }
  return m;
}

TEST(SurfaceCvtTest, LegsWeldedToATableAtOneVertexComeBackClosed) {
  // A table top (1 x 1 x 0.05, its underside at z = 0) and four octagonal
  // legs (radius 0.03, length 1) whose cap centres are vertices of the
  // underside: one part joined at four single vertices, as modelled assets
  // are (scripts/stress-shapes.py, low-poly-table). Before the pinches were
  // split (surface/pinch_split.h) cells grew through them from a leg into
  // the top, and the topology step's splits at the joins could not all be
  // merged away: 300 asked, 326 came back.
  Mesh table = box(1, 1, 0.05, 20);
  for (size_t v = 0; v < table.vertex_count(); ++v) table.positions[3 * v + 2] += 0.025f;
  for (int corner = 0; corner < 4; ++corner) {
    const Mesh leg = rod((corner & 1) ? 0.4 : -0.4, (corner & 2) ? 0.4 : -0.4, 0.0, 1.0, 0.03, 8, 10);
    const uint32_t base = uint32_t(table.vertex_count());
    table.positions.insert(table.positions.end(), leg.positions.begin(), leg.positions.end());
    for (uint32_t i : leg.indices) table.indices.push_back(base + i);
  }
  for (uint32_t target : {300u, 1000u}) {
    CvtStats stats;
    const Mesh out = remesh(table, target, DensityMode::kCurvature, &stats);
    EXPECT_NEAR(double(out.vertex_count()), double(target), 0.02 * target) << target;
    EXPECT_EQ(count(out).boundary_edges, 0u) << target;
    EXPECT_EQ(count(out).non_manifold_edges, 0u) << target;
    EXPECT_EQ(pieces(out), 5u) << target;  // the top and four legs, each closed
  }
}

TEST(SurfaceCvtTest, TwoBoxesSharingAFaceComeBackAsTwoClosedBoxesAtTheCount) {
  // Boxes side by side, each with its own wall on x = 0 (after the weld the
  // two walls lie on top of each other, drawn both ways round: a double-sided
  // wall inside one box, as modelled assets have). Every edge of the wall is
  // in four faces. Joined there as one fan, the cells ran across the wall and
  // the dual lost or gained vertices: 128 for 100, 1,385 for 2,000.
  Mesh boxes;
  for (double x : {-0.5, 0.5}) {
    Mesh b = box(1, 1, 1, 16);
    const uint32_t base = uint32_t(boxes.vertex_count());
    for (size_t i = 0; i < b.positions.size(); ++i) boxes.positions.push_back(b.positions[i] + (i % 3 == 0 ? float(x) : 0.0f));
    for (uint32_t v : b.indices) boxes.indices.push_back(base + v);
  }
  for (uint32_t target : {100u, 2000u}) {
    const Mesh out = remesh(boxes, target, DensityMode::kCurvature);
    EXPECT_NEAR(double(out.vertex_count()), double(target), 0.02 * target) << target;
    EXPECT_EQ(count(out).boundary_edges, 0u) << target;
    EXPECT_EQ(count(out).non_manifold_edges, 0u) << target;
    EXPECT_EQ(pieces(out), 2u) << target;  // one closed box each side of the wall
  }
}

TEST(SurfaceCvtTest, SmallPartsAreKept) {
  // Three closed boxes of sizes 1, 0.1 and 0.05: each gets vertices and stays closed.
  Mesh m;
  for (double s : {1.0, 0.1, 0.05}) {
    Mesh b = box(s, s, s, 6);
    const uint32_t base = uint32_t(m.vertex_count());
    for (size_t i = 0; i < b.positions.size(); ++i) m.positions.push_back(b.positions[i] + (i % 3 == 0 ? float(3 * s) : 0.0f));
    for (uint32_t v : b.indices) m.indices.push_back(base + v);
  }
  const Mesh out = remesh(m, 300, DensityMode::kUniform);
  EXPECT_EQ(count(out).boundary_edges, 0u);
  size_t small = 0;  // vertices of the two small boxes (x > 0.2, beside the big one at 3)
  for (size_t v = 0; v < out.vertex_count(); ++v) small += out.positions[3 * v] < 0.5f;
  EXPECT_GE(small, 8u);
}

TEST(SurfaceCvtTest, ThinHandleKeepsItsGenus) {
  // A torus whose tube is about three cells around at this target: cells
  // that would wrap the tube are split, so the dual stays a closed torus.
  const Mesh t = torus(1.0, 0.03, 12, 240);
  CvtStats stats;
  const Mesh out = remesh(t, 400, DensityMode::kUniform, &stats);
  const Counts k = count(out);
  EXPECT_EQ(k.boundary_edges, 0u);
  EXPECT_EQ(k.non_manifold_edges, 0u);
  std::set<std::pair<uint32_t, uint32_t>> edges;
  for (size_t f = 0; f < out.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = out.indices[3 * f + c], b = out.indices[3 * f + (c + 1) % 3];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  EXPECT_EQ(int64_t(out.vertex_count()) - int64_t(edges.size()) + int64_t(out.face_count()), 0);  // genus 1
  EXPECT_EQ(stats.defective_cells, 0u);
  EXPECT_NEAR(double(out.vertex_count()), 400.0, 8.0);  // splits made up for by merges: +-2%
}

// A closed rod along x: an open tube (seg around, rings along) capped by two fans.
Mesh rod(double r, double length, int seg, int rings) {
  Mesh m = tube(r, length, seg, rings);
  for (size_t v = 0; v < m.vertex_count(); ++v) std::swap(m.positions[3 * v], m.positions[3 * v + 2]);
  const uint32_t first = uint32_t(m.vertex_count()), last = first + 1;
  m.positions.insert(m.positions.end(), {float(-length / 2), 0, 0, float(length / 2), 0, 0});
  const uint32_t top = uint32_t(rings * seg);
  for (int i = 0; i < seg; ++i) {
    const uint32_t a = uint32_t(i), b = uint32_t((i + 1) % seg);
    m.indices.insert(m.indices.end(), {first, b, a, last, top + a, top + b});
  }
  return m;
}

size_t components(const Mesh& m) {
  std::vector<uint32_t> parent(m.vertex_count());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int c = 1; c < 3; ++c) parent[find(m.indices[3 * f + c])] = find(m.indices[3 * f]);
  std::set<uint32_t> roots;
  for (size_t f = 0; f < m.face_count(); ++f) roots.insert(find(m.indices[3 * f]));
  return roots.size();
}

TEST(SurfaceCvtTest, ThinRodStaysOnePiece) {
  // A rod 200 times as long as it is wide, at a count that leaves about two
  // isotropic cells around it: cells grown from the seeds close into bands
  // around the rod, which meet their neighbours in whole circles and in no
  // dual triangle. They are split like any cell that is not a disk; before
  // that, the rod came back as four closed pieces.
  const Mesh r = rod(0.05, 20.0, 32, 400);
  ASSERT_EQ(components(r), 1u);
  CvtStats stats;
  const Mesh out = remesh(r, 300, DensityMode::kUniform, &stats);
  const Counts k = count(out);
  EXPECT_EQ(k.boundary_edges, 0u);
  EXPECT_EQ(k.non_manifold_edges, 0u);
  EXPECT_EQ(components(out), 1u);
  EXPECT_EQ(stats.defective_cells, 0u);
  EXPECT_NEAR(double(out.vertex_count()), 300.0, 6.0);
  // It still spans the rod's length.
  float lo = 0, hi = 0;
  for (size_t v = 0; v < out.vertex_count(); ++v)
    lo = std::min(lo, out.positions[3 * v]), hi = std::max(hi, out.positions[3 * v]);
  EXPECT_GT(hi - lo, 19.5f);
}

TEST(SurfaceCvtTest, ThinPartsAtAFewVerticesKeepBothSides) {
  // Far fewer vertices than the thin parts' widths ask for: a plate 0.4%
  // thick at 100 vertices (cells 35 times as wide as the plate is thick)
  // and the rod above at 100 (a cell's width is the rod's circumference).
  // Cells grown over the rim face both ways, and the dual cannot keep the
  // two sides apart; cells that take only elements facing their own way do.
  // Before, the plate came back in two closed pieces, the rod in twelve.
  struct Case {
    const char* name;
    Mesh mesh;
  };
  const Case cases[] = {{"plate", box(1, 1, 0.004, 40)}, {"rod", rod(0.05, 20.0, 32, 400)}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    CvtStats stats;
    const Mesh out = remesh(c.mesh, 100, DensityMode::kUniform, &stats);
    const Counts k = count(out);
    EXPECT_EQ(k.boundary_edges, 0u);
    EXPECT_EQ(k.non_manifold_edges, 0u);
    EXPECT_EQ(components(out), 1u);
    EXPECT_NEAR(double(out.vertex_count()), 100.0, 2.0);
    EXPECT_GT(volume(out), 0.5 * volume(c.mesh));  // both sides kept apart
  }
}

// Two balls of radius 0.25 at z = -0.75 and 0.75 joined by a neck of radius
// `neck`: a closed surface of revolution, `seg` around, `rings` along z.
Mesh dumbbell(double neck, int seg, int rings) {
  Mesh m;
  m.positions.insert(m.positions.end(), {0, 0, -1});
  for (int j = 1; j < rings; ++j) {
    const double z = -1.0 + 2.0 * j / rings, d = std::min(std::abs(z + 0.75), std::abs(z - 0.75));
    const double ball = d < 0.25 ? std::sqrt(0.0625 - d * d) : 0.0;
    const double r = std::abs(z) < 0.75 ? std::max(ball, neck) : ball;
    for (int i = 0; i < seg; ++i) {
      const double a = 2 * kPi * i / seg;
      m.positions.insert(m.positions.end(), {float(r * std::cos(a)), float(r * std::sin(a)), float(z)});
    }
  }
  m.positions.insert(m.positions.end(), {0, 0, 1});
  const uint32_t top = uint32_t(m.vertex_count() - 1);
  auto at = [&](int j, int i) { return uint32_t(1 + (j - 1) * seg + (i % seg)); };
  for (int i = 0; i < seg; ++i) {
    m.indices.insert(m.indices.end(), {0, at(1, i + 1), at(1, i)});
    m.indices.insert(m.indices.end(), {top, at(rings - 1, i), at(rings - 1, i + 1)});
    for (int j = 1; j + 1 < rings; ++j)
      m.indices.insert(m.indices.end(), {at(j, i), at(j, i + 1), at(j + 1, i + 1), at(j, i), at(j + 1, i + 1), at(j + 1, i)});
  }
  return m;
}

TEST(SurfaceCvtTest, ThinNeckKeepsTheBallsJoined) {
  // A neck 1% of the length wide holds 4% of the area: at 100 vertices its
  // cells go round it, and the splits that undo that need more than a
  // quarter of the count in splits and 8 rounds (with those, it came back
  // in three pieces).
  const Mesh d = dumbbell(0.01, 96, 200);
  ASSERT_EQ(components(d), 1u);
  const Mesh out = remesh(d, 100, DensityMode::kCurvature);
  const Counts k = count(out);
  EXPECT_EQ(k.boundary_edges, 0u);
  EXPECT_EQ(k.non_manifold_edges, 0u);
  EXPECT_EQ(components(out), 1u);
  EXPECT_NEAR(double(out.vertex_count()), 100.0, 2.0);
}

TEST(SurfaceCvtTest, SmallWindowsSideBySideStayOpenAndApart) {
  // Two windows of one grid cell each, one cell apart, on the +x side of a
  // box remeshed coarsely: each keeps its own loop (a cell on both would
  // join them, three cells on one could cap it).
  const Mesh window = box(1, 1, 1, 16, [](int face, int i, int j) { return face == 1 && j == 8 && (i == 6 || i == 8); });
  const Mesh w = remesh(window, 400, DensityMode::kUniform);
  EXPECT_EQ(count(w).loops, 2u);
  EXPECT_EQ(count(w).non_manifold_edges, 0u);
}

TEST(SurfaceCvtTest, SameCellsAndMeshOnAnyThreadCount) {
  // The dual's vertex placement and edge sort run in parallel, and the CVT
  // must stay free of thread-count effects as it gains parallel parts: the
  // cells, every energy along the way and the mesh must not depend on how
  // many threads made them. A torus with a thin tube also takes the split
  // and merge rounds. The sweeps run slabs of the surface at once (two at
  // 300 cells, six at 1,500: three of each colour together).
  for (const uint32_t cells : {300u, 1500u})
  for (const Mesh& input : {box(1, 0.7, 0.4, 12), torus(1.0, 0.03, 12, 240)}) {
    const std::vector<float> ones(input.vertex_count(), 1.0f);
    auto refined = refine_surface(input, ones, 1, 0.02, 10'000'000);
    ASSERT_TRUE(refined.ok());
    const std::vector<double> mass = vertex_areas(refined->mesh);
    std::vector<uint32_t> reference;
    CvtStats first;
    Mesh first_mesh;
    for (int threads : {1, 2, 4}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      std::vector<uint32_t> label;
      CvtStats stats;
      ASSERT_TRUE(surface_cvt(refined->mesh, mass, cells, {}, &label, &stats).ok());
      Mesh out;
      std::vector<uint32_t> cell;
      ASSERT_TRUE(mesh_clusters(refined->mesh, label, stats.clusters, &out, &cell, nullptr).ok());
      if (threads == 1) {
        reference = label;
        first = stats;
        first_mesh = out;
        EXPECT_GT(stats.moves, 0u);
        EXPECT_GT(out.face_count(), 0u);
        continue;
      }
      EXPECT_EQ(label, reference) << threads << " threads";
      EXPECT_EQ(stats.energy, first.energy) << threads << " threads";
      EXPECT_EQ(stats.cells_split, first.cells_split) << threads << " threads";
      EXPECT_EQ(out.positions, first_mesh.positions) << threads << " threads";
      EXPECT_EQ(out.indices, first_mesh.indices) << threads << " threads";
    }
  }
}

// The anisotropic offsets taper towards sharp vertices over hops found by a
// walk whose rings are listed in whatever order the threads reach them: the
// cells must not depend on it. A box's edges and corners are sharp, and its
// many rings meet (0.04 of the diagonal, as a job; 900 cells).
// A box refined as a job refines it, its elements' areas as masses and a
// job's anisotropy: the case of the tests below (900 cells).
struct AnisotropicBox {
  Mesh mesh;
  std::vector<double> mass;
  CvtOptions options;
};
AnisotropicBox anisotropic_box() {
  const Mesh input = box(1, 0.7, 0.4, 16);
  const std::vector<float> ones(input.vertex_count(), 1.0f);
  auto refined = refine_surface(input, ones, 1, 0.015, 10'000'000);
  EXPECT_TRUE(refined.ok());
  AnisotropicBox b;
  if (!refined.ok()) return b;
  b.mesh = refined->mesh;
  b.mass = vertex_areas(b.mesh);
  b.options.anisotropy = kDefaultAnisotropy * diagonal(input);
  return b;
}

TEST(SurfaceCvtTest, AnisotropicCellsAreTheSameOnAnyThreadCount) {
  const AnisotropicBox b = anisotropic_box();
  ASSERT_GT(b.mesh.face_count(), 0u);
  const std::vector<double>& mass = b.mass;
  const CvtOptions& options = b.options;
  std::vector<uint32_t> reference;
  CvtStats first;
  for (int threads : {1, 2, 4, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<uint32_t> label;
    CvtStats stats;
    ASSERT_TRUE(surface_cvt(b.mesh, mass, 900, options, &label, &stats).ok());
    if (threads == 1) {
      reference = label;
      first = stats;
      EXPECT_GT(stats.moves, 0u);
      continue;
    }
    EXPECT_EQ(label, reference) << threads << " threads";
    EXPECT_EQ(stats.energy, first.energy) << threads << " threads";
  }
}

// The vertex normals from the corners by vertex (what surface_refine keeps on
// 8 threads or more) are the ones every face's range gives, bit for bit (a
// curved surface, where the order of a vertex's sum shows in its last bits):
// the same cells and energy, isotropic and anisotropic.
TEST(SurfaceCvtTest, NormalsFromTheCornersGiveTheSameCells) {
  Mesh sphere = testing::icosphere(5);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> jitter(-0.004f, 0.004f);  // generic normals, no symmetric sums
  for (float& p : sphere.positions) p += jitter(rng);
  const std::vector<double> mass = vertex_areas(sphere);
  VertexCorners corners;
  MeshEdges edges;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 8);  // over the cores where fewer
    tbb::task_arena(8).execute([&] { edges = mesh_edges(sphere.indices, sphere.vertex_count(), &corners); });
  }
  ASSERT_TRUE(corners.built(sphere.vertex_count()));
  for (double anisotropy : {0.0, kDefaultAnisotropy * diagonal(sphere)}) {
    CvtOptions options;
    options.anisotropy = anisotropy;
    std::vector<uint32_t> reference, label;
    CvtStats first, stats;
    CvtSurfaceCache by_ranges, by_corners;  // each run's normals, to compare bit for bit
    options.surface_cache = &by_ranges;
    ASSERT_TRUE(surface_cvt(sphere, edges, mass, 500, options, &reference, &first).ok());
    options.corners = &corners;
    options.surface_cache = &by_corners;
    ASSERT_TRUE(surface_cvt(sphere, edges, mass, 500, options, &label, &stats).ok());
    ASSERT_EQ(by_corners.normal.size(), sphere.vertex_count());
    ASSERT_EQ(by_ranges.normal.size(), by_corners.normal.size());
    EXPECT_EQ(std::memcmp(by_ranges.normal.data(), by_corners.normal.data(), by_ranges.normal.size() * sizeof(Vec3d)),
              0);
    EXPECT_EQ(label, reference) << "anisotropy " << anisotropy;
    EXPECT_EQ(stats.energy, first.energy) << "anisotropy " << anisotropy;
    EXPECT_GT(stats.moves, 0u);
  }
}

// A smoothing twin (the GPU's on a GPU job; here the CPU's passes) runs while
// the walk to the sharp vertices and the plan (parts, quotas, loops, seeds)
// run on threads of their own: the same cells as all in line, cold and from
// a warm start, on any thread count; a twin that fails fails the CVT.
TEST(SurfaceCvtTest, SmoothingTwinBesideTheWalkGivesTheSameCells) {
  const AnisotropicBox b = anisotropic_box();
  ASSERT_GT(b.mesh.face_count(), 0u);
  const Mesh& mesh = b.mesh;
  const std::vector<double>& mass = b.mass;
  CvtOptions options = b.options;
  std::vector<uint32_t> reference;
  CvtStats first;
  ASSERT_TRUE(surface_cvt(mesh, mass, 900, options, &reference, &first).ok());
  std::atomic<int> calls{0};
  options.device_smoothing = [&calls](const MeshEdges& edges, int passes, std::vector<Vec3d>* values) {
    ++calls;
    return cpu::smooth_over_edges(edges, passes, values);
  };
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<uint32_t> label;
    CvtStats stats;
    ASSERT_TRUE(surface_cvt(mesh, mass, 900, options, &label, &stats).ok());
    EXPECT_EQ(label, reference) << threads << " threads";
    EXPECT_EQ(stats.energy, first.energy) << threads << " threads";
  }
  EXPECT_EQ(calls.load(), 3);
  // Warm, from the cells of a run at fewer cells (cut up to the count).
  std::vector<uint32_t> coarse, warm_inline, warm_beside;
  CvtOptions plain;
  plain.anisotropy = options.anisotropy;
  ASSERT_TRUE(surface_cvt(mesh, mass, 800, plain, &coarse, nullptr).ok());
  plain.start_label = &coarse;
  ASSERT_TRUE(surface_cvt(mesh, mass, 900, plain, &warm_inline, nullptr).ok());
  CvtOptions twin = options;
  twin.start_label = &coarse;
  ASSERT_TRUE(surface_cvt(mesh, mass, 900, twin, &warm_beside, nullptr).ok());
  EXPECT_EQ(warm_beside, warm_inline);
  EXPECT_NE(warm_beside, reference);  // the warm start went its own way
  options.device_smoothing = [](const MeshEdges&, int, std::vector<Vec3d>*) {
    return Status(StatusCode::kInternal, "device lost");
  };
  std::vector<uint32_t> label;
  EXPECT_FALSE(surface_cvt(mesh, mass, 900, options, &label, nullptr).ok());
}

}  // namespace
}  // namespace vpr
