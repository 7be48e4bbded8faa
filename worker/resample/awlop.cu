// Stage 6 (Section V, Eq. 17-18) on the GPU: AWLOP's Jacobi iterations, one
// thread per particle. Neighbourhoods come from exact uniform-grid k-NN
// searches (knn_grid.cuh): the input grid once, the particle grid rebuilt every
// iteration as the particles move, both ranked by (float distance, index) like
// the CPU twin's kd-trees. The per-particle arithmetic is awlop_kernels.h,
// shared with the CPU twin.
#include <algorithm>
#include <cmath>
#include <cub/device/device_reduce.cuh>
#include <string>
#include <utility>
#include <vector>

#include "resample/awlop.h"
#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "gpu/knn_grid.cuh"

namespace vpr::cuda {
namespace {

constexpr uint32_t kNoSelf = 0xFFFFFFFFu;

// v_j = 1 + sum theta over p_j's k nearest other input points (WLOP Eq. 3).
template <int K>
__global__ void density_kernel(GridView inputs, const float* input_points, int k_others, double inv_h2,
                               double* density) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= inputs.n) return;
  const GridParams gp = *inputs.params;
  const float4 p = inputs.points[t];
  const uint32_t j = __float_as_uint(p.w);
  TopK<K> top;
  top.k = k_others;
  grid_knn(inputs, gp, p.x, p.y, p.z, j, &top);
  const Vec3d pj = load3d(input_points, j);
  double v = 1.0;
  for (int m = 0; m < top.count; ++m) awlop_add_density(&v, pj, load3d(input_points, top.index[m]), inv_h2);
  density[j] = v;
}

struct StepArgs {
  GridView inputs, particles;
  const float* input_points;  // np x 3, original order
  const double* density;      // np
  const float* current;       // nx x 3, previous iteration
  const double* weight;       // nx: w_q = 1 / I(c_q)
  int k_in, k_px;
  double inv_h2, r_floor, mu;
  float* next;  // nx x 3
};

// One Jacobi update x_i <- A_i + mu R_i (Eq. 17), threads in particle-grid
// order so that neighbouring threads search neighbouring cells.
template <int K>
__global__ void awlop_step_kernel(StepArgs a) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= a.particles.n) return;
  const float4 xp = a.particles.points[t];
  const uint32_t i = __float_as_uint(xp.w);
  const Vec3d x = load3d(a.current, i);
  TopK<K> top;

  // Eq. (17): attraction to the density-weighted average of nearby inputs.
  top.k = a.k_in;
  const GridParams gin = *a.inputs.params;
  grid_knn(a.inputs, gin, xp.x, xp.y, xp.z, kNoSelf, &top);
  AwlopSum attraction;
  double r2_min = INFINITY;
  for (int m = 0; m < top.count; ++m) r2_min = fmin(r2_min, norm2(load3d(a.input_points, top.index[m]) - x));
  for (int m = 0; m < top.count; ++m) {
    const uint32_t j = top.index[m];
    awlop_add_attraction(&attraction, x, load3d(a.input_points, j), a.density[j], r2_min, a.inv_h2, a.r_floor);
  }

  // Eq. (18): repulsion from the k nearest other particles, weighted by 1 / I.
  top.k = a.k_px;
  const GridParams gpx = *a.particles.params;
  grid_knn(a.particles, gpx, xp.x, xp.y, xp.z, i, &top);
  AwlopSum repulsion;
  r2_min = INFINITY;
  for (int m = 0; m < top.count; ++m) r2_min = fmin(r2_min, norm2(load3d(a.current, top.index[m]) - x));
  for (int m = 0; m < top.count; ++m) {
    const uint32_t q = top.index[m];
    awlop_add_repulsion(&repulsion, x, load3d(a.current, q), a.weight[q], r2_min, a.inv_h2, a.r_floor);
  }

  const Vec3d moved = awlop_update(x, attraction, repulsion, a.mu);
  store3(a.next, i, Vec3{float(moved.x), float(moved.y), float(moved.z)});
}

// Nearest-neighbour distance of every grid point (for the CV statistics).
__global__ void nearest_kernel(GridView grid, const float* points, double* nn, double* nn2) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= grid.n) return;
  const GridParams gp = *grid.params;
  const float4 p = grid.points[t];
  const uint32_t i = __float_as_uint(p.w);
  TopK<1> top;
  top.k = 1;
  grid_knn(grid, gp, p.x, p.y, p.z, i, &top);
  const double d = std::sqrt(norm2(load3d(points, top.index[0]) - load3d(points, i)));
  nn[i] = d;
  nn2[i] = d * d;
}

// Sums of nearest-neighbour distances and their squares into sums[0..1], as
// nearest_neighbor_cv computes them on the CPU (n >= 2).
struct NearestStats {
  DeviceBuffer<double> nn, nn2;
  DeviceBuffer<uint8_t> temp;
  size_t temp_bytes = 0;

  Status run(const KnnGrid& grid, const float* points, size_t n, double* sums, const ExecContext& ctx) {
    const cudaStream_t stream = stream_of(ctx);
    if (nn.size() != n) {
      VPR_RETURN_IF_ERROR(nn.allocate(n, ctx));
      VPR_RETURN_IF_ERROR(nn2.allocate(n, ctx));
      VPR_CUDA_TRY(cub::DeviceReduce::Sum(nullptr, temp_bytes, nn.get(), sums, n, stream));
      VPR_RETURN_IF_ERROR(temp.allocate(std::max<size_t>(temp_bytes, 1), ctx));
    }
    nearest_kernel<<<blocks_for(n, kSearchBlock), kSearchBlock, 0, stream>>>(grid.view(), points, nn.get(), nn2.get());
    VPR_CUDA_LAUNCHED("nearest_kernel");
    size_t bytes = temp_bytes;
    VPR_CUDA_TRY(cub::DeviceReduce::Sum(temp.get(), bytes, nn.get(), sums, n, stream));
    bytes = temp_bytes;
    VPR_CUDA_TRY(cub::DeviceReduce::Sum(temp.get(), bytes, nn2.get(), sums + 1, n, stream));
    return Status::Ok();
  }
};

