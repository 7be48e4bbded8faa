// GPU twin of mean_curvatures (surface_density.h): the host's bucket sorts as
// stable radix sorts, the same lists in the same order, and the arithmetic of
// curvature_terms.h (this file is built without FMA contraction). On a
// million faces the host's sorts were most of the 100 ms that the field
// waited for beside the render (docs/performance.md).
//
// The half-edges: key (lower, upper) with the face as value, sorted stably,
// so each edge's faces stay in face order (the host's (upper, face) order
// within a lower vertex's bucket). Runs of equal keys are the edges,
// numbered in key order. A vertex's faces: the corners' vertices sorted with
// the faces as values; its edges to lower vertices: the edges' upper ends
// sorted with the edge numbers as values (entries past the edge count carry
// the vertex count, which sorts last). Each list's start per vertex is found
// by binary search.
#include <algorithm>
#include <climits>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_run_length_encode.cuh>
#include <cub/device/device_scan.cuh>
#include <future>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "gpu/sorted_search.cuh"
#include "surface/curvature_terms.h"
#include "surface/surface_density.h"

namespace vpr::cuda {
namespace {

__global__ void faces_kernel(const float* p, const uint32_t* idx, size_t nf, Vec3d* normal, double* twice_area) {
  const size_t f = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (f < nf) face_normal_area(p, &idx[3 * f], &normal[f], &twice_area[f]);
}

// bad: set when an index is nv or more.
__global__ void half_keys_kernel(const uint32_t* idx, size_t corners, uint32_t nv, uint64_t* key, uint32_t* face,
                                 uint32_t* bad) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= corners) return;
  const uint32_t a = idx[i], b = idx[i - i % 3 + (i % 3 + 1) % 3];
  if (a >= nv) *bad = 1;
  const uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
  key[i] = uint64_t(lo) << 32 | hi;
  face[i] = uint32_t(i / 3);
}

__global__ void iota_faces_kernel(uint32_t* face, size_t corners) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < corners) face[i] = uint32_t(i / 3);
}

// The edges' ends from the runs' keys, and the keys of the sort by upper end
// (the vertex count past the last edge).
__global__ void edge_ends_kernel(const uint64_t* unique, const uint32_t* runs, size_t slots, uint32_t nv,
                                 uint32_t* lower, uint32_t* upper, uint32_t* upper_key, uint32_t* edge) {
  const size_t e = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (e >= slots) return;
  const bool real = e < *runs;
  lower[e] = real ? uint32_t(unique[e] >> 32) : nv;
  upper[e] = real ? uint32_t(unique[e]) : nv;
  upper_key[e] = upper[e];
  edge[e] = uint32_t(e);
}

struct FaceOf {
  const uint32_t* face;
  __device__ uint32_t operator()(uint32_t i) const { return face[i]; }
};
struct UpperOf {
  const uint32_t* upper;
  __device__ uint32_t operator()(uint32_t e) const { return upper[e]; }
};

__global__ void min_cosine_kernel(const Vec3d* normal, const uint32_t* half_face, const uint32_t* edge_begin,
                                  uint32_t ne, double* min_cosine) {
  const uint32_t e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e < ne) min_cosine[e] = edge_min_cosine(normal, FaceOf{half_face}, edge_begin[e], edge_begin[e + 1]);
}

__global__ void terms_kernel(const float* p, const uint32_t* idx, const Vec3d* normal, const uint32_t* half_face,
                             const uint32_t* edge_begin, const uint32_t* lower, const uint32_t* upper, uint32_t ne,
                             const double* angle, bool weigh, double concave_weight, const char* outwards,
                             double* term, double* weighted) {
  const uint32_t e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= ne) return;
  edge_curvature_terms(p, idx, normal, FaceOf{half_face}, edge_begin[e], edge_begin[e + 1], lower[e], upper[e],
                       angle[e], weigh, concave_weight, outwards, &term[e], weigh ? &weighted[e] : nullptr);
}

