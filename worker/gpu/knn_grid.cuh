// Exact k-nearest-neighbour search on the GPU over a uniform grid, shared by
// the saliency field's k-NN graph (Algorithm 1) and AWLOP's neighbourhoods
// (Eq. 17-18). The CPU twins use FLANN kd-trees; this search returns the same
// neighbours in the same order:
//  - squared distances in float, summed as FLANN's L2_Simple does
//    (((0 + dx*dx) + dy*dy) + dz*dz with d = query - point), with __fadd_rn /
//    __fmul_rn so that nvcc cannot contract them into FMAs;
//  - ordered by (squared distance, index), so ties go to the smaller index,
//    at the k-th place too.
// Exactness: the search visits the grid in cubic shells (rings) around the
// query's cell and stops only when the k-th distance is strictly below a lower
// bound on the distance to every cell not yet visited (the nearest face of the
// visited box that is not the grid's border), shrunk by the rounding of cell
// assignment and of the float distance. A query outside the grid is clamped to
// a border cell; the bound stays valid because it is measured from the query's
// true position.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>
#include <type_traits>

#include "gpu/device_buffer.h"
#include "core/exec_context.h"
#include "core/status.h"

namespace vpr::cuda {

// Largest k the search keeps in registers/local memory; callers check it.
inline constexpr int kMaxGridK = 64;
// Threads per block of the search kernels: small blocks, so that the few
// thousand particles of AWLOP still spread over every SM.
inline constexpr int kSearchBlock = 64;

struct GridParams {
  double lo[3];     // corner of cell (0, 0, 0), model units
  double cell;      // cell edge length
  double inv_cell;  // 1 / cell
  double slack;     // bound on the rounding of cell assignment, model units
  int dims[3];      // cells per axis; dims[0] * dims[1] * dims[2] <= capacity
};

// Non-owning view handed to kernels. points: n entries sorted by cell, xyz in
// model units and w holding the original index's bits; cell_start: cells + 1.
struct GridView {
  const GridParams* params;
  const float4* points;
  const uint32_t* cell_start;
  uint32_t n;
};

// Owns a grid over n device points; rebuilt in place as points move (AWLOP).
// Everything runs on ctx's stream without a host synchronisation: the bounding
// box and cell size are computed on the device, the cell count is fixed by n.
class KnnGrid {
 public:
  // points: n x 3 floats on the device, 1 <= n <= 2^27 (else RESOURCE_EXHAUSTED).
  Status build(const float* points, size_t n, const ExecContext& ctx);
  GridView view() const { return {params_.get(), sorted_.get(), cell_start_.get(), uint32_t(n_)}; }
  size_t size() const { return n_; }

 private:
  size_t n_ = 0, cells_ = 0;
  DeviceBuffer<GridParams> params_;
  DeviceBuffer<float4> sorted_;
  DeviceBuffer<uint32_t> cell_start_, counts_, cell_of_, rank_;
  DeviceBuffer<uint8_t> scan_temp_;
  size_t scan_temp_bytes_ = 0;
};

// The k best (squared distance, index) pairs seen so far, best first.
template <int K>
struct TopK {
  float dist[K];
  uint32_t index[K];
  int count = 0;
  int k = 0;

  __device__ static bool before(float d, uint32_t i, float od, uint32_t oi) { return d < od || (d == od && i < oi); }

