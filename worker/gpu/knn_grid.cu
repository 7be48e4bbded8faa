// Building the uniform grid of knn_grid.cuh: bounding box and cell size on the
// device (one block), then a counting sort of the points by cell (atomic
// histogram, exclusive scan, scatter). The order of points inside a cell
// depends on the atomics, but no result does: the search ranks candidates by
// (distance, index), a total order.
#include <algorithm>
#include <cmath>
#include <cub/block/block_reduce.cuh>
#include <cub/device/device_scan.cuh>
#include <string>

#include "gpu/cuda_check.h"
#include "gpu/knn_grid.cuh"

namespace vpr::cuda {
namespace {

constexpr int kSetupThreads = 1024;

// Cells for n points. Surface samples fill about 3 C^(2/3) of C cells of a
// cube, so C = (n / 12)^1.5 puts ~4 points in an occupied cell, a 3 x 3 x 3
// block holds ~10-40 candidates and k = 10-20 queries mostly stop after ring 1.
// At least n (volume data), at most 8n (memory: 4 bytes a cell).
size_t grid_capacity(size_t n) {
  const double surface = std::pow(double(n) / 12.0, 1.5);
  const size_t cells = surface < double(8 * n) ? size_t(surface) : 8 * n;
  return std::max<size_t>(1, std::max(cells, n));
}

struct MinOp {
  __device__ float operator()(float a, float b) const { return fminf(a, b); }
};
struct MaxOp {
  __device__ float operator()(float a, float b) const { return fmaxf(a, b); }
};

// Cell size s and dims for the box: start from the cube root of (volume /
// capacity), with each extent floored at 1e-3 of the largest so flat data
// starts sensibly, then grow s until the cells fit (flat or thin data converge
// towards the 2-D or 1-D spacing).
__device__ GridParams grid_params(const float lo_f[3], const float hi_f[3], uint32_t capacity) {
  GridParams gp;
  double e[3], emax = 0.0, magnitude = 0.0;
  for (int a = 0; a < 3; ++a) {
    gp.lo[a] = lo_f[a];
    e[a] = double(hi_f[a]) - double(lo_f[a]);
    emax = fmax(emax, e[a]);
    magnitude = fmax(magnitude, fmax(fabs(double(lo_f[a])), fabs(double(hi_f[a]))));
    gp.dims[a] = 1;
  }
  gp.cell = emax > 0.0 ? emax : 1.0;  // one cell: every point in it (all identical, or one point)
  if (emax > 0.0 && isfinite(emax)) {
    const double floor_e = emax * 1e-3;
    double volume = 1.0;
    for (int a = 0; a < 3; ++a) volume *= fmax(e[a], floor_e);
    double s = cbrt(volume / double(capacity));
    for (int it = 0; it < 200; ++it) {
      double d[3], cells = 1.0;
      for (int a = 0; a < 3; ++a) {
        d[a] = fmax(1.0, ceil(e[a] / s));
        cells *= d[a];
      }
      if (cells <= double(capacity)) {
        gp.cell = s;
        for (int a = 0; a < 3; ++a) gp.dims[a] = int(d[a]);
        break;
      }
      s *= fmax(1.01, cbrt(cells / double(capacity)));
    }
  }
  gp.inv_cell = 1.0 / gp.cell;
  // Cell assignment and face positions are computed in double from float
  // coordinates: their rounding is ~1e-16 of the magnitudes; 1e-12 is ample.
  gp.slack = 1e-12 * (magnitude + emax + gp.cell);
  return gp;
}

__global__ void grid_setup_kernel(const float* points, uint32_t n, uint32_t capacity, GridParams* out) {
  using Reduce = cub::BlockReduce<float, kSetupThreads>;
  __shared__ typename Reduce::TempStorage temp;
  __shared__ float box[6];
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t i = threadIdx.x; i < n; i += blockDim.x) {
    for (int a = 0; a < 3; ++a) {
      const float v = points[3 * size_t(i) + a];
      lo[a] = fminf(lo[a], v);
      hi[a] = fmaxf(hi[a], v);
    }
  }
  for (int a = 0; a < 3; ++a) {
    const float l = Reduce(temp).Reduce(lo[a], MinOp{});
    __syncthreads();
    const float h = Reduce(temp).Reduce(hi[a], MaxOp{});
    __syncthreads();
    if (threadIdx.x == 0) {
      box[a] = l;
      box[3 + a] = h;
    }
  }
  if (threadIdx.x == 0) *out = grid_params(box, box + 3, capacity);
}

__global__ void grid_assign_kernel(const float* points, uint32_t n, const GridParams* params, uint32_t* cell_of,
                                   uint32_t* rank, uint32_t* counts) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const GridParams& gp = *params;
  int c[3];
  for (int a = 0; a < 3; ++a) c[a] = grid_coord(points[3 * size_t(i) + a], gp.lo[a], gp.inv_cell, gp.dims[a]);
  const uint32_t cell =
      (uint32_t(c[2]) * uint32_t(gp.dims[1]) + uint32_t(c[1])) * uint32_t(gp.dims[0]) + uint32_t(c[0]);
  cell_of[i] = cell;
  rank[i] = atomicAdd(&counts[cell], 1u);
}

