// The L2 fit's normal equations (offset_fit.h) in compressed columns, built
// column by column in parallel, and their conjugate gradients with the
// product's terms in parallel.
//
// Both give Eigen's bits: each entry (i, j) is the sum of its faces' terms in
// face order with the regularization last, as SparseMatrix::setFromTriplets
// sums the fit's triplets (listed face by face, then the diagonal); the
// product's term j sums column j by ascending row from zero, as Eigen's
// solver multiplies (by the transpose of a column-major matrix given with
// Lower | Upper: a row-major view); and the vector steps are
// Eigen's own expressions in the order of its ConjugateGradient with the
// diagonal preconditioner (IterativeLinearSolvers, Eigen 3.4). So the offsets
// are the same on any thread count, and the same as the serial solver's.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "surface/offset_match.h"

namespace vpr {

struct OffsetSystemInput {
  const std::vector<uint32_t>* indices = nullptr;     // output triangles
  const std::vector<uint32_t>* face_start = nullptr;  // faces around each output vertex (CSR, one per corner)
  const std::vector<uint32_t>* faces_of = nullptr;    // in face order
  const std::vector<int64_t>* unknown = nullptr;      // per vertex, its row, or -1 (held)
  const std::vector<OffsetFaceSums>* per_face = nullptr;
  // Per face, N_k . n_t for its corners (0 for a held one); read only where
  // the face has samples (face_has_samples).
  const std::vector<std::array<double, 3>>* along = nullptr;
  const std::vector<double>* offset = nullptr;  // per vertex, the offsets so far
  double regularization = 0;
  int64_t free_count = 0;
};

// A face's samples weigh something: it enters the system.
inline bool face_has_samples(const OffsetFaceSums& s) {
  return s[12] + s[13] + s[14] > 0;
}

// (A^T W A + lambda D) in columns: column j's rows ascending. Symmetric up
// to rounding (entry (i, j) sums w b_k b_l, (j, i) w b_l b_k).
struct OffsetSystem {
  std::vector<uint32_t> column_start;  // free_count + 1
  std::vector<uint32_t> row;
  std::vector<double> value;
  Eigen::VectorXd rhs;  // A^T W r - lambda D d
};

OffsetSystem offset_system(const OffsetSystemInput& in);

// Solves system e = rhs: conjugate gradients down to 1e-10 of the right-hand
// side's residual, at most 500 iterations; should they not converge, the
// sparse Cholesky factorization. False when neither solves it.
bool solve_offset_system(const OffsetSystem& system, Eigen::VectorXd* e);

}  // namespace vpr
