// GPU twin of the CVT's colour sweeps (cvt_sweeps.h): one thread an element,
// the arithmetic of cvt_sweep_kernels.h, the cells' fixed-point sums kept
// with integer atomics (exact and order-free), and E summed by one block in
// the CPU reference's order, so the labels are the reference's bit for bit.
#include <algorithm>
#include <cub/device/device_radix_sort.cuh>
#include <string>
#include <vector>

#include "core/step_marks.h"
#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "surface/cvt_sweep_kernels.h"
#include "surface/cvt_sweeps.h"
#include "surface/cvt_sweeps_setup.h"

namespace vpr::cuda {
namespace {

struct Elements {
  const uint32_t* offset;
  const uint32_t* neighbor;
  const uint32_t* faces;
  const Vec3d* x;
  const Vec3d* y;
  const Vec3d* normal;
  const double* mass;
  const char* on_loop;
  uint32_t n;
};

__global__ void colour_round_kernel(Elements e, uint8_t* colour, uint32_t* round_of, uint32_t round, uint32_t* coloured,
                                    uint32_t* colours) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= e.n || round_of[v] != 0xFFFFFFFFu) return;
  const uint8_t c = cvt_colour_in_round(e.offset, e.neighbor, colour, round_of, round, v);
  if (c == kUncoloured) return;
  colour[v] = c;
  round_of[v] = round;
  atomicAdd(coloured, 1u);
  if (c < 64) atomicMax(colours, uint32_t(c) + 1);
}

__device__ void add_sums(unsigned long long* cell, const long long* c, bool subtract) {
  for (int k = 0; k < kCvtSums; ++k)
    atomicAdd(cell + k, static_cast<unsigned long long>(subtract ? -c[k] : c[k]));  // two's complement: exact
}

__global__ void initial_sums_kernel(Elements e, CvtFixedScale scale, const uint32_t* label, unsigned long long* sums,
                                    uint32_t* size) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= e.n || label[v] == kNoCell) return;
  long long c[kCvtSums];
  cvt_contribution(e.mass[v], e.x[v], e.y[v], e.normal[v], scale, c);
  add_sums(sums + size_t(label[v]) * kCvtSums, c, false);
  atomicAdd(size + label[v], 1u);
}

// The elements of one colour, listed (by_colour): thread i decides list[i]'s
// move into move[i], and the next kernel applies it.
__global__ void decide_kernel(Elements e, CvtFixedScale scale, const uint32_t* list, uint32_t count,
                              const uint32_t* label, const unsigned long long* sums, const uint32_t* size,
                              double threshold, uint32_t* move) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  const uint32_t v = list[i];
  move[i] = kNoCell;
  if (!cvt_on_cell_edge(e.offset, e.neighbor, label, v)) return;  // no cell to move to: most elements
  long long c[kCvtSums];
  cvt_contribution(e.mass[v], e.x[v], e.y[v], e.normal[v], scale, c);
  move[i] = cvt_best_move(e.offset, e.neighbor, e.faces, label, reinterpret_cast<const long long*>(sums), size, scale,
                          cvt_sums(c, scale), e.normal[v], e.on_loop[v] != 0, v, threshold);
}

__global__ void apply_kernel(Elements e, CvtFixedScale scale, const uint32_t* list, uint32_t count,
                             const uint32_t* move, uint32_t* label, unsigned long long* sums, uint32_t* size,
                             unsigned long long* moved) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count || move[i] == kNoCell) return;
  const uint32_t v = list[i];
  long long c[kCvtSums];
  cvt_contribution(e.mass[v], e.x[v], e.y[v], e.normal[v], scale, c);
  add_sums(sums + size_t(label[v]) * kCvtSums, c, true);
  add_sums(sums + size_t(move[i]) * kCvtSums, c, false);
  atomicSub(size + label[v], 1u);
  atomicAdd(size + move[i], 1u);
  label[v] = move[i];
  atomicAdd(moved, 1ull);
}

__global__ void iota_kernel(uint32_t* out, uint32_t n) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < n) out[v] = v;
}

// How many elements have each colour (64: the ones never moved).
__global__ void colour_count_kernel(const uint8_t* colour, uint32_t n, uint32_t* count) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < n) atomicAdd(count + colour[v], 1u);
}

