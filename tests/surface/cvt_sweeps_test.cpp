// The CVT's sweeps in colour rounds (cvt_sweeps.h), the form its GPU twin
// runs: the colouring, the rounds' moves (E falls, cells stay whole, loop
// elements stay put, one result on any thread count), and surface_cvt
// finishing from them. The GPU twin's labels against these: tests/gpu.
#include "surface/cvt_sweeps.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <set>
#include <vector>

#include "surface/cvt_sweep_kernels.h"
#include "surface/cvt_sweeps_setup.h"
#include "surface/surface_cvt.h"
#include "test_meshes.h"

namespace vpr {
namespace {

// A surface with its elements' arrays as surface_cvt makes them (isotropic
// here: y = 0), and its cells after seeding and growth, before any sweep.
struct Problem {
  Mesh mesh;
  MeshEdges edges;
  std::vector<Vec3d> x, y, normal;
  std::vector<double> mass;
  std::vector<char> on_loop;
  std::vector<uint32_t> start;
  uint32_t cells = 0;

  CvtSweepInput input() const {
    CvtSweepInput in;
    in.edges = &edges;
    in.x = x.data();
    in.y = y.data();
    in.normal = normal.data();
    in.mass = mass.data();
    in.on_loop = on_loop.data();
    in.cells = cells;
    for (size_t v = 0; v < x.size(); ++v) in.constant += mass[v] * dot(x[v], x[v]);
    return in;
  }
};

// An icosphere with the faces above z_cut left out (z_cut > 1: closed); its
// elements weigh more toward +x, so the cells differ in size.
Problem make_problem(int level, double z_cut, uint32_t cells) {
  Problem p;
  const Mesh sphere = testing::icosphere(level);
  p.mesh.positions = sphere.positions;
  for (size_t f = 0; f < sphere.face_count(); ++f) {
    double z = 0;
    for (int k = 0; k < 3; ++k) z += sphere.positions[3 * sphere.indices[3 * f + k] + 2] / 3.0;
    if (z < z_cut) p.mesh.indices.insert(p.mesh.indices.end(), &sphere.indices[3 * f], &sphere.indices[3 * f + 3]);
  }
  p.edges = mesh_edges(p.mesh);
  const size_t nv = p.mesh.vertex_count();
  p.x.resize(nv);
  p.y.assign(nv, Vec3d{0, 0, 0});
  p.normal.resize(nv);
  p.mass = vertex_areas(p.mesh);
  p.on_loop.assign(nv, 0);
  for (uint32_t v = 0; v < nv; ++v) {
    p.x[v] = load3d(p.mesh.positions.data(), v);
    p.normal[v] = p.x[v] * (1.0 / norm(p.x[v]));
    p.mass[v] *= 1.0 + 3.0 * (p.x[v].x + 1.0);
    for (uint32_t i = p.edges.offset[v]; i < p.edges.offset[v + 1]; ++i) p.on_loop[v] |= p.edges.faces[i] == 1;
  }
  CvtOptions seeds;
  seeds.max_sweeps = 0;
  seeds.topology_rounds = 0;
  CvtStats stats;
  EXPECT_TRUE(surface_cvt(p.mesh, p.edges, p.mass, cells, seeds, &p.start, &stats).ok());
  p.cells = stats.clusters;
  return p;
}

// Every cell holds elements, and they are one piece over the mesh's edges.
void expect_cells_whole(const Problem& p, const std::vector<uint32_t>& label) {
  std::vector<std::vector<uint32_t>> members(p.cells);
  for (uint32_t v = 0; v < label.size(); ++v)
    if (label[v] != kNoCell) members[label[v]].push_back(v);
  size_t broken = 0, empty = 0;
  for (uint32_t c = 0; c < p.cells; ++c) {
    if (members[c].empty()) {
      ++empty;
      continue;
    }
    std::set<uint32_t> seen = {members[c][0]};
    std::vector<uint32_t> stack = {members[c][0]};
    while (!stack.empty()) {
      const uint32_t v = stack.back();
      stack.pop_back();
      for (const uint32_t* w = p.edges.begin(v); w != p.edges.end(v); ++w)
        if (label[*w] == c && seen.insert(*w).second) stack.push_back(*w);
    }
    broken += seen.size() != members[c].size();
  }
  EXPECT_EQ(empty, 0u);
  EXPECT_EQ(broken, 0u);
}

TEST(CvtColourSweeps, NoTwoNeighboursShareAColour) {
  const Problem p = make_problem(4, 0.6, 150);
  uint32_t colours = 0;
  auto colour = cpu::cvt_colouring(p.edges, &colours);
  ASSERT_TRUE(colour.ok()) << colour.status().to_string();
  size_t clashes = 0, high = 0;
  for (uint32_t v = 0; v < p.x.size(); ++v) {
    high += (*colour)[v] >= colours;
    for (const uint32_t* w = p.edges.begin(v); w != p.edges.end(v); ++w) clashes += (*colour)[*w] == (*colour)[v];
  }
  EXPECT_EQ(clashes, 0u);
  EXPECT_EQ(high, 0u);  // degree 6 at most: every element gets a colour the rounds move
  EXPECT_GE(colours, 3u);
  EXPECT_LE(colours, 7u);  // at most one more than the largest degree
}

// The rounds lower E, leave every cell one piece and the loop's elements
// where they were, and give the same labels on any thread count.
TEST(CvtColourSweeps, RoundsLowerTheEnergyAndKeepEveryCellWhole) {
  const Problem p = make_problem(5, 0.6, 300);  // 10,242 elements, an opening
  ASSERT_EQ(p.cells, 300u);
  std::vector<uint32_t> label = p.start;
  CvtSweepOutput out;
  ASSERT_TRUE(cpu::cvt_colour_sweeps(p.input(), &label, &out).ok());
  EXPECT_TRUE(out.converged);
  EXPECT_GE(out.sweeps, 3);
  EXPECT_GT(out.moves, 300u);
  ASSERT_EQ(out.energy.size(), size_t(out.sweeps));
  CvtSweepOutput none;
  std::vector<uint32_t> unmoved = p.start;
  CvtSweepInput zero = p.input();
  zero.max_sweeps = 0;
  ASSERT_TRUE(cpu::cvt_colour_sweeps(zero, &unmoved, &none).ok());
  EXPECT_EQ(unmoved, p.start);
  // E at the start, from the same sums: the first sweep's E is below it, the last well below.
  double start = zero.constant;
  {
    std::vector<double> m(p.cells), sx(p.cells), sy(p.cells), sz(p.cells);
    for (uint32_t v = 0; v < p.x.size(); ++v) {
      const uint32_t c = p.start[v];
      if (c == kNoCell) continue;
      m[c] += p.mass[v], sx[c] += p.mass[v] * p.x[v].x, sy[c] += p.mass[v] * p.x[v].y, sz[c] += p.mass[v] * p.x[v].z;
    }
    for (uint32_t c = 0; c < p.cells; ++c) start -= (sx[c] * sx[c] + sy[c] * sy[c] + sz[c] * sz[c]) / m[c];
  }
  EXPECT_LT(out.energy.front(), start);
  EXPECT_LT(out.energy.back(), 0.95 * start) << out.energy.back() / start;
  expect_cells_whole(p, label);
  // The loop's elements moved only along it: each cell keeps the loop
  // elements it had, less or more, but meets the loop iff it did.
  std::set<uint32_t> on_before, on_after;
  size_t loop_moves = 0;
  for (uint32_t v = 0; v < label.size(); ++v)
    if (p.on_loop[v]) {
      on_before.insert(p.start[v]);
      on_after.insert(label[v]);
      loop_moves += label[v] != p.start[v];
    }
  EXPECT_GT(on_before.size(), 10u);
  EXPECT_EQ(on_after, on_before);
  EXPECT_GT(loop_moves, 0u);
  for (int threads : {1, 3}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<uint32_t> again = p.start;
    CvtSweepOutput again_out;
    ASSERT_TRUE(cpu::cvt_colour_sweeps(p.input(), &again, &again_out).ok());
    EXPECT_EQ(again, label) << threads << " threads";
    EXPECT_EQ(again_out.energy, out.energy) << threads << " threads";
  }
}

// The rounds weigh only elements with a neighbour in another cell
// (cvt_on_cell_edge): every element they skip is one cvt_best_move would
// not move, on the start's cells and on cells scattered at random (where
// most elements lie on some cell's edge), with and without the loop rule.
TEST(CvtColourSweeps, ElementsInsideTheirCellsHaveNoMove) {
  const Problem p = make_problem(4, 0.6, 60);
  const CvtSweepInput in = p.input();
  const uint32_t nv = uint32_t(p.x.size());
  std::vector<uint32_t> scattered(nv);
  uint64_t state = 12345;
  for (uint32_t v = 0; v < nv; ++v) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    const bool moved = p.start[v] != kNoCell && (state >> 40) % 4 == 0;  // elements without mass keep no cell
    scattered[v] = moved ? uint32_t((state >> 20) % p.cells) : p.start[v];
  }
  for (const std::vector<uint32_t>* label : {&p.start, static_cast<const std::vector<uint32_t>*>(&scattered)}) {
    std::vector<long long> sums(size_t(p.cells) * kCvtSums, 0);
    std::vector<uint32_t> size(p.cells, 0);
    const CvtFixedScale scale = cvt_fixed_scale(in, *label);
    for (uint32_t v = 0; v < nv; ++v) {
      if ((*label)[v] == kNoCell) continue;
      long long c[kCvtSums];
      cvt_contribution(p.mass[v], p.x[v], p.y[v], p.normal[v], scale, c);
      for (int k = 0; k < kCvtSums; ++k) sums[size_t((*label)[v]) * kCvtSums + k] += c[k];
      ++size[(*label)[v]];
    }
    size_t inside = 0, edge = 0, moves = 0;
    for (uint32_t v = 0; v < nv; ++v) {
      long long c[kCvtSums];
      cvt_contribution(p.mass[v], p.x[v], p.y[v], p.normal[v], scale, c);
      for (bool on_loop : {false, true}) {
        const uint32_t best =
            cvt_best_move(p.edges.offset.data(), p.edges.neighbor.data(), p.edges.faces.data(), label->data(),
                          sums.data(), size.data(), scale, cvt_sums(c, scale), p.normal[v], on_loop, v, 0.0);
        if (cvt_on_cell_edge(p.edges.offset.data(), p.edges.neighbor.data(), label->data(), v)) {
          edge += !on_loop;
          moves += best != kNoCell;
        } else {
          inside += !on_loop;
          EXPECT_EQ(best, kNoCell) << "element " << v;
        }
      }
    }
    EXPECT_GT(inside, 100u);
    EXPECT_GT(edge, 100u);
    EXPECT_GT(moves, 10u);  // the rule is not vacuous: edge elements do move
  }
}

TEST(CvtColourSweeps, LabelsOutsideTheCellsAreRefused) {
  const Problem p = make_problem(3, 2.0, 40);
  std::vector<uint32_t> label = p.start;
  label[5] = p.cells;
  CvtSweepOutput out;
  const Status s = cpu::cvt_colour_sweeps(p.input(), &label, &out);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("outside its 40 cells"), std::string::npos) << s.message();
  std::vector<uint32_t> short_labels(p.start.begin(), p.start.end() - 1);
  EXPECT_FALSE(cpu::cvt_colour_sweeps(p.input(), &short_labels, &out).ok());
}

