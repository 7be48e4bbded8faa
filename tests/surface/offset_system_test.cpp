// The L2 fit's system built column by column in parallel and solved with
// parallel products (surface/offset_system.h) against the serial way it was built and
// solved: Eigen's triplets summed by setFromTriplets and its
// ConjugateGradient. Every entry, the right-hand side and the solution must
// be the same bits, on one thread and on several.
#include "surface/offset_system.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/Sparse>
#include <algorithm>
#include <array>
#include <cstring>
#include <random>
#include <vector>

#include "test_meshes.h"

namespace vpr {
namespace {

struct Fixture {
  std::vector<uint32_t> indices, face_start, faces_of;
  std::vector<int64_t> unknown;
  std::vector<OffsetFaceSums> per_face;
  std::vector<std::array<double, 3>> along;
  std::vector<double> offset;
  int64_t free_count = 0;
  OffsetSystemInput input() const {
    OffsetSystemInput in;
    in.indices = &indices;
    in.face_start = &face_start;
    in.faces_of = &faces_of;
    in.unknown = &unknown;
    in.per_face = &per_face;
    in.along = &along;
    in.offset = &offset;
    in.regularization = 1e-3;
    in.free_count = free_count;
    return in;
  }
};

// An icosphere's triangles with a degenerate one (a vertex twice) added, a
// fifth of the vertices held, a tenth of the faces without samples, and each
// face's sums from a few random samples (sum w b b^T, sum w b r, sum w b).
Fixture fixture(uint32_t seed) {
  Fixture f;
  const Mesh m = testing::icosphere(4);
  const size_t nv = m.vertex_count();
  f.indices = m.indices;
  f.indices.insert(f.indices.end(), {5, 5, 9});
  const size_t nf = f.indices.size() / 3;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1), sym(-1, 1);
  f.unknown.assign(nv, -1);
  for (size_t v = 0; v < nv; ++v)
    if (unit(rng) > 0.2) f.unknown[v] = f.free_count++;
  f.face_start.assign(nv + 1, 0);
  for (uint32_t v : f.indices) ++f.face_start[v + 1];
  for (size_t v = 0; v < nv; ++v) f.face_start[v + 1] += f.face_start[v];
  f.faces_of.resize(f.indices.size());
  std::vector<uint32_t> fill(f.face_start.begin(), f.face_start.end() - 1);
  for (size_t g = 0; g < nf; ++g)
    for (int c = 0; c < 3; ++c) f.faces_of[fill[f.indices[3 * g + c]]++] = uint32_t(g);
  f.per_face.assign(nf, OffsetFaceSums{});
  f.along.assign(nf, {0, 0, 0});
  for (size_t g = 0; g < nf; ++g) {
    if (unit(rng) < 0.1) continue;
    OffsetFaceSums& s = f.per_face[g];
    for (int sample = 0; sample < 4; ++sample) {
      double b[3] = {unit(rng), unit(rng), unit(rng)};
      const double total = b[0] + b[1] + b[2];
      const double w = unit(rng), r = sym(rng) * 1e-3;
      for (double& bk : b) bk /= total;
      for (int k = 0; k < 3; ++k) {
        for (int l = 0; l < 3; ++l) s[3 * k + l] += w * b[k] * b[l];
        s[9 + k] += w * b[k] * r;
        s[12 + k] += w * b[k];
      }
    }
    for (int k = 0; k < 3; ++k) f.along[g][k] = f.unknown[f.indices[3 * g + k]] >= 0 ? 0.5 + 0.5 * unit(rng) : 0.0;
  }
  f.offset.resize(nv);
  for (double& d : f.offset) d = sym(rng) * 1e-4;
  return f;
}

// The serial way: triplets face by face, the diagonal last, setFromTriplets.
Eigen::SparseMatrix<double> reference(const Fixture& f, Eigen::VectorXd* rhs) {
  const size_t nv = f.unknown.size(), nf = f.indices.size() / 3;
  std::vector<Eigen::Triplet<double>> entries;
  *rhs = Eigen::VectorXd::Zero(f.free_count);
  Eigen::VectorXd mass = Eigen::VectorXd::Zero(f.free_count);
  for (size_t g = 0; g < nf; ++g) {
    const OffsetFaceSums& s = f.per_face[g];
    if (!(s[12] + s[13] + s[14] > 0)) continue;
    const uint32_t* u = &f.indices[3 * g];
    for (int k = 0; k < 3; ++k) {
      const int64_t i = f.unknown[u[k]];
      if (i < 0) continue;
      (*rhs)[i] += f.along[g][k] * s[9 + k];
      mass[i] += s[12 + k];
      for (int l = 0; l < 3; ++l) {
        const double value = f.along[g][k] * f.along[g][l] * s[3 * k + l];
        if (f.unknown[u[l]] >= 0 && value != 0) entries.emplace_back(i, f.unknown[u[l]], value);
      }
    }
  }
  const double mean_mass = mass.sum() / double(f.free_count);
  for (size_t v = 0; v < nv; ++v) {
    const int64_t i = f.unknown[v];
    if (i < 0) continue;
    const double w = 1e-3 * std::max(mass[i], 1e-3 * mean_mass);
    entries.emplace_back(i, i, w);
    (*rhs)[i] -= w * f.offset[v];
  }
  Eigen::SparseMatrix<double> a(f.free_count, f.free_count);
  a.setFromTriplets(entries.begin(), entries.end());
  return a;
}

bool same_bits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

TEST(OffsetSystem, ColumnsAreTheTripletsSumsAndTheSolutionEigensOnAnyThreadCount) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    const Fixture f = fixture(seed);
    Eigen::VectorXd want_rhs;
    const Eigen::SparseMatrix<double> a = reference(f, &want_rhs);
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper> cg;
    cg.setTolerance(1e-10);
    cg.setMaxIterations(500);
    cg.compute(a);
    const Eigen::VectorXd want = cg.solve(want_rhs);
    ASSERT_EQ(cg.info(), Eigen::Success) << cg.iterations() << " iterations, error " << cg.error();
    ASSERT_GT(cg.iterations(), 3);  // a real solve, not a one-step one
    for (int threads : {1, 4}) {
      tbb::task_arena arena(threads);
      OffsetSystem system;
      Eigen::VectorXd e;
      bool solved = false;
      arena.execute([&] {
        system = offset_system(f.input());
        solved = solve_offset_system(system, &e);
      });
      ASSERT_TRUE(solved);
      ASSERT_EQ(system.column_start.size(), size_t(f.free_count) + 1);
      ASSERT_EQ(size_t(system.column_start.back()), size_t(a.nonZeros())) << "seed " << seed;
      // Column j: the reference's column j, row by row.
      for (int j = 0; j < a.outerSize(); ++j) {
        uint32_t e = system.column_start[j];
        for (Eigen::SparseMatrix<double>::InnerIterator it(a, j); it; ++it, ++e) {
          ASSERT_LT(e, system.column_start[j + 1]) << "column " << j;
          ASSERT_EQ(system.row[e], uint32_t(it.row())) << "column " << j;
          EXPECT_TRUE(same_bits(system.value[e], it.value()))
              << "(" << it.row() << ", " << j << ") threads " << threads;
        }
        EXPECT_EQ(e, system.column_start[j + 1]) << "column " << j;
      }
      for (int64_t i = 0; i < f.free_count; ++i) {
        ASSERT_TRUE(same_bits(system.rhs[i], want_rhs[i])) << "rhs " << i;
        ASSERT_TRUE(same_bits(e[i], want[i])) << "e " << i << ": " << e[i] << " against " << want[i];
      }
    }
  }
}