__global__ void vertices_kernel(uint32_t nv, uint32_t corners, uint32_t ne, const double* twice_area,
                                const uint32_t* corner_vertex, const uint32_t* corner_face,
                                const uint32_t* down_upper, const uint32_t* down, const uint32_t* lower,
                                const uint32_t* upper, const double* term, const double* weighted, double* mean,
                                double* mean_weighted) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= nv) return;
  const VertexCurvatureRows rows{twice_area,
                                 corner_face,
                                 first_at_least(corner_vertex, corners, v),
                                 first_at_least(corner_vertex, corners, v + 1),
                                 down,
                                 first_at_least(down_upper, ne, v),
                                 first_at_least(down_upper, ne, v + 1),
                                 lower,
                                 first_at_least(lower, ne, v),
                                 first_at_least(lower, ne, v + 1)};
  if (mean) mean[v] = vertex_curvature(v, rows, term, UpperOf{upper});
  if (mean_weighted) mean_weighted[v] = vertex_curvature(v, rows, weighted, UpperOf{upper});
}

}  // namespace

Status mean_curvatures(const Mesh& mesh, double concave_weight, std::vector<double>* mean,
                       std::vector<double>* weighted, const ExecContext& ctx) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count(), nc = 3 * nf;
  if (nv >= UINT32_MAX || nc + 1 > size_t(INT_MAX))
    return invalid_argument("mean curvature: " + std::to_string(nf) + " faces over " + std::to_string(nv) +
                            " vertices is more than the GPU twin's indexing takes (" + std::to_string(INT_MAX / 3) +
                            " faces)");
  const bool weigh = weighted != nullptr;
  if (nf == 0) {
    if (mean) mean->assign(nv, 0.0);
    if (weighted) weighted->assign(nv, 0.0);
    return Status::Ok();
  }
  // Which way each part faces: one serial union-find on the host, beside the
  // sorts (as the host twin does).
  std::future<std::vector<char>> outwards_beside;
  if (weigh && concave_weight != 1.0)
    outwards_beside = std::async(std::launch::async, [&mesh] { return faces_outwards(mesh); });
  const cudaStream_t stream = stream_of(ctx);
  const int n = int(nc), vertex_bits = bits_for(nv);
  DeviceBuffer<float> d_p;
  DeviceBuffer<uint32_t> d_idx;
  VPR_RETURN_IF_ERROR(d_p.upload(mesh.positions.data(), 3 * nv, ctx));
  VPR_RETURN_IF_ERROR(d_idx.upload(mesh.indices.data(), nc, ctx));

  // The keys first, which read only the indices: an index past the vertices
  // stops the job here, before any kernel reads a position through it.
  DeviceBuffer<uint64_t> d_key, d_key_sorted, d_unique;
  DeviceBuffer<uint32_t> d_face, d_half_face, d_count, d_edge_begin, d_runs, d_bad;
  VPR_RETURN_IF_ERROR(d_key.allocate(nc, ctx));
  VPR_RETURN_IF_ERROR(d_face.allocate(nc, ctx));
  VPR_RETURN_IF_ERROR(d_bad.allocate(1, ctx));
  VPR_RETURN_IF_ERROR(d_bad.zero());
  half_keys_kernel<<<blocks_for(nc), kBlock, 0, stream>>>(d_idx.get(), nc, uint32_t(nv), d_key.get(), d_face.get(),
                                                          d_bad.get());
  VPR_CUDA_LAUNCHED("half_keys_kernel");
  uint32_t bad = 0;
  VPR_RETURN_IF_ERROR(d_bad.download(&bad, 1));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  if (bad) return invalid_argument("mean curvature: an index is " + std::to_string(nv) + " (the vertex count) or more");

  DeviceBuffer<Vec3d> d_normal;
  DeviceBuffer<double> d_twice_area;
  VPR_RETURN_IF_ERROR(d_normal.allocate(nf, ctx));
  VPR_RETURN_IF_ERROR(d_twice_area.allocate(nf, ctx));
  faces_kernel<<<blocks_for(nf), kBlock, 0, stream>>>(d_p.get(), d_idx.get(), nf, d_normal.get(), d_twice_area.get());
  VPR_CUDA_LAUNCHED("faces_kernel");

  // The half-edges by (lower, upper), and their runs: the edges.
  VPR_RETURN_IF_ERROR(d_key_sorted.allocate(nc, ctx));
  VPR_RETURN_IF_ERROR(d_half_face.allocate(nc, ctx));
  VPR_RETURN_IF_ERROR(d_unique.allocate(nc, ctx));
  VPR_RETURN_IF_ERROR(d_count.allocate(nc + 1, ctx));
  VPR_RETURN_IF_ERROR(d_count.zero());
  VPR_RETURN_IF_ERROR(d_edge_begin.allocate(nc + 1, ctx));
  VPR_RETURN_IF_ERROR(d_runs.allocate(1, ctx));
  // The corners by vertex: the index buffer sorted with the faces as values.
  DeviceBuffer<uint32_t> d_corner_face_in, d_corner_vertex, d_corner_face;
  VPR_RETURN_IF_ERROR(d_corner_face_in.allocate(nc, ctx));
  VPR_RETURN_IF_ERROR(d_corner_vertex.allocate(nc, ctx));
  VPR_RETURN_IF_ERROR(d_corner_face.allocate(nc, ctx));
  iota_faces_kernel<<<blocks_for(nc), kBlock, 0, stream>>>(d_corner_face_in.get(), nc);
  VPR_CUDA_LAUNCHED("iota_faces_kernel");
  // The edges by upper end (nc slots; past the edge count the key nv).
  DeviceBuffer<uint32_t> d_lower, d_upper, d_upper_key, d_edge, d_down_upper, d_down;
  for (DeviceBuffer<uint32_t>* b : {&d_lower, &d_upper, &d_upper_key, &d_edge, &d_down_upper, &d_down})
    VPR_RETURN_IF_ERROR(b->allocate(nc, ctx));

  size_t half_bytes = 0, encode_bytes = 0, scan_bytes = 0, corner_bytes = 0, down_bytes = 0;
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(nullptr, half_bytes, d_key.get(), d_key_sorted.get(), d_face.get(),
                                               d_half_face.get(), n, 0, 32 + vertex_bits, stream));
  VPR_CUDA_TRY(cub::DeviceRunLengthEncode::Encode(nullptr, encode_bytes, d_key_sorted.get(), d_unique.get(),
                                                  d_count.get(), d_runs.get(), n, stream));
  VPR_CUDA_TRY(cub::DeviceScan::ExclusiveSum(nullptr, scan_bytes, d_count.get(), d_edge_begin.get(), n + 1, stream));
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(nullptr, corner_bytes, d_idx.get(), d_corner_vertex.get(),
                                               d_corner_face_in.get(), d_corner_face.get(), n, 0, vertex_bits, stream));
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(nullptr, down_bytes, d_upper_key.get(), d_down_upper.get(), d_edge.get(),
                                               d_down.get(), n, 0, vertex_bits, stream));
  DeviceBuffer<uint8_t> temp;
  VPR_RETURN_IF_ERROR(
      temp.allocate(std::max({half_bytes, encode_bytes, scan_bytes, corner_bytes, down_bytes, size_t(1)}), ctx));
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(temp.get(), half_bytes, d_key.get(), d_key_sorted.get(), d_face.get(),
                                               d_half_face.get(), n, 0, 32 + vertex_bits, stream));
  VPR_CUDA_TRY(cub::DeviceRunLengthEncode::Encode(temp.get(), encode_bytes, d_key_sorted.get(), d_unique.get(),
                                                  d_count.get(), d_runs.get(), n, stream));
  // Counts past the runs stay zero: edge_begin[runs] is the corner count.
  VPR_CUDA_TRY(
      cub::DeviceScan::ExclusiveSum(temp.get(), scan_bytes, d_count.get(), d_edge_begin.get(), n + 1, stream));
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(temp.get(), corner_bytes, d_idx.get(), d_corner_vertex.get(),
                                               d_corner_face_in.get(), d_corner_face.get(), n, 0, vertex_bits, stream));
  edge_ends_kernel<<<blocks_for(nc), kBlock, 0, stream>>>(d_unique.get(), d_runs.get(), nc, uint32_t(nv),
                                                          d_lower.get(), d_upper.get(), d_upper_key.get(),
                                                          d_edge.get());
  VPR_CUDA_LAUNCHED("edge_ends_kernel");
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(temp.get(), down_bytes, d_upper_key.get(), d_down_upper.get(),
                                               d_edge.get(), d_down.get(), n, 0, vertex_bits, stream));

  // Each edge's smallest cosine here, its acos on the host (the one rounding
  // the twins would not share), then the terms.
  uint32_t runs = 0;
  VPR_RETURN_IF_ERROR(d_runs.download(&runs, 1));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  const uint32_t ne = runs;
  DeviceBuffer<double> d_angle;
  VPR_RETURN_IF_ERROR(d_angle.allocate(ne, ctx));
  min_cosine_kernel<<<blocks_for(ne), kBlock, 0, stream>>>(d_normal.get(), d_half_face.get(), d_edge_begin.get(), ne,
                                                           d_angle.get());
  VPR_CUDA_LAUNCHED("min_cosine_kernel");
  std::vector<double> angle(ne);
  VPR_RETURN_IF_ERROR(d_angle.download(angle.data(), ne));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ne, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t e = r.begin(); e != r.end(); ++e) angle[e] = edge_angle(angle[e]);
  });
  VPR_RETURN_IF_ERROR(d_angle.upload(angle.data(), ne, ctx));
  // The parts' orientation from the host, when weighed.
  DeviceBuffer<char> d_outwards;
  if (outwards_beside.valid()) {
    const std::vector<char> outwards = outwards_beside.get();
    VPR_RETURN_IF_ERROR(d_outwards.upload(outwards.data(), nf, ctx));
  }
  DeviceBuffer<double> d_term, d_weighted;
  VPR_RETURN_IF_ERROR(d_term.allocate(ne, ctx));
  if (weigh) VPR_RETURN_IF_ERROR(d_weighted.allocate(ne, ctx));
  terms_kernel<<<blocks_for(ne), kBlock, 0, stream>>>(d_p.get(), d_idx.get(), d_normal.get(), d_half_face.get(),
                                                      d_edge_begin.get(), d_lower.get(), d_upper.get(), ne,
                                                      d_angle.get(), weigh, concave_weight, d_outwards.get(),
                                                      d_term.get(), d_weighted.get());
  VPR_CUDA_LAUNCHED("terms_kernel");

  DeviceBuffer<double> d_mean, d_mean_weighted;
  if (mean) VPR_RETURN_IF_ERROR(d_mean.allocate(nv, ctx));
  if (weigh) VPR_RETURN_IF_ERROR(d_mean_weighted.allocate(nv, ctx));
  vertices_kernel<<<blocks_for(nv), kBlock, 0, stream>>>(
      uint32_t(nv), uint32_t(nc), ne, d_twice_area.get(), d_corner_vertex.get(), d_corner_face.get(),
      d_down_upper.get(), d_down.get(), d_lower.get(), d_upper.get(), d_term.get(), d_weighted.get(), d_mean.get(),
      d_mean_weighted.get());
  VPR_CUDA_LAUNCHED("vertices_kernel");

  std::vector<double> h(mean ? nv : 0), w(weigh ? nv : 0);
  if (mean) VPR_RETURN_IF_ERROR(d_mean.download(h.data(), nv));
  if (weigh) VPR_RETURN_IF_ERROR(d_mean_weighted.download(w.data(), nv));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  if (mean) *mean = std::move(h);
  if (weigh) *weighted = std::move(w);
  return Status::Ok();
}

}  // namespace vpr::cuda