// The CPU's formula from the two sums (nearest_neighbor_cv).
double cv_from_sums(double sum, double sum2, size_t n) {
  const double mean = sum / double(n);
  if (mean <= 0) return 0.0;
  const double var = std::max(0.0, sum2 / double(n) - mean * mean);
  return std::sqrt(var) / mean;
}

}  // namespace

Status awlop(const float* input_points, size_t np, float* particles, const float* particle_importance, size_t nx,
             double h, const AwlopOptions& options, AwlopStats* stats, const ExecContext& ctx) {
  VPR_RETURN_IF_ERROR(check_awlop_args(input_points, np, particles, particle_importance, nx, h, options));
  if (options.k > kMaxGridK)
    return unavailable("AWLOP: k = " + std::to_string(options.k) +
                       ", the GPU twin handles k <= " + std::to_string(kMaxGridK) + "; use the CPU twin");
  if (stats) {
    *stats = AwlopStats{};
    stats->h = h;
  }
  if (nx == 0) return Status::Ok();
  const cudaStream_t stream = stream_of(ctx);
  const int k = options.k;
  const bool want_cv = stats != nullptr && nx >= 2;

  DeviceBuffer<float> inputs, current, next;
  DeviceBuffer<double> weight, density, sums;
  VPR_RETURN_IF_ERROR(inputs.upload(input_points, 3 * np, ctx));
  VPR_RETURN_IF_ERROR(current.upload(particles, 3 * nx, ctx));
  VPR_RETURN_IF_ERROR(next.allocate(3 * nx, ctx));
  // Adaptive repulsion weight w_q = 1 / I(c_q) (Eq. 18).
  std::vector<double> host_weight(nx);
  for (size_t q = 0; q < nx; ++q) host_weight[q] = 1.0 / double(particle_importance[q]);
  VPR_RETURN_IF_ERROR(weight.upload(host_weight.data(), nx, ctx));
  VPR_RETURN_IF_ERROR(density.allocate(np, ctx));
  VPR_RETURN_IF_ERROR(sums.allocate(4, ctx));
  VPR_RETURN_IF_ERROR(sums.zero());

  StepArgs args{};
  args.input_points = inputs.get();
  args.density = density.get();
  args.weight = weight.get();
  args.k_in = int(std::min<size_t>(size_t(k), np));
  args.k_px = int(std::min<size_t>(size_t(k), nx - 1));  // other particles only
  args.inv_h2 = 1.0 / (h * h);
  args.r_floor = 1e-9 * h;  // guard for r -> 0 in 1/r (Eq. 17-18)
  args.mu = options.mu;

  KnnGrid input_grid, particle_grid;
  VPR_RETURN_IF_ERROR(input_grid.build(inputs.get(), np, ctx));
  args.inputs = input_grid.view();
  const int k_density = int(std::min<size_t>(size_t(k), np - 1));
  VPR_RETURN_IF_ERROR(dispatch_k(k, [&](auto kk) -> Status {
    density_kernel<decltype(kk)::value><<<blocks_for(np, kSearchBlock), kSearchBlock, 0, stream>>>(
        input_grid.view(), inputs.get(), k_density, args.inv_h2, density.get());
    VPR_CUDA_LAUNCHED("density_kernel");
    return Status::Ok();
  }));

  NearestStats nearest;
  for (int it = 0; it < options.iterations; ++it) {
    VPR_RETURN_IF_ERROR(particle_grid.build(current.get(), nx, ctx));  // particles moved: rebuild
    if (it == 0 && want_cv) VPR_RETURN_IF_ERROR(nearest.run(particle_grid, current.get(), nx, sums.get(), ctx));
    args.particles = particle_grid.view();
    args.current = current.get();
    args.next = next.get();
    VPR_RETURN_IF_ERROR(dispatch_k(k, [&](auto kk) -> Status {
      awlop_step_kernel<decltype(kk)::value><<<blocks_for(nx, kSearchBlock), kSearchBlock, 0, stream>>>(args);
      VPR_CUDA_LAUNCHED("awlop_step_kernel");
      return Status::Ok();
    }));
    std::swap(current, next);  // Jacobi: the next iteration reads only these positions
  }
  if (want_cv) {
    VPR_RETURN_IF_ERROR(particle_grid.build(current.get(), nx, ctx));
    if (options.iterations == 0) VPR_RETURN_IF_ERROR(nearest.run(particle_grid, current.get(), nx, sums.get(), ctx));
    VPR_RETURN_IF_ERROR(nearest.run(particle_grid, current.get(), nx, sums.get() + 2, ctx));
  }

  double host_sums[4] = {0, 0, 0, 0};
  VPR_RETURN_IF_ERROR(current.download(particles, 3 * nx));
  VPR_RETURN_IF_ERROR(sums.download(host_sums, 4));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  if (stats) {
    stats->iterations = options.iterations;
    if (want_cv) {
      stats->nn_cv_before = cv_from_sums(host_sums[0], host_sums[1], nx);
      stats->nn_cv_after = cv_from_sums(host_sums[2], host_sums[3], nx);
    }
  }
  return Status::Ok();
}

}  // namespace vpr::cuda