TEST(OffsetSystem, ColumnsAreSortedByRowWithOneDiagonalEach) {
  const Fixture f = fixture(7);
  const OffsetSystem system = offset_system(f.input());
  for (int64_t i = 0; i < f.free_count; ++i) {
    int diagonals = 0;
    for (uint32_t e = system.column_start[i]; e < system.column_start[i + 1]; ++e) {
      if (e > system.column_start[i]) EXPECT_LT(system.row[e - 1], system.row[e]);
      if (system.row[e] == uint32_t(i)) {
        ++diagonals;
        EXPECT_GT(system.value[e], 0);
      }
    }
    EXPECT_EQ(diagonals, 1) << "column " << i;
  }
}

TEST(OffsetSystem, AZeroRightHandSideGivesZeroOffsets) {
  Fixture f = fixture(4);
  for (OffsetFaceSums& s : f.per_face)
    for (int k = 0; k < 3; ++k) s[9 + k] = 0;
  std::fill(f.offset.begin(), f.offset.end(), 0.0);
  const OffsetSystem system = offset_system(f.input());
  Eigen::VectorXd e;
  ASSERT_TRUE(solve_offset_system(system, &e));
  ASSERT_EQ(e.size(), f.free_count);
  EXPECT_EQ(e.cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace vpr
