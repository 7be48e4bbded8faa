// The CVT's cells grown from their seeds (cell_growth.h): every element
// reached, each cell one piece holding its seed, the nearest seed by distance
// over the edges, one result on any thread count, bad seeds refused (the
// facing rule: surface_cvt_test's thin plates and parts). The GPU twin
// against this: tests/gpu.
#include "surface/cell_growth.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <set>
#include <vector>

#include "test_meshes.h"

namespace vpr {
namespace {

struct Surface {
  Mesh mesh;
  MeshEdges edges;
  std::vector<Vec3d> x, normal;
};

Surface sphere_surface() {
  Surface s;
  s.mesh = testing::icosphere(4);
  s.edges = mesh_edges(s.mesh);
  for (size_t v = 0; v < s.mesh.vertex_count(); ++v) {
    s.x.push_back(load3d(s.mesh.positions.data(), v));
    s.normal.push_back(s.x.back() * (1.0 / norm(s.x.back())));
  }
  return s;
}

std::vector<uint32_t> grow(const Surface& s, const std::vector<uint32_t>& seeds) {
  std::vector<uint32_t> label(s.x.size(), kNoCell);
  for (uint32_t c = 0; c < seeds.size(); ++c) label[seeds[c]] = c;
  CellGrowthInput in;
  in.edges = &s.edges;
  in.x = s.x.data();
  in.normal = s.normal.data();
  in.seeds = &seeds;
  EXPECT_TRUE(cpu::grow_cells(in, &label).ok());
  return label;
}

TEST(CellGrowth, EveryElementJoinsAWholeCellAroundItsSeed) {
  const Surface s = sphere_surface();  // 2,562 elements
  std::vector<uint32_t> seeds;
  for (uint32_t v = 0; v < s.x.size(); v += 97) seeds.push_back(v);
  const std::vector<uint32_t> label = grow(s, seeds);
  size_t unreached = 0, broken = 0, far = 0;
  std::vector<std::vector<uint32_t>> members(seeds.size());
  for (uint32_t v = 0; v < label.size(); ++v) {
    if (label[v] == kNoCell) {
      ++unreached;
      continue;
    }
    members[label[v]].push_back(v);
    // Graph distance is near the straight one here: no other seed is much nearer in space.
    for (uint32_t seed : seeds) far += norm(s.x[seed] - s.x[v]) < 0.5 * norm(s.x[seeds[label[v]]] - s.x[v]);
  }
  EXPECT_EQ(unreached, 0u);
  EXPECT_EQ(far, 0u);
  for (uint32_t c = 0; c < seeds.size(); ++c) {
    EXPECT_EQ(label[seeds[c]], c);
    std::set<uint32_t> seen = {seeds[c]};
    std::vector<uint32_t> stack = {seeds[c]};
    while (!stack.empty()) {
      const uint32_t v = stack.back();
      stack.pop_back();
      for (const uint32_t* w = s.edges.begin(v); w != s.edges.end(v); ++w)
        if (label[*w] == c && seen.insert(*w).second) stack.push_back(*w);
    }
    broken += seen.size() != members[c].size();
  }
  EXPECT_EQ(broken, 0u);
  for (int threads : {1, 3}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    EXPECT_EQ(grow(s, seeds), label) << threads << " threads";
  }
}

TEST(CellGrowth, RefusesSeedsThatAreNotTheirCellsElements) {
  const Surface s = sphere_surface();
  std::vector<uint32_t> seeds = {3, 50};
  std::vector<uint32_t> label(s.x.size(), kNoCell);
  label[3] = 0;  // seed 1 unlabelled
  CellGrowthInput in;
  in.edges = &s.edges;
  in.x = s.x.data();
  in.normal = s.normal.data();
  in.seeds = &seeds;
  const Status st = cpu::grow_cells(in, &label);
  EXPECT_EQ(st.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(st.message().find("seed 1"), std::string::npos) << st.message();
  seeds = {3, uint32_t(s.x.size())};
  EXPECT_FALSE(cpu::grow_cells(in, &label).ok());
}

}  // namespace
}  // namespace vpr
