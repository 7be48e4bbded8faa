// The peer methods of worker/peers: each lands near the target vertex count,
// returns a valid compact mesh close to the input, and refuses bad input.
#include "peers/peers.h"

#include <gtest/gtest.h>

#include <cmath>

#include "eval/hausdorff.h"
#include "eval/mesh_quality.h"
#include "io/mesh_io.h"
#include "test_meshes.h"

namespace vpr {
namespace {

bool compact_and_valid(const Mesh& m) {
  if (!validate_mesh(m).ok()) return false;
  std::vector<bool> used(m.vertex_count(), false);
  for (uint32_t i : m.indices) used[i] = true;
  for (bool u : used)
    if (!u) return false;
  return true;
}

// Every face its own three vertices, winding kept: what an STL file holds.
Mesh unwelded(const Mesh& mesh) {
  Mesh soup;
  for (uint32_t i : mesh.indices) {
    soup.indices.push_back(uint32_t(soup.vertex_count()));
    soup.positions.insert(soup.positions.end(), &mesh.positions[3 * i], &mesh.positions[3 * i + 3]);
  }
  return soup;
}

TEST(Peers, EachLandsNearTheTargetOnAnUnweldedSphere) {
  const Mesh sphere = testing::icosphere(4);  // 2562 vertices, radius 1
  const Mesh soup = unwelded(sphere);
  for (const auto& peer : peers::all_peers()) {
    SCOPED_TRACE(peer.name);
    auto r = peer.run(soup, 600);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    EXPECT_TRUE(compact_and_valid(r->mesh));
    EXPECT_NEAR(double(r->mesh.vertex_count()), 600.0, 0.02 * 600) << r->note;
    EXPECT_EQ(mesh_quality(r->mesh).non_manifold_edges, 0u);
    EXPECT_TRUE(mesh_quality(r->mesh).closed);
    HausdorffOptions ho;
    ho.samples_per_mesh = 20000;
    auto h = hausdorff_distance(sphere, r->mesh, ho);
    ASSERT_TRUE(h.ok());
    // 600 vertices: edges of about 0.15, sagitta about 0.003 of the radius,
    // 0.001 of the diagonal (2 sqrt 3).
    EXPECT_LT(h->max, 0.005);
    EXPECT_GE(r->ms, r->core_ms);
  }
}

TEST(Peers, IsotropicRepairsAFlippedSoup) {
  const Mesh soup = testing::flipped_soup(testing::icosphere(4));
  auto r = peers::cgal_isotropic_remesh(soup, 600);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_NEAR(double(r->mesh.vertex_count()), 600.0, 12.0) << r->note;
  EXPECT_TRUE(mesh_quality(r->mesh).closed);
}

TEST(Peers, OpenMeshAndMeshoptHitTheTargetOnSpot) {
  auto spot = read_mesh("../shared/models/spot.obj");
  ASSERT_TRUE(spot.ok()) << spot.status().to_string();
  auto qem = peers::openmesh_quadric(*spot, 1000);
  ASSERT_TRUE(qem.ok());
  EXPECT_EQ(qem->mesh.vertex_count(), 1000u);
  EXPECT_EQ(mesh_quality(qem->mesh).non_manifold_edges, 0u);
  auto mo = peers::meshopt_simplify(*spot, 1000);
  ASSERT_TRUE(mo.ok());
  EXPECT_NEAR(double(mo->mesh.vertex_count()), 1000.0, 20.0) << mo->note;
  auto iso = peers::cgal_isotropic_remesh(*spot, 1000);
  ASSERT_TRUE(iso.ok()) << iso.status().to_string();
  EXPECT_NEAR(double(iso->mesh.vertex_count()), 1000.0, 20.0) << iso->note;
  EXPECT_EQ(mesh_quality(iso->mesh).non_manifold_edges, 0u);
  // Isotropic remeshing makes near-equilateral triangles; QEM does not try to.
  EXPECT_GT(mesh_quality(iso->mesh).min_angle_deg, 10.0);
}

TEST(Peers, RejectBadInputNamingTheMethod) {
  Mesh bad = testing::icosphere(1);
  bad.indices[4] = 999;
  for (const auto& peer : peers::all_peers()) {
    auto r = peer.run(bad, 20);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(r.status().message().find(peer.name), std::string::npos) << r.status().message();
  }
  for (const auto& peer : peers::all_peers()) EXPECT_FALSE(peer.run(testing::icosphere(1), 0).ok());
}

TEST(Peers, IsotropicSplitsAVertexSharedByTwoSpheres) {
  // Two spheres touching at one vertex: non-manifold there, fixed by splitting it.
  Mesh a = testing::icosphere(3), b = testing::icosphere(3);
  const float* p0 = &a.positions[0];
  Mesh both = a;
  const uint32_t offset = uint32_t(a.vertex_count());
  for (size_t v = 0; v < b.vertex_count(); ++v)
    for (int k = 0; k < 3; ++k) both.positions.push_back(b.positions[3 * v + k] + 2 * p0[k]);
  for (uint32_t i : b.indices) both.indices.push_back(i + offset);
  // b's antipode of its vertex 0 sits at 2*p0 - p0 = p0: weld it to a's vertex 0 by index.
  uint32_t touching = 0;
  for (size_t v = 0; v < b.vertex_count(); ++v)
    if (std::abs(b.positions[3 * v] + p0[0]) < 1e-6f && std::abs(b.positions[3 * v + 1] + p0[1]) < 1e-6f &&
        std::abs(b.positions[3 * v + 2] + p0[2]) < 1e-6f)
      touching = uint32_t(v);
  for (uint32_t& i : both.indices)
    if (i == touching + offset) i = 0;
  ASSERT_GT(mesh_quality(both).non_manifold_vertices, 0u);
  auto r = peers::cgal_isotropic_remesh(both, 400);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_NE(r->note.find("split"), std::string::npos) << r->note;
  EXPECT_NEAR(double(r->mesh.vertex_count()), 400.0, 8.0) << r->note;
}

TEST(Peers, IsotropicRefusesAnEdgeSharedByThreeFacesClearly) {
  // Three triangles on one edge (a "book"): orient_polygon_soup splits it into
  // sheets, so this must either succeed with a note or fail naming the problem.
  Mesh book;
  book.positions = {0, 0, 0, 0, 0, 1, 1, 0, 0, -1, 0, 0, 0, 1, 0};
  book.indices = {0, 1, 2, 0, 1, 3, 0, 1, 4};
  auto r = peers::cgal_isotropic_remesh(book, 100);
  if (r.ok()) {
    EXPECT_EQ(mesh_quality(r->mesh).non_manifold_edges, 0u);
    EXPECT_FALSE(r->note.empty());
  } else {
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(r.status().message().find("2-manifold"), std::string::npos) << r.status().message();
  }
}

}  // namespace
}  // namespace vpr
