// GPU twin of the cells' growth (cell_growth.h): a round is two launches over
// every element (the best neighbour of each element beside last round's
// front, from the round's start; then the improvements written and the next
// front marked), with the arithmetic of cell_growth_best: the CPU's cells.
#include <algorithm>
#include <string>
#include <vector>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "surface/cell_growth.h"

namespace vpr::cuda {
namespace {

struct Surface {
  const uint32_t* offset;
  const uint32_t* neighbor;
  const Vec3d* x;
  const Vec3d* normal;
  const uint32_t* seeds;
  uint32_t n;
};

__global__ void best_kernel(Surface s, const double* dist, const uint32_t* label, const uint8_t* front,
                            const uint8_t* settled, bool facing, double* best_dist, uint32_t* best_cell) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= s.n) return;
  best_cell[v] = kNoCell;
  if (settled[v]) return;
  bool beside = false;
  for (uint32_t i = s.offset[v]; i < s.offset[v + 1] && !beside; ++i) beside = front[s.neighbor[i]] != 0;
  if (!beside) return;
  cell_growth_best(s.offset, s.neighbor, s.x, s.normal, s.seeds, dist, label, facing, v, best_dist + v, best_cell + v);
}

__global__ void apply_kernel(uint32_t n, const double* best_dist, const uint32_t* best_cell, double* dist,
                             uint32_t* label, uint8_t* front, uint32_t* front_count) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= n) return;
  front[v] = best_cell[v] != kNoCell;
  if (!front[v]) return;
  dist[v] = best_dist[v];
  label[v] = best_cell[v];
  atomicAdd(front_count, 1u);
}

// The second pass's start: the first pass's cells settled, the front their
// elements beside an element no cell took.
__global__ void settle_kernel(Surface s, const uint32_t* label, uint8_t* settled, uint8_t* front,
                              uint32_t* front_count) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= s.n) return;
  settled[v] = label[v] != kNoCell;
  bool open = false;
  if (settled[v])
    for (uint32_t i = s.offset[v]; i < s.offset[v + 1] && !open; ++i) open = label[s.neighbor[i]] == kNoCell;
  front[v] = open;
  if (open) atomicAdd(front_count, 1u);
}

__global__ void seed_kernel(const uint32_t* seeds, uint32_t count, double* dist, uint8_t* front) {
  const uint32_t c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= count) return;
  dist[seeds[c]] = 0;
  front[seeds[c]] = 1;
}

__global__ void fill_kernel(double* dist, uint32_t n) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < n) dist[v] = INFINITY;
}

}  // namespace

Status grow_cells(const CellGrowthInput& in, std::vector<uint32_t>* label_io, const ExecContext& ctx) {
  VPR_RETURN_IF_ERROR(check_cell_growth_input(in, *label_io));
  const MeshEdges& adj = *in.edges;
  const uint32_t nv = uint32_t(adj.vertex_count());
  const uint32_t seeds = uint32_t(in.seeds->size());
  if (nv == 0 || seeds == 0) return Status::Ok();
  std::vector<uint32_t>& label = *label_io;
  const cudaStream_t stream = stream_of(ctx);
  DeviceBuffer<uint32_t> d_offset, d_neighbor, d_seeds, d_label, d_best_cell, d_count;
  DeviceBuffer<Vec3d> d_x, d_normal;
  DeviceBuffer<double> d_dist, d_best_dist;
  DeviceBuffer<uint8_t> d_front, d_settled;
  VPR_RETURN_IF_ERROR(UploadBatch(ctx)
                          .add(&d_offset, adj.offset.data(), adj.offset.size())
                          .add(&d_neighbor, adj.neighbor.data(), adj.neighbor.size())
                          .add(&d_seeds, in.seeds->data(), seeds)
                          .add(&d_x, in.x, nv)
                          .add(&d_normal, in.normal, nv)
                          .add(&d_label, label.data(), nv)
                          .run());
  VPR_RETURN_IF_ERROR(d_best_cell.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_best_dist.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_dist.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_front.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_settled.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_count.allocate(1, ctx));
  VPR_RETURN_IF_ERROR(d_front.zero());
  VPR_RETURN_IF_ERROR(d_settled.zero());
  const Surface s{d_offset.get(), d_neighbor.get(), d_x.get(), d_normal.get(), d_seeds.get(), nv};
  const unsigned blocks = blocks_for(nv);
  fill_kernel<<<blocks, kBlock, 0, stream>>>(d_dist.get(), nv);
  VPR_CUDA_LAUNCHED("fill_kernel");
  seed_kernel<<<blocks_for(seeds), kBlock, 0, stream>>>(d_seeds.get(), seeds, d_dist.get(), d_front.get());
  VPR_CUDA_LAUNCHED("seed_kernel");
  auto grow = [&](bool facing) -> Status {
    for (uint32_t count = 1; count > 0;) {
      best_kernel<<<blocks, kBlock, 0, stream>>>(s, d_dist.get(), d_label.get(), d_front.get(), d_settled.get(), facing,
                                                 d_best_dist.get(), d_best_cell.get());
      VPR_CUDA_LAUNCHED("best_kernel");
      VPR_RETURN_IF_ERROR(d_count.zero());
      apply_kernel<<<blocks, kBlock, 0, stream>>>(nv, d_best_dist.get(), d_best_cell.get(), d_dist.get(), d_label.get(),
                                                  d_front.get(), d_count.get());
      VPR_CUDA_LAUNCHED("apply_kernel");
      VPR_RETURN_IF_ERROR(d_count.download(&count, 1));
      VPR_CUDA_TRY(cudaStreamSynchronize(stream));
    }
    return Status::Ok();
  };
  VPR_RETURN_IF_ERROR(grow(true));
  VPR_RETURN_IF_ERROR(d_count.zero());
  settle_kernel<<<blocks, kBlock, 0, stream>>>(s, d_label.get(), d_settled.get(), d_front.get(), d_count.get());
  VPR_CUDA_LAUNCHED("settle_kernel");
  VPR_RETURN_IF_ERROR(grow(false));
  VPR_RETURN_IF_ERROR(d_label.download(label.data(), nv));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

}  // namespace vpr::cuda
