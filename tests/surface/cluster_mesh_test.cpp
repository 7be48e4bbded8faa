// Parts of mesh_clusters (cluster_mesh.h) made apart or skipped where they
// cannot matter. The dual's facts of the surface alone (dual_surface), which
// the pipeline makes while a GPU runs the CVT's sweeps: its boundary and
// sharp edges and the faces' planes are right on a shape whose answers are
// known, and mesh_clusters gives the same bits with them made beforehand
// (with or without the planes, per-cell sums or the one loop) as without
// them. Cells whose points fall within a thousandth of a spacing of each
// other: found (the in-order pass runs only when some pair is that close)
// and moved apart. The projections onto the cells' faces made by a projector
// over the flat lists a device is given (flat_projector.h): the host's bits,
// and the host's mesh when the projector fails at any step.
#include "surface/cluster_mesh.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "flat_projector.h"
#include "surface/mesh_edges.h"
#include "surface/surface_cvt.h"
#include "test_meshes.h"

namespace vpr {
namespace {

// A unit cube without its top (z = 1), each side an n x n grid of squares cut
// into two triangles, outward, corners shared between sides: one boundary
// loop of 4n edges and 8n edges on its eight right-angled creases.
Mesh open_box(int n) {
  Mesh m;
  std::map<std::tuple<int, int, int>, uint32_t> index;  // grid point (in 1/n) -> vertex
  auto vertex = [&](int i, int j, int k) {
    const auto key = std::make_tuple(i, j, k);
    auto it = index.find(key);
    if (it != index.end()) return it->second;
    const uint32_t v = uint32_t(m.vertex_count());
    for (int c : {i, j, k}) m.positions.push_back(float(c) / float(n));
    index.emplace(key, v);
    return v;
  };
  // The sides x = 0, x = 1, y = 0, y = 1 and z = 0; each triangle turned
  // outwards (away from the cube's centre).
  for (const std::pair<int, int>& side : {std::pair{2, 0}, std::pair{0, 0}, std::pair{0, 1}, std::pair{1, 0}, std::pair{1, 1}}) {
    const int axis = side.first, at = side.second;  // lambdas cannot capture structured bindings in C++17
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        auto point = [&](int da, int db) {
          int p[3];
          p[axis] = at * n;
          p[(axis + 1) % 3] = a + da;
          p[(axis + 2) % 3] = b + db;
          return vertex(p[0], p[1], p[2]);
        };
        const uint32_t q[4] = {point(0, 0), point(1, 0), point(1, 1), point(0, 1)};
        for (const std::array<uint32_t, 3>& t : {std::array<uint32_t, 3>{q[0], q[1], q[2]}, {q[0], q[2], q[3]}}) {
          const Vec3d p0 = load3d(m.positions.data(), t[0]), p1 = load3d(m.positions.data(), t[1]),
                      p2 = load3d(m.positions.data(), t[2]);
          const bool out = dot(cross(p1 - p0, p2 - p0), p0 - Vec3d{0.5, 0.5, 0.5}) > 0;
          for (uint32_t v : {t[0], out ? t[1] : t[2], out ? t[2] : t[1]}) m.indices.push_back(v);
        }
      }
  }
  return m;
}

TEST(DualSurfaceTest, BoundaryCreasesAndPlanesOfAnOpenBox) {
  const int n = 12;
  const Mesh box = open_box(n);
  const MeshEdges edges = mesh_edges(box);
  const DualSurface facts = dual_surface(box, edges, true);
  ASSERT_EQ(facts.on_boundary.size(), 3 * box.face_count());
  size_t boundary = 0;
  for (char b : facts.on_boundary) boundary += b != 0;
  EXPECT_EQ(boundary, size_t(4 * n));
  // Sharp: the four upright edges and the four of the bottom, none on the rim
  // (one face) and none inside a side (flat).
  EXPECT_EQ(facts.sharp_edges.size(), size_t(8 * n));
  for (const auto& [u, w] : facts.sharp_edges) {
    EXPECT_LT(u, w);
    int on_faces = 0;  // coordinates at 0 or 1 that both ends share: two on a crease
    for (int k = 0; k < 3; ++k) {
      const float a = box.positions[3 * u + k], b = box.positions[3 * w + k];
      on_faces += a == b && (a == 0.0f || a == 1.0f);
    }
    EXPECT_EQ(on_faces, 2) << u << " " << w;
  }
  // Planes: unit normals pointing out of the box, five unit sides of area.
  ASSERT_EQ(facts.normal.size(), box.face_count());
  double area = 0;
  for (size_t f = 0; f < box.face_count(); ++f) {
    area += facts.area[f];
    EXPECT_NEAR(norm(facts.normal[f]), 1.0, 1e-12);
    const uint32_t* t = &box.indices[3 * f];
    const Vec3d centroid = (load3d(box.positions.data(), t[0]) + load3d(box.positions.data(), t[1]) +
                            load3d(box.positions.data(), t[2])) *
                           (1.0 / 3);
    EXPECT_GT(dot(facts.normal[f], centroid - Vec3d{0.5, 0.5, 0.5}), 0.0) << "face " << f;
  }
  EXPECT_NEAR(area, 5.0, 1e-9);
  // Without planes: none.
  const DualSurface bare = dual_surface(box, edges, false);
  EXPECT_TRUE(bare.normal.empty());
  EXPECT_EQ(bare.on_boundary, facts.on_boundary);
  EXPECT_EQ(bare.sharp_edges, facts.sharp_edges);
}

TEST(DualSurfaceTest, FactsMadeBeforehandGiveTheSameMesh) {
  const Mesh box = open_box(24);
  const MeshEdges edges = mesh_edges(box);
  std::vector<uint32_t> label;
  CvtStats cvt;
  CvtOptions cvt_options;
  cvt_options.anisotropy = 0.04 * std::sqrt(3.0);
  ASSERT_TRUE(surface_cvt(box, edges, vertex_areas(box), 300, cvt_options, &label, &cvt).ok());
  const DualSurface with_planes = dual_surface(box, edges, true), bare = dual_surface(box, edges, false);
  for (int per_cell : {0, 1}) {
    ClusterMeshOptions options;
    options.per_cell_sums = per_cell;
    Mesh reference;
    std::vector<uint32_t> reference_cells;
    ClusterMeshStats stats;
    ASSERT_TRUE(mesh_clusters(box, edges, label, cvt.clusters, &reference, &reference_cells, &stats, options).ok());
    ASSERT_GT(reference.face_count(), 500u);
    EXPECT_EQ(stats.boundary_loops, 1u);
    for (const DualSurface* facts : {&with_planes, &bare}) {
      options.surface_facts = facts;
      Mesh out;
      std::vector<uint32_t> cells;
      ASSERT_TRUE(mesh_clusters(box, edges, label, cvt.clusters, &out, &cells, nullptr, options).ok());
      EXPECT_EQ(out.positions, reference.positions) << "per cell " << per_cell << ", planes " << !facts->normal.empty();
      EXPECT_EQ(out.indices, reference.indices) << "per cell " << per_cell << ", planes " << !facts->normal.empty();
      EXPECT_EQ(cells, reference_cells);
    }
  }
  // The facts of another surface are refused, naming the problem.
  const Mesh other = open_box(6);
  const DualSurface wrong = dual_surface(other, mesh_edges(other), false);
  ClusterMeshOptions options;
  options.surface_facts = &wrong;
  Mesh out;
  const Status s = mesh_clusters(box, edges, label, cvt.clusters, &out, nullptr, nullptr, options);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("another surface"), std::string::npos) << s.to_string();
  // Facts of the right size whose sharp edges name vertices the surface does
  // not have: refused, never read out of bounds.
  DualSurface forged = dual_surface(box, edges, false);
  forged.sharp_edges.push_back({uint32_t(box.vertex_count()), uint32_t(box.vertex_count() + 7)});
  options.surface_facts = &forged;
  const Status f = mesh_clusters(box, edges, label, cvt.clusters, &out, nullptr, nullptr, options);
  EXPECT_EQ(f.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(f.message().find("sharp edge"), std::string::npos) << f.to_string();
}

// A flat n x n grid of unit squares in z = 0, two triangles each.
Mesh grid(int n) {
  Mesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      for (float c : {float(i), float(j), 0.0f}) m.positions.push_back(c);
  auto at = [n](int i, int j) { return uint32_t(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      for (uint32_t v : {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)})
        m.indices.push_back(v);
  return m;
}

// Cells on a grid: 0 a ring round (cx, cy) (from 1.2 to 4 squares out), 1
// the disk inside it, then the rest by quadrant about the grid's middle.
// About a grid point both have their centroid there, and both touch it: the
// ring through the faces between its inner vertices and the disk's.
std::vector<uint32_t> ring_and_disk(const Mesh& m, double cx, double cy, double mid) {
  std::vector<uint32_t> label(m.vertex_count());
  for (size_t v = 0; v < label.size(); ++v) {
    const double x = m.positions[3 * v], y = m.positions[3 * v + 1];
    const double r = std::hypot(x - cx, y - cy);
    label[v] = r < 1.2 ? 1u : r < 4 ? 0u : 2u + (x >= mid ? 1u : 0u) + (y >= mid ? 2u : 0u);
  }
  return label;
}

TEST(ClusterMeshTest, CellsAtOnePointAreMovedApartAndOnlyThen) {
  const Mesh flat = grid(24);
  const MeshEdges edges = mesh_edges(flat);
  ClusterMeshOptions options;
  options.relax_rounds = 0;
  options.offset.enabled = false;
  // The ring and the disk about the grid point (8, 8): both cells' points
  // land on it, so the disk's (the later cell) moves to its nearest element
  // clear of the ring's. (The disk meets no third cell, so the dual leaves
  // it out; what is counted is the move.)
  {
    Mesh out;
    ClusterMeshStats stats;
    ASSERT_TRUE(mesh_clusters(flat, edges, ring_and_disk(flat, 8, 8, 12), 6, &out, nullptr, &stats, options).ok());
    EXPECT_EQ(stats.points_separated, 1u);
    EXPECT_GT(out.face_count(), 0u);
  }
  // About (8.5, 8.25), off the grid points, the disk's centroid and the
  // ring's differ: nothing moves.
  {
    Mesh out;
    ClusterMeshStats stats;
    ASSERT_TRUE(mesh_clusters(flat, edges, ring_and_disk(flat, 8.5, 8.25, 12), 6, &out, nullptr, &stats, options).ok());
    EXPECT_EQ(stats.points_separated, 0u);
    EXPECT_GT(out.face_count(), 0u);
  }
}

// A surface and its CVT cells, for the projection tests.
struct Cells {
  Mesh surface;
  MeshEdges edges;
  std::vector<uint32_t> label;
  uint32_t count = 0;
};

Cells cells_of(Mesh surface, uint32_t target, double anisotropy) {
  Cells c;
  c.surface = std::move(surface);
  c.edges = mesh_edges(c.surface);
  CvtStats cvt;
  CvtOptions options;
  if (anisotropy >= 0) options.anisotropy = anisotropy;
  EXPECT_TRUE(surface_cvt(c.surface, c.edges, vertex_areas(c.surface), target, options, &c.label, &cvt).ok());
  c.count = cvt.clusters;
  return c;
}

// An open box (a boundary loop, creases, corners) and a torus 10^4 units
// from the origin, where floats have few bits to spare.
std::vector<Cells> projection_cases() {
  Mesh far = testing::torus(1.0, 0.35, 64, 128);
  for (size_t i = 0; i < far.positions.size(); i += 3) far.positions[i] += 2e5f;
  std::vector<Cells> cases;
  cases.push_back(cells_of(open_box(24), 300, 0.04 * std::sqrt(3.0)));
  cases.push_back(cells_of(std::move(far), 600, -1));
  return cases;
}

TEST(ClusterMeshTest, ProjectionsOverFlatListsGiveTheHostsBits) {
  for (const Cells& c : projection_cases()) {
    ASSERT_GT(c.count, 250u);
    Mesh reference, unrelaxed;
    std::vector<uint32_t> reference_cells;
    ClusterMeshStats host_stats;
    ASSERT_TRUE(mesh_clusters(c.surface, c.edges, c.label, c.count, &reference, &reference_cells, &host_stats).ok());
    EXPECT_FALSE(host_stats.projected_on_device);
    EXPECT_TRUE(host_stats.projection_fallback.empty());
    ClusterMeshOptions bare;
    bare.relax_rounds = 0;
    ASSERT_TRUE(mesh_clusters(c.surface, c.edges, c.label, c.count, &unrelaxed, nullptr, nullptr, bare).ok());
    EXPECT_NE(unrelaxed.positions, reference.positions) << "the relaxation moves vertices";

    testing::ProjectorCalls calls;
    ClusterMeshOptions options;
    options.device_projector = [&](const CellFaceLists& lists) -> StatusOr<std::unique_ptr<DualProjector>> {
      EXPECT_EQ(lists.start->size(), size_t(c.count) + 1);
      return std::unique_ptr<DualProjector>(std::make_unique<testing::FlatProjector>(lists, -1, &calls));
    };
    Mesh out;
    std::vector<uint32_t> cells;
    ClusterMeshStats stats;
    ASSERT_TRUE(mesh_clusters(c.surface, c.edges, c.label, c.count, &out, &cells, &stats, options).ok());
    EXPECT_EQ(calls.places, 1);
    EXPECT_EQ(calls.relaxes, options.relax_rounds);
    EXPECT_TRUE(stats.projected_on_device);
    EXPECT_EQ(out.positions, reference.positions);
    EXPECT_EQ(out.indices, reference.indices);
    EXPECT_EQ(cells, reference_cells);
  }
}

TEST(ClusterMeshTest, AProjectorThatFailsLeavesTheHostTheSameMesh) {
  const Cells c = projection_cases().front();
  Mesh reference;
  ASSERT_TRUE(mesh_clusters(c.surface, c.edges, c.label, c.count, &reference, nullptr, nullptr).ok());
  // Refused at once, at the placing, and at the second relaxation round.
  for (int fail_at : {-2, 0, 2}) {
    testing::ProjectorCalls calls;
    ClusterMeshOptions options;
    options.device_projector = [&](const CellFaceLists& lists) -> StatusOr<std::unique_ptr<DualProjector>> {
      if (fail_at == -2) return resource_exhausted("no device (test)");
      return std::unique_ptr<DualProjector>(std::make_unique<testing::FlatProjector>(lists, fail_at, &calls));
    };
    Mesh out;
    ClusterMeshStats stats;
    ASSERT_TRUE(mesh_clusters(c.surface, c.edges, c.label, c.count, &out, nullptr, &stats, options).ok());
    EXPECT_FALSE(stats.projected_on_device) << fail_at;
    EXPECT_NE(stats.projection_fallback.find(fail_at == -2 ? "no device" : "refused"), std::string::npos)
        << stats.projection_fallback;
    EXPECT_EQ(calls.places, fail_at == 2 ? 1 : 0);
    EXPECT_EQ(calls.relaxes, fail_at == 2 ? 1 : 0);
    EXPECT_EQ(out.positions, reference.positions) << fail_at;
    EXPECT_EQ(out.indices, reference.indices) << fail_at;
  }
}

}  // namespace
}  // namespace vpr