  __device__ void offer(float d, uint32_t i) {
    if (d != d) return;  // NaN (non-finite input): never a neighbour, never blocks one
    int pos;
    if (count == k) {
      if (!before(d, i, dist[k - 1], index[k - 1])) return;
      pos = k - 1;
    } else {
      pos = count++;
    }
    while (pos > 0 && before(d, i, dist[pos - 1], index[pos - 1])) {
      dist[pos] = dist[pos - 1];
      index[pos] = index[pos - 1];
      --pos;
    }
    dist[pos] = d;
    index[pos] = i;
  }
};

// FLANN's L2_Simple in float, uncontracted.
__device__ inline float flann_sq_dist(float qx, float qy, float qz, float4 p) {
  const float dx = __fsub_rn(qx, p.x), dy = __fsub_rn(qy, p.y), dz = __fsub_rn(qz, p.z);
  float r = __fmul_rn(dx, dx);
  r = __fadd_rn(r, __fmul_rn(dy, dy));
  return __fadd_rn(r, __fmul_rn(dz, dz));
}

// Cell coordinate of v along one axis, clamped to the grid (NaN -> 0). In
// double, so the rounding that `slack` covers is tiny.
__device__ inline int grid_coord(float v, double lo, double inv_cell, int dim) {
  const double t = floor((double(v) - lo) * inv_cell);
  return int(fmin(fmax(t, 0.0), double(dim - 1)));
}

// The k nearest grid points to q, skipping the point whose original index is
// `self` (pass UINT32_MAX for an outside query). top->k must be set (k <= n,
// k <= K); returns with top->count = min(k, points other than self).
template <int K>
__device__ void grid_knn(const GridView& grid, const GridParams& gp, float qx, float qy, float qz, uint32_t self,
                         TopK<K>* top) {
  top->count = 0;
  if (top->k <= 0) return;
  const float q[3] = {qx, qy, qz};
  int c[3];
  for (int a = 0; a < 3; ++a) c[a] = grid_coord(q[a], gp.lo[a], gp.inv_cell, gp.dims[a]);

  auto scan = [&](uint32_t first_cell, uint32_t last_cell) {
    const uint32_t end = grid.cell_start[last_cell + 1];
    for (uint32_t t = grid.cell_start[first_cell]; t < end; ++t) {
      const float4 p = grid.points[t];
      const uint32_t index = __float_as_uint(p.w);
      if (index != self) top->offer(flann_sq_dist(qx, qy, qz, p), index);
    }
  };

  for (int r = 0;; ++r) {
    // Shell r: the cells at Chebyshev distance r from c, row by row along x
    // (a row's cells, hence its points, are contiguous).
    const int x0 = max(c[0] - r, 0), x1 = min(c[0] + r, gp.dims[0] - 1);
    const int y0 = max(c[1] - r, 0), y1 = min(c[1] + r, gp.dims[1] - 1);
    const int z0 = max(c[2] - r, 0), z1 = min(c[2] + r, gp.dims[2] - 1);
    for (int z = z0; z <= z1; ++z) {
      for (int y = y0; y <= y1; ++y) {
        const uint32_t row = (uint32_t(z) * uint32_t(gp.dims[1]) + uint32_t(y)) * uint32_t(gp.dims[0]);
        if (abs(z - c[2]) == r || abs(y - c[1]) == r) {
          scan(row + uint32_t(x0), row + uint32_t(x1));
        } else {
          if (c[0] - r >= 0) scan(row + uint32_t(c[0] - r), row + uint32_t(c[0] - r));
          if (c[0] + r < gp.dims[0]) scan(row + uint32_t(c[0] + r), row + uint32_t(c[0] + r));
        }
      }
    }
    // Every point not visited lies beyond a face of the visited box that is
    // not the grid's border: the nearest such face bounds its distance.
    double bound = INFINITY;
    for (int a = 0; a < 3; ++a) {
      if (c[a] - r > 0) bound = fmin(bound, double(q[a]) - (gp.lo[a] + double(c[a] - r) * gp.cell));
      if (c[a] + r < gp.dims[a] - 1) bound = fmin(bound, gp.lo[a] + double(c[a] + r + 1) * gp.cell - double(q[a]));
    }
    if (bound == INFINITY) return;  // the whole grid has been visited
    bound -= gp.slack;
    if (top->count == top->k && bound > 0.0) {
      // A float squared distance is at least (1 - 6 u) of the true one (u =
      // 2^-24); below 1e-30 float underflow could break that, so keep going.
      const double floor2 = bound * bound * (1.0 - 1e-6);
      if (floor2 > 1e-30 && double(top->dist[top->k - 1]) < floor2) return;
    }
  }
}

// Calls launch(std::integral_constant<int, K>{}) with the smallest K in
// {16, 32, 64} that holds k (k <= kMaxGridK, checked by the caller): the
// neighbour lists live in per-thread arrays of compile-time size.
template <class Launch>
Status dispatch_k(int k, Launch&& launch) {
  if (k <= 16) return launch(std::integral_constant<int, 16>{});
  if (k <= 32) return launch(std::integral_constant<int, 32>{});
  return launch(std::integral_constant<int, 64>{});
}

}  // namespace vpr::cuda