// surface_cvt with colour rounds before its own sweeps (as on a GPU): the
// count exactly, a manifold dual, E within 2% of the CPU's sweeps alone, few
// sweeps of its own after the rounds, one result on any thread count; an
// error from the rounds is the CVT's error.
TEST(CvtColourSweeps, SurfaceCvtFinishesFromTheRounds) {
  const Problem p = make_problem(5, 0.6, 300);
  CvtOptions plain;
  plain.anisotropy = 0.05;
  CvtOptions rounds = plain;
  int calls = 0;
  rounds.device_sweeps = [&calls](const CvtSweepInput& in, std::vector<uint32_t>* label, CvtSweepOutput* out) {
    ++calls;
    return cpu::cvt_colour_sweeps(in, label, out);
  };
  std::vector<uint32_t> a, b;
  CvtStats sa, sb;
  ASSERT_TRUE(surface_cvt(p.mesh, p.edges, p.mass, 300, plain, &a, &sa).ok());
  ASSERT_TRUE(surface_cvt(p.mesh, p.edges, p.mass, 300, rounds, &b, &sb).ok());
  EXPECT_GE(calls, 1);
  EXPECT_EQ(sa.device_sweeps, 0u);
  EXPECT_GE(sb.device_sweeps, 3u);
  // The CPU's sweeps after the rounds: at most half as many as alone (13
  // here; 6 after the rounds, which move the loop's elements only along it).
  EXPECT_LE(2 * (size_t(sb.sweeps) - sb.device_sweeps), size_t(sa.sweeps)) << sb.sweeps << " sweeps in all";
  EXPECT_EQ(sb.clusters, 300u);
  EXPECT_EQ(sb.defective_cells, 0u);
  EXPECT_LT(sb.energy.back(), 1.02 * sa.energy.back()) << sb.energy.back() / sa.energy.back();
  EXPECT_NE(a, b);  // another path to another local minimum
  for (int threads : {1, 3}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<uint32_t> again;
    CvtStats s;
    ASSERT_TRUE(surface_cvt(p.mesh, p.edges, p.mass, 300, rounds, &again, &s).ok());
    EXPECT_EQ(again, b) << threads << " threads";
  }
  CvtOptions failing = plain;
  failing.device_sweeps = [](const CvtSweepInput&, std::vector<uint32_t>*, CvtSweepOutput*) {
    return resource_exhausted("device memory: test");
  };
  std::vector<uint32_t> c;
  CvtStats sc;
  EXPECT_EQ(surface_cvt(p.mesh, p.edges, p.mass, 300, failing, &c, &sc).code(), StatusCode::kResourceExhausted);
}

}  // namespace
}  // namespace vpr