__global__ void grid_scatter_kernel(const float* points, uint32_t n, const uint32_t* cell_of, const uint32_t* rank,
                                    const uint32_t* cell_start, float4* sorted) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const float* p = points + 3 * size_t(i);
  sorted[cell_start[cell_of[i]] + rank[i]] = make_float4(p[0], p[1], p[2], __uint_as_float(i));
}

}  // namespace

Status KnnGrid::build(const float* points, size_t n, const ExecContext& ctx) {
  assert(n >= 1);
  constexpr size_t kMaxPoints = size_t(1) << 27;  // 8n cells (and dims) must fit an int
  if (n > kMaxPoints)
    return resource_exhausted("k-NN grid: " + std::to_string(n) + " points, the GPU limit is " +
                              std::to_string(kMaxPoints));
  const cudaStream_t stream = stream_of(ctx);
  if (n != n_) {
    n_ = 0;
    const size_t cells = grid_capacity(n);
    VPR_RETURN_IF_ERROR(params_.allocate(1, ctx));
    VPR_RETURN_IF_ERROR(sorted_.allocate(n, ctx));
    VPR_RETURN_IF_ERROR(cell_of_.allocate(n, ctx));
    VPR_RETURN_IF_ERROR(rank_.allocate(n, ctx));
    VPR_RETURN_IF_ERROR(counts_.allocate(cells + 1, ctx));
    VPR_RETURN_IF_ERROR(cell_start_.allocate(cells + 1, ctx));
    size_t bytes = 0;
    VPR_CUDA_TRY(cub::DeviceScan::ExclusiveSum(nullptr, bytes, counts_.get(), cell_start_.get(), cells + 1, stream));
    VPR_RETURN_IF_ERROR(scan_temp_.allocate(std::max<size_t>(bytes, 1), ctx));
    scan_temp_bytes_ = bytes;
    cells_ = cells;
    n_ = n;
  }
  const uint32_t n32 = uint32_t(n);
  VPR_RETURN_IF_ERROR(counts_.zero());
  grid_setup_kernel<<<1, kSetupThreads, 0, stream>>>(points, n32, uint32_t(cells_), params_.get());
  VPR_CUDA_LAUNCHED("grid_setup_kernel");
  grid_assign_kernel<<<blocks_for(n), kBlock, 0, stream>>>(points, n32, params_.get(), cell_of_.get(), rank_.get(),
                                                           counts_.get());
  VPR_CUDA_LAUNCHED("grid_assign_kernel");
  size_t bytes = scan_temp_bytes_;
  VPR_CUDA_TRY(
      cub::DeviceScan::ExclusiveSum(scan_temp_.get(), bytes, counts_.get(), cell_start_.get(), cells_ + 1, stream));
  grid_scatter_kernel<<<blocks_for(n), kBlock, 0, stream>>>(points, n32, cell_of_.get(), rank_.get(), cell_start_.get(),
                                                            sorted_.get());
  VPR_CUDA_LAUNCHED("grid_scatter_kernel");
  return Status::Ok();
}

}  // namespace vpr::cuda
