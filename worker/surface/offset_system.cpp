#include "surface/offset_system.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>

namespace vpr {
namespace {

// Adds value to the column's entry in row, or appends one: the sums in the
// order their terms come, as setFromTriplets collapses duplicates.
void add_entry(uint32_t row, double value, uint32_t* rows, double* values, uint32_t* count) {
  for (uint32_t e = 0; e < *count; ++e)
    if (rows[e] == row) {
      values[e] += value;
      return;
    }
  rows[*count] = row;
  values[*count] = value;
  ++*count;
}

// tmp = A^T p, one column of A a term of tmp, in parallel; each from zero
// by ascending row. The matrix is symmetric up to rounding; Eigen's solver
// given a column-major matrix and Lower | Upper multiplies by its transpose
// (a row-major view, whose rows it sums so).
void multiply(const OffsetSystem& system, const Eigen::VectorXd& p, Eigen::VectorXd* tmp) {
  const size_t columns = system.column_start.size() - 1;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, columns, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t j = r.begin(); j != r.end(); ++j) {
      double sum = 0;
      for (uint32_t e = system.column_start[j]; e < system.column_start[j + 1]; ++e)
        sum += system.value[e] * p[system.row[e]];
      (*tmp)[j] = sum;
    }
  });
}

// Eigen's conjugate_gradient with its DiagonalPreconditioner, step for step
// (the same expressions, so the same reductions), with the parallel product.
bool conjugate_gradients(const OffsetSystem& system, const Eigen::VectorXd& rhs, Eigen::VectorXd* x) {
  const double tolerance = 1e-10;
  const int max_iterations = 500;
  const Eigen::Index n = rhs.size();
  Eigen::VectorXd invdiag(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    invdiag[i] = 1.0;
    for (uint32_t e = system.column_start[i]; e < system.column_start[i + 1]; ++e)
      if (system.row[e] == uint32_t(i) && system.value[e] != 0) invdiag[i] = 1.0 / system.value[e];
  }
  x->setZero(n);
  Eigen::VectorXd residual = rhs;  // rhs - A x with x = 0
  const double rhs_norm2 = rhs.squaredNorm();
  if (rhs_norm2 == 0) return true;
  const double threshold = std::max(tolerance * tolerance * rhs_norm2, std::numeric_limits<double>::min());
  double residual_norm2 = residual.squaredNorm();
  if (residual_norm2 < threshold) return true;
  Eigen::VectorXd p(n);
  p = invdiag.array() * residual.array();
  Eigen::VectorXd z(n), tmp(n);
  double abs_new = residual.dot(p);
  for (int i = 0; i < max_iterations; ++i) {
    multiply(system, p, &tmp);
    const double alpha = abs_new / p.dot(tmp);
    *x += alpha * p;
    residual -= alpha * tmp;
    residual_norm2 = residual.squaredNorm();
    if (residual_norm2 < threshold) break;
    z = invdiag.array() * residual.array();
    const double abs_old = abs_new;
    abs_new = residual.dot(z);
    const double beta = abs_new / abs_old;
    p = z + beta * p;
  }
  return std::sqrt(residual_norm2 / rhs_norm2) <= tolerance;
}

}  // namespace

