// GPU twin of mesh_edges (mesh_edges.h): the rows by one radix sort of the
// face edges' two directions, where the host fills and sorts a row per vertex.
// Integers only: the same rows as the host's, and the corners by vertex
// always (the host makes them on 8 threads or more).
//
// Each corner h (face edge idx[h] -> idx[next(h)], ends a != b) gives the
// keys (a, b) and (b, a), a in the high half: sorted, a run of equal keys is
// one entry of a's row, its length the faces that use the edge (the host's
// count: both directions of every face edge between a and b). A repeated
// corner (a == b) gives two keys (nv, 0), which sort after every real one
// and are dropped. Each row's start is the first key of its vertex, found by
// binary search. The corners by vertex: the corners' vertices sorted with
// the corners as values; the sort is stable, so each row stays ascending.
#include <climits>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_run_length_encode.cuh>
#include <string>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "gpu/sorted_search.cuh"
#include "surface/mesh_edges.h"

namespace vpr::cuda {
namespace {

// bad: set when an index is nv or more (its key would not sort in key_bits).
__global__ void edge_keys_kernel(const uint32_t* idx, size_t corners, uint32_t nv, uint64_t* keys, uint32_t* bad) {
  const size_t h = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (h >= corners) return;
  const uint32_t a = idx[h], b = idx[h - h % 3 + (h % 3 + 1) % 3];
  if (a >= nv) *bad = 1;
  const bool edge = a != b && a < nv && b < nv;
  keys[2 * h] = edge ? uint64_t(a) << 32 | b : uint64_t(nv) << 32;
  keys[2 * h + 1] = edge ? uint64_t(b) << 32 | a : uint64_t(nv) << 32;
}

__global__ void iota_kernel(uint32_t* out, size_t n) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) out[i] = uint32_t(i);
}

// The first of the n sorted entries whose vertex is v or more (v = 0 .. nv).
__device__ uint32_t first_of(const uint64_t* keys, uint32_t n, uint32_t v) {
  uint32_t lo = 0, hi = n;
  while (lo < hi) {
    const uint32_t mid = lo + (hi - lo) / 2;
    if (uint32_t(keys[mid] >> 32) < v)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

__global__ void row_starts_kernel(const uint64_t* unique, const uint32_t* runs, uint32_t nv, uint32_t* offset) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v <= nv) offset[v] = first_of(unique, *runs, v);
}

__global__ void corner_starts_kernel(const uint32_t* vertex, uint32_t corners, uint32_t nv, uint32_t* offset) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v <= nv) offset[v] = first_at_least(vertex, corners, v);
}

__global__ void neighbors_kernel(const uint64_t* unique, const uint32_t* runs, uint32_t* neighbor) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < *runs) neighbor[i] = uint32_t(unique[i]);
}

}  // namespace