// One block of kCvtEnergyLanes threads: lane t sums cells t, t + lanes, ...
// in order, then the lanes halve pairwise (the CPU reference's order).
__global__ void energy_kernel(const unsigned long long* sums, uint32_t cells, CvtFixedScale scale, double constant,
                              double* energy) {
  __shared__ double lane[kCvtEnergyLanes];
  const uint32_t t = threadIdx.x;
  double sum = 0;
  for (uint32_t c = t; c < cells; c += kCvtEnergyLanes)
    sum += cvt_cell_energy(cvt_sums(reinterpret_cast<const long long*>(sums) + size_t(c) * kCvtSums, scale));
  lane[t] = sum;
  __syncthreads();
  for (uint32_t half = kCvtEnergyLanes / 2; half > 0; half /= 2) {
    if (t < half) lane[t] += lane[t + half];
    __syncthreads();
  }
  if (t == 0) *energy = constant + lane[0];
}

}  // namespace

Status cvt_colour_sweeps(const CvtSweepInput& in, std::vector<uint32_t>* label_io, CvtSweepOutput* out,
                         const ExecContext& ctx) {
  VPR_RETURN_IF_ERROR(check_cvt_sweep_input(in, *label_io));
  *out = CvtSweepOutput{};
  const MeshEdges& adj = *in.edges;
  const uint32_t nv = uint32_t(adj.vertex_count());
  if (nv == 0 || in.cells == 0) return Status::Ok();
  std::vector<uint32_t>& label = *label_io;
  const CvtFixedScale scale = cvt_fixed_scale(in, label);
  const cudaStream_t stream = stream_of(ctx);
  StepMarks marks("cvt_rounds");

  DeviceBuffer<uint32_t> d_offset, d_neighbor, d_faces, d_label, d_round, d_move, d_size, d_counters;
  DeviceBuffer<Vec3d> d_x, d_y, d_normal;
  DeviceBuffer<double> d_mass, d_energy;
  DeviceBuffer<char> d_on_loop;
  DeviceBuffer<uint8_t> d_colour;
  DeviceBuffer<unsigned long long> d_sums, d_moved;
  VPR_RETURN_IF_ERROR(UploadBatch(ctx)  // 55 MB on igea: one staged upload
                          .add(&d_offset, adj.offset.data(), adj.offset.size())
                          .add(&d_neighbor, adj.neighbor.data(), adj.neighbor.size())
                          .add(&d_faces, adj.faces.data(), adj.faces.size())
                          .add(&d_x, in.x, nv)
                          .add(&d_y, in.y, nv)
                          .add(&d_normal, in.normal, nv)
                          .add(&d_mass, in.mass, nv)
                          .add(&d_on_loop, in.on_loop, nv)
                          .add(&d_label, label.data(), nv)
                          .run());
  if (in.uploaded) in.uploaded();
  marks.mark("upload");
  VPR_RETURN_IF_ERROR(d_round.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_move.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_colour.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_size.allocate(in.cells, ctx));
  VPR_RETURN_IF_ERROR(d_sums.allocate(size_t(in.cells) * kCvtSums, ctx));
  VPR_RETURN_IF_ERROR(d_counters.allocate(2, ctx));  // elements coloured, colours
  VPR_RETURN_IF_ERROR(d_moved.allocate(1, ctx));
  VPR_RETURN_IF_ERROR(d_energy.allocate(1, ctx));
  VPR_CUDA_TRY(cudaMemsetAsync(d_round.get(), 0xFF, nv * sizeof(uint32_t), stream));
  VPR_CUDA_TRY(cudaMemsetAsync(d_colour.get(), kUncoloured, nv, stream));
  VPR_RETURN_IF_ERROR(d_size.zero());
  VPR_RETURN_IF_ERROR(d_sums.zero());
  VPR_RETURN_IF_ERROR(d_counters.zero());
  const Elements e{d_offset.get(), d_neighbor.get(), d_faces.get(),   d_x.get(), d_y.get(),
                   d_normal.get(), d_mass.get(),     d_on_loop.get(), nv};
  const unsigned blocks = blocks_for(nv);

  // Colours: a round a launch; the count of coloured elements read back each round.
  uint32_t counters[2] = {0, 0};
  for (uint32_t round = 0; counters[0] < nv; ++round) {
    if (round >= kCvtMaxColourRounds) return internal_error("CVT colour sweeps: colouring did not finish");
    colour_round_kernel<<<blocks, kBlock, 0, stream>>>(e, d_colour.get(), d_round.get(), round, d_counters.get(),
                                                       d_counters.get() + 1);
    VPR_CUDA_LAUNCHED("colour_round_kernel");
    VPR_RETURN_IF_ERROR(d_counters.download(counters, 2));
    VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  }
  const uint32_t colours = counters[1];
  out->colours = colours;
  marks.mark("colours");

  // The elements listed by colour (a stable radix sort of the colours, so
  // each colour's list is ascending), so that a round launches over its own
  // elements only: on igea's 405,000 elements seven colours of about 58,000.
  DeviceBuffer<uint32_t> d_index, d_by_colour, d_colour_count;
  DeviceBuffer<uint8_t> d_sorted_colour, d_sort_temp;
  VPR_RETURN_IF_ERROR(d_index.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_by_colour.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_sorted_colour.allocate(nv, ctx));
  VPR_RETURN_IF_ERROR(d_colour_count.allocate(kCvtColourSlots, ctx));
  VPR_RETURN_IF_ERROR(d_colour_count.zero());
  iota_kernel<<<blocks, kBlock, 0, stream>>>(d_index.get(), nv);
  VPR_CUDA_LAUNCHED("iota_kernel");
  colour_count_kernel<<<blocks, kBlock, 0, stream>>>(d_colour.get(), nv, d_colour_count.get());
  VPR_CUDA_LAUNCHED("colour_count_kernel");
  size_t sort_bytes = 0;
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(nullptr, sort_bytes, d_colour.get(), d_sorted_colour.get(),
                                               d_index.get(), d_by_colour.get(), int(nv), 0, 7, stream));
  VPR_RETURN_IF_ERROR(d_sort_temp.allocate(std::max<size_t>(sort_bytes, 1), ctx));
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(d_sort_temp.get(), sort_bytes, d_colour.get(), d_sorted_colour.get(),
                                               d_index.get(), d_by_colour.get(), int(nv), 0, 7, stream));
  uint32_t colour_count[kCvtColourSlots];
  VPR_RETURN_IF_ERROR(d_colour_count.download(colour_count, kCvtColourSlots));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  std::vector<uint32_t> colour_start(colours + 1, 0);  // colours < 64 come first, in order
  for (uint32_t k = 0; k < colours; ++k) colour_start[k + 1] = colour_start[k] + colour_count[k];

  initial_sums_kernel<<<blocks, kBlock, 0, stream>>>(e, scale, d_label.get(), d_sums.get(), d_size.get());
  VPR_CUDA_LAUNCHED("initial_sums_kernel");
  auto energy = [&](double* value) -> Status {
    energy_kernel<<<1, kCvtEnergyLanes, 0, stream>>>(d_sums.get(), in.cells, scale, in.constant, d_energy.get());
    VPR_CUDA_LAUNCHED("energy_kernel");
    return d_energy.download(value, 1);
  };
  double previous = 0;
  VPR_RETURN_IF_ERROR(energy(&previous));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  marks.mark("lists_sums");
  for (int sweep = 0; sweep < in.max_sweeps; ++sweep) {
    const double threshold = 1e-18 * std::abs(previous);
    VPR_RETURN_IF_ERROR(d_moved.zero());
    for (uint32_t k = 0; k < colours; ++k) {
      const uint32_t* list = d_by_colour.get() + colour_start[k];
      const uint32_t count = colour_count[k];
      if (count == 0) continue;
      decide_kernel<<<blocks_for(count), kBlock, 0, stream>>>(e, scale, list, count, d_label.get(), d_sums.get(),
                                                              d_size.get(), threshold, d_move.get());
      VPR_CUDA_LAUNCHED("decide_kernel");
      apply_kernel<<<blocks_for(count), kBlock, 0, stream>>>(e, scale, list, count, d_move.get(), d_label.get(),
                                                             d_sums.get(), d_size.get(), d_moved.get());
      VPR_CUDA_LAUNCHED("apply_kernel");
    }
    double now = 0;
    unsigned long long moved = 0;
    VPR_RETURN_IF_ERROR(energy(&now));
    VPR_RETURN_IF_ERROR(d_moved.download(&moved, 1));
    VPR_CUDA_TRY(cudaStreamSynchronize(stream));
    if (cvt_sweeps_stop(previous, now, size_t(moved), in.tolerance, out)) break;
    previous = now;
  }
  marks.mark("sweeps");
  VPR_RETURN_IF_ERROR(d_label.download(label.data(), nv));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  marks.mark("download");
  return Status::Ok();
}

}  // namespace vpr::cuda