OffsetSystem offset_system(const OffsetSystemInput& in) {
  const std::vector<uint32_t>& indices = *in.indices;
  const std::vector<uint32_t>& face_start = *in.face_start;
  const std::vector<uint32_t>& faces_of = *in.faces_of;
  const std::vector<int64_t>& unknown = *in.unknown;
  const size_t nv = unknown.size();
  // Each vertex's column in scratch: at most three entries per face it is a
  // corner of, and the diagonal.
  auto base = [&](size_t v) { return 3 * size_t(face_start[v]) + v; };
  std::vector<uint32_t> scratch_row(base(nv));
  std::vector<double> scratch_value(base(nv));
  std::vector<uint32_t> count(nv, 0);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(in.free_count), mass = Eigen::VectorXd::Zero(in.free_count);
  // fn(v, i, rows, values) for each free vertex v (column i) in parallel,
  // with its column's scratch.
  auto each_column = [&](auto&& fn) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 512), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v)
        if (unknown[v] >= 0) fn(v, unknown[v], &scratch_row[base(v)], &scratch_value[base(v)]);
    });
  };

  // Column i and the right-hand side's row i (vertex v): its faces in face
  // order (a face listed once per corner of v's is taken once), as the
  // triplets list them.
  each_column([&](size_t v, int64_t i, uint32_t* rows, double* values) {
    double row_rhs = 0, row_mass = 0;
    uint32_t previous = UINT32_MAX;
    for (uint32_t e = face_start[v]; e < face_start[v + 1]; ++e) {
      const uint32_t g = faces_of[e];
      if (g == previous) continue;
      previous = g;
      const OffsetFaceSums& s = (*in.per_face)[g];
      if (!face_has_samples(s)) continue;
      const uint32_t* u = &indices[3 * size_t(g)];
      const std::array<double, 3>& along = (*in.along)[g];
      for (int k = 0; k < 3; ++k)
        if (u[k] == v) {
          row_rhs += along[k] * s[9 + k];
          row_mass += s[12 + k];
        }
      // Column i's entries (k, l) with corner l at v, in the triplets'
      // order: corner k first, then l.
      for (int k = 0; k < 3; ++k) {
        if (unknown[u[k]] < 0) continue;
        for (int l = 0; l < 3; ++l) {
          if (u[l] != v) continue;
          const double value = along[k] * along[l] * s[3 * k + l];
          if (value != 0) add_entry(uint32_t(unknown[u[k]]), value, rows, values, &count[v]);
        }
      }
    }
    rhs[i] = row_rhs;
    mass[i] = row_mass;
  });

  // The regularization, last into each diagonal (a vertex no sample sees
  // still gets a positive one); then each column by row.
  const double mean_mass = mass.sum() / double(in.free_count);
  each_column([&](size_t v, int64_t i, uint32_t* rows, double* values) {
    const double w = in.regularization * std::max(mass[i], 1e-3 * mean_mass);
    add_entry(uint32_t(i), w, rows, values, &count[v]);
    rhs[i] -= w * (*in.offset)[v];
    for (uint32_t a = 1; a < count[v]; ++a)  // a few entries: insertion sort
      for (uint32_t b = a; b > 0 && rows[b - 1] > rows[b]; --b) {
        std::swap(rows[b - 1], rows[b]);
        std::swap(values[b - 1], values[b]);
      }
  });

  OffsetSystem out;
  out.column_start.assign(size_t(in.free_count) + 1, 0);
  for (size_t v = 0; v < nv; ++v)
    if (unknown[v] >= 0) out.column_start[size_t(unknown[v]) + 1] = count[v];
  for (size_t i = 0; i < size_t(in.free_count); ++i) out.column_start[i + 1] += out.column_start[i];
  out.row.resize(out.column_start.back());
  out.value.resize(out.column_start.back());
  each_column([&](size_t v, int64_t i, const uint32_t* rows, const double* values) {
    const uint32_t at = out.column_start[size_t(i)];
    std::copy_n(rows, count[v], &out.row[at]);
    std::copy_n(values, count[v], &out.value[at]);
  });
  out.rhs = std::move(rhs);
  return out;
}

bool solve_offset_system(const OffsetSystem& system, Eigen::VectorXd* e) {
  if (conjugate_gradients(system, system.rhs, e) && e->allFinite()) return true;
  const Eigen::Index n = system.rhs.size();
  Eigen::SparseMatrix<double> a(n, n);
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(system.value.size());
  for (Eigen::Index j = 0; j < n; ++j)
    for (uint32_t k = system.column_start[j]; k < system.column_start[j + 1]; ++k)
      entries.emplace_back(system.row[k], j, system.value[k]);
  a.setFromTriplets(entries.begin(), entries.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(a);
  if (ldlt.info() != Eigen::Success) return false;
  *e = ldlt.solve(system.rhs);
  return ldlt.info() == Eigen::Success;
}

}  // namespace vpr