Status mesh_edges(const std::vector<uint32_t>& indices, size_t vertex_count, MeshEdges* edges, VertexCorners* corners,
                  const ExecContext& ctx) {
  const size_t nc = indices.size() - indices.size() % 3;
  if (vertex_count >= UINT32_MAX || 2 * nc > size_t(INT_MAX))
    return invalid_argument("mesh edges: " + std::to_string(nc / 3) + " faces over " + std::to_string(vertex_count) +
                            " vertices is more than the GPU twin's indexing takes (" + std::to_string(INT_MAX / 6) +
                            " faces)");
  const uint32_t nv = uint32_t(vertex_count);
  MeshEdges e;
  VertexCorners vc;
  e.offset.assign(nv + 1, 0);
  vc.offset.assign(nv + 1, 0);
  if (nc == 0) {
    *edges = std::move(e);
    *corners = std::move(vc);
    return Status::Ok();
  }
  const cudaStream_t stream = stream_of(ctx);
  const int n_keys = int(2 * nc), n_corners = int(nc);
  const int key_bits = 32 + bits_for(nv);  // the sentinel's vertex nv included
  DeviceBuffer<uint32_t> d_idx;
  VPR_RETURN_IF_ERROR(d_idx.upload(indices.data(), nc, ctx));

  // The corners by vertex first: the index buffer is the sort's input.
  DeviceBuffer<uint32_t> d_order, d_vertex_sorted, d_corner;
  VPR_RETURN_IF_ERROR(d_order.allocate(nc, ctx));
  VPR_RETURN_IF_ERROR(d_vertex_sorted.allocate(nc, ctx));
  VPR_RETURN_IF_ERROR(d_corner.allocate(nc, ctx));
  iota_kernel<<<blocks_for(nc), kBlock, 0, stream>>>(d_order.get(), nc);
  VPR_CUDA_LAUNCHED("iota_kernel");
  size_t pair_bytes = 0;
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(nullptr, pair_bytes, d_idx.get(), d_vertex_sorted.get(), d_order.get(),
                                               d_corner.get(), n_corners, 0, bits_for(nv), stream));

  // The edge keys and their runs.
  // The unsorted keys' buffer takes the runs' keys once sorted.
  DeviceBuffer<uint64_t> d_keys, d_sorted;
  DeviceBuffer<uint32_t> d_count, d_runs, d_bad;
  VPR_RETURN_IF_ERROR(d_keys.allocate(2 * nc, ctx));
  VPR_RETURN_IF_ERROR(d_sorted.allocate(2 * nc, ctx));
  VPR_RETURN_IF_ERROR(d_bad.allocate(1, ctx));
  VPR_RETURN_IF_ERROR(d_bad.zero());
  edge_keys_kernel<<<blocks_for(nc), kBlock, 0, stream>>>(d_idx.get(), nc, nv, d_keys.get(), d_bad.get());
  VPR_CUDA_LAUNCHED("edge_keys_kernel");
  size_t sort_bytes = 0, encode_bytes = 0;
  VPR_CUDA_TRY(
      cub::DeviceRadixSort::SortKeys(nullptr, sort_bytes, d_keys.get(), d_sorted.get(), n_keys, 0, key_bits, stream));
  VPR_RETURN_IF_ERROR(d_count.allocate(2 * nc, ctx));
  VPR_RETURN_IF_ERROR(d_runs.allocate(1, ctx));
  VPR_CUDA_TRY(cub::DeviceRunLengthEncode::Encode(nullptr, encode_bytes, d_sorted.get(), d_keys.get(), d_count.get(),
                                                  d_runs.get(), n_keys, stream));
  DeviceBuffer<uint8_t> temp;
  VPR_RETURN_IF_ERROR(temp.allocate(std::max(pair_bytes, std::max(sort_bytes, encode_bytes)), ctx));
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(temp.get(), pair_bytes, d_idx.get(), d_vertex_sorted.get(),
                                               d_order.get(), d_corner.get(), n_corners, 0, bits_for(nv), stream));
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortKeys(temp.get(), sort_bytes, d_keys.get(), d_sorted.get(), n_keys, 0, key_bits,
                                              stream));
  VPR_CUDA_TRY(cub::DeviceRunLengthEncode::Encode(temp.get(), encode_bytes, d_sorted.get(), d_keys.get(), d_count.get(),
                                                  d_runs.get(), n_keys, stream));

  // Row starts from the runs (the sentinel's run, if any, is past row nv - 1:
  // offset[nv] stops before it), the corners' row starts, the neighbours.
  DeviceBuffer<uint32_t> d_offset, d_corner_offset, d_neighbor;
  VPR_RETURN_IF_ERROR(d_offset.allocate(size_t(nv) + 1, ctx));
  VPR_RETURN_IF_ERROR(d_corner_offset.allocate(size_t(nv) + 1, ctx));
  VPR_RETURN_IF_ERROR(d_neighbor.allocate(2 * nc, ctx));
  row_starts_kernel<<<blocks_for(size_t(nv) + 1), kBlock, 0, stream>>>(d_keys.get(), d_runs.get(), nv, d_offset.get());
  VPR_CUDA_LAUNCHED("row_starts_kernel");
  corner_starts_kernel<<<blocks_for(size_t(nv) + 1), kBlock, 0, stream>>>(d_vertex_sorted.get(), uint32_t(nc), nv,
                                                                          d_corner_offset.get());
  VPR_CUDA_LAUNCHED("corner_starts_kernel");
  neighbors_kernel<<<blocks_for(2 * nc), kBlock, 0, stream>>>(d_keys.get(), d_runs.get(), d_neighbor.get());
  VPR_CUDA_LAUNCHED("neighbors_kernel");

  VPR_RETURN_IF_ERROR(d_offset.download(e.offset.data(), size_t(nv) + 1));
  VPR_RETURN_IF_ERROR(d_corner_offset.download(vc.offset.data(), size_t(nv) + 1));
  vc.corner.resize(nc);
  VPR_RETURN_IF_ERROR(d_corner.download(vc.corner.data(), nc));
  uint32_t bad = 0;
  VPR_RETURN_IF_ERROR(d_bad.download(&bad, 1));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));  // the rows' count sizes the rest
  if (bad) return invalid_argument("mesh edges: an index is " + std::to_string(nv) + " (the vertex count) or more");
  const size_t entries = e.offset[nv];
  e.neighbor.resize(entries);
  e.faces.resize(entries);
  VPR_RETURN_IF_ERROR(d_neighbor.download(e.neighbor.data(), entries));
  VPR_RETURN_IF_ERROR(d_count.download(e.faces.data(), entries));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  *edges = std::move(e);
  *corners = std::move(vc);
  return Status::Ok();
}

}  // namespace vpr::cuda
