// finish_attention_field on the device (attention_finish.cuh). Step by step
// as on the host (attention_field.cpp):
//  1. each cue map's reference, its median over finite values or, where that
//     is 0, the median of its positive ones: a sort of the values with the
//     non-finite ones keyed +inf, then one thread picks the element the
//     host's nth_element would;
//  2. the nearness along the view direction, from its minimum and maximum;
//  3. the raw cue per vertex, in the host's double arithmetic;
//  4. the ranks: a stable radix sort of the raw values (ties by vertex, as
//     the host's LSD sort leaves them), runs of equal values found by a scan
//     over their first entries, each run given its mean rank.
#include "saliency/attention_finish.cuh"

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/device/device_scan.cuh>

#include <math_constants.h>

#include <algorithm>
#include <cassert>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"

namespace vpr::cuda {
namespace {

__global__ void finite_key_kernel(const float* x, uint32_t n, float* key) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) key[i] = isfinite(x[i]) ? x[i] : CUDART_INF_F;
}

// First index in [lo, hi) of the sorted keys where pred(key) holds (pred is
// false then true along the array).
template <class Pred>
__device__ uint32_t first_where(const float* key, uint32_t lo, uint32_t hi, Pred pred) {
  while (lo < hi) {
    const uint32_t mid = lo + (hi - lo) / 2;
    if (pred(key[mid]))
      hi = mid;
    else
      lo = mid + 1;
  }
  return lo;
}

// typical_positive_value (core/median.h) over the finite values, from their
// sorted keys: the element of rank m / 2 of the m finite values, or where
// that is not positive, of rank p / 2 of the p positive ones; 0 when none.
__global__ void reference_kernel(const float* sorted_key, uint32_t n, double* ref) {
  if (blockIdx.x != 0 || threadIdx.x != 0) return;
  const uint32_t m = first_where(sorted_key, 0, n, [](float k) { return k == CUDART_INF_F; });
  const double median = m ? double(sorted_key[m / 2]) : 0.0;
  if (median > 0) {
    *ref = median;
    return;
  }
  const uint32_t z = first_where(sorted_key, 0, m, [](float k) { return k > 0.0f; });
  *ref = m > z ? double(sorted_key[z + (m - z) / 2]) : 0.0;
}

// x / reference capped, as over_median on the host.
__device__ double over_reference(float x, double ref, double cap) {
  const double t = x;
  if (!isfinite(t)) return cap;
  if (!(ref > 0)) return 1.0;
  const double q = t / ref;
  return cap < q ? cap : q;
}

// Nearness's coordinate along the view direction, from each grid entry's own
// copy of its vertex's position; written in vertex order.
__global__ void along_kernel(const float* sorted, const uint32_t* order, uint32_t n, double dx, double dy, double dz,
                             double* along) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= n) return;
  along[order[t]] = dx * double(sorted[4 * t]) + dy * double(sorted[4 * t + 1]) + dz * double(sorted[4 * t + 2]);
}

struct RawInputs {
  const double* fine;
  const float* coarse;
  const float* density;     // null without the image cue
  const float* visibility;  // null without visibility
  const double* along;
  const double* lo_hi;  // minimum, maximum of along
  const double* refs;   // references of coarse, density
  double cap;
  double view_bias;
};

// The raw cue of vertex v (finish_attention_field's loop), keyed for the sort:
// -0.0 as +0.0, which the host's ordering and tie test treat as equal.
__global__ void raw_kernel(RawInputs in, uint32_t n, double* key, uint32_t* vertex) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= n) return;
  const double lo = in.lo_hi[0], hi = in.lo_hi[1];
  const double nearness = hi > lo ? (in.along[v] - lo) / (hi - lo) : 1.0;
  const double fine = in.fine[v];
  const double wide = over_reference(in.coarse[v], in.refs[0], in.cap);
  double cues;
  if (in.density) {
    const double image = over_reference(in.density[v], in.refs[1], in.cap);
    cues = (fine + wide + image) / 3.0;
  } else {
    cues = 0.5 * (fine + wide);
  }
  double raw = sqrt(cues) * (1.0 - in.view_bias + in.view_bias * nearness);
  if (in.visibility) {
    const double s = in.visibility[v];
    raw *= s < 0.0 ? 0.0 : (1.0 < s ? 1.0 : s);  // std::clamp's order: NaN stays NaN
  }
  if (!isfinite(raw)) raw = 0.0;
  key[v] = raw == 0.0 ? 0.0 : raw;
  vertex[v] = v;
}

// 1 where a sorted entry starts a run of equal raw values.
__global__ void run_head_kernel(const double* key, uint32_t n, uint32_t* head) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t < n) head[t] = t == 0 || key[t] != key[t - 1];
}

// Each run's first and one-past-last sorted position (run = inclusive head sum - 1).
__global__ void run_bounds_kernel(const double* key, const uint32_t* run, uint32_t n, uint32_t* first,
                                  uint32_t* end) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= n) return;
  const uint32_t r = run[t] - 1;
  if (t == 0 || key[t] != key[t - 1]) first[r] = t;
  if (t + 1 == n || key[t] != key[t + 1]) end[r] = t + 1;
}

// The mean rank of each entry's run, scaled to [min_importance, 1].
__global__ void rank_kernel(const uint32_t* vertex, const uint32_t* run, const uint32_t* first, const uint32_t* end,
                            uint32_t n, double min_importance, double span, float* importance) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= n) return;
  const uint32_t r = run[t] - 1;
  const uint64_t i = first[r], j = end[r];
  const double rank = n > 1 ? 0.5 * double(i + j - 1) / double(n - 1) : 1.0;
  importance[vertex[t]] = float(min_importance + span * rank);
}

// The reference of one cue map (n values in vertex order) into *ref.
Status reference_of(const float* values, uint32_t n, double* ref, DeviceBuffer<float>* keys,
                    DeviceBuffer<float>* sorted_keys, DeviceBuffer<uint8_t>* temp, const ExecContext& ctx) {
  const cudaStream_t stream = stream_of(ctx);
  finite_key_kernel<<<blocks_for(n), kBlock, 0, stream>>>(values, n, keys->get());
  VPR_CUDA_LAUNCHED("finite_key_kernel");
  size_t bytes = temp->size();
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortKeys(temp->get(), bytes, keys->get(), sorted_keys->get(), int(n), 0,
                                              int(8 * sizeof(float)), stream));
  reference_kernel<<<1, 1, 0, stream>>>(sorted_keys->get(), n, ref);
  VPR_CUDA_LAUNCHED("reference_kernel");
  return Status::Ok();
}

}  // namespace

Status finish_attention_on_device(const float* sorted, const uint32_t* order, const float* coarse,
                                  const float* density, const std::vector<double>& fine, const float* visibility,
                                  size_t vertex_count, const AttentionFieldOptions& o, std::vector<float>* importance,
                                  const ExecContext& ctx) {
  assert(fine.size() == vertex_count && vertex_count < (size_t(1) << 31));
  const uint32_t n = uint32_t(vertex_count);
  const cudaStream_t stream = stream_of(ctx);

  // cub's scratch space, once, at the largest size any step asks for.
  size_t temp_bytes = 0, bytes = 0;
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortKeys(nullptr, bytes, static_cast<float*>(nullptr),
                                              static_cast<float*>(nullptr), int(n), 0, 32, stream));
  temp_bytes = std::max(temp_bytes, bytes);
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(nullptr, bytes, static_cast<double*>(nullptr),
                                               static_cast<double*>(nullptr), static_cast<uint32_t*>(nullptr),
                                               static_cast<uint32_t*>(nullptr), int(n), 0, 64, stream));
  temp_bytes = std::max(temp_bytes, bytes);
  VPR_CUDA_TRY(cub::DeviceReduce::Min(nullptr, bytes, static_cast<double*>(nullptr), static_cast<double*>(nullptr),
                                      int(n), stream));
  temp_bytes = std::max(temp_bytes, bytes);
  VPR_CUDA_TRY(cub::DeviceReduce::Max(nullptr, bytes, static_cast<double*>(nullptr), static_cast<double*>(nullptr),
                                      int(n), stream));
  temp_bytes = std::max(temp_bytes, bytes);
  VPR_CUDA_TRY(cub::DeviceScan::InclusiveSum(nullptr, bytes, static_cast<uint32_t*>(nullptr),
                                             static_cast<uint32_t*>(nullptr), int(n), stream));
  temp_bytes = std::max(temp_bytes, bytes);
  temp_bytes = std::max<size_t>(temp_bytes, 16);  // a null scratch pointer would make cub only size it
  DeviceBuffer<uint8_t> temp;
  VPR_RETURN_IF_ERROR(temp.allocate(temp_bytes, ctx));

  // 1. References: refs[0] of the coarse map, refs[1] of the image cue.
  DeviceBuffer<double> refs, lo_hi;
  DeviceBuffer<float> keys, sorted_keys;
  VPR_RETURN_IF_ERROR(refs.allocate(2, ctx));
  VPR_RETURN_IF_ERROR(lo_hi.allocate(2, ctx));
  VPR_RETURN_IF_ERROR(keys.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(sorted_keys.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(reference_of(coarse, n, refs.get(), &keys, &sorted_keys, &temp, ctx));
  if (density) VPR_RETURN_IF_ERROR(reference_of(density, n, refs.get() + 1, &keys, &sorted_keys, &temp, ctx));

  // 2. The view direction's extent over the vertices.
  DeviceBuffer<double> along;
  VPR_RETURN_IF_ERROR(along.allocate(n, ctx));
  along_kernel<<<blocks_for(n), kBlock, 0, stream>>>(sorted, order, n, double(o.view_direction.x),
                                                     double(o.view_direction.y), double(o.view_direction.z),
                                                     along.get());
  VPR_CUDA_LAUNCHED("along_kernel");
  bytes = temp_bytes;
  VPR_CUDA_TRY(cub::DeviceReduce::Min(temp.get(), bytes, along.get(), lo_hi.get(), int(n), stream));
  bytes = temp_bytes;
  VPR_CUDA_TRY(cub::DeviceReduce::Max(temp.get(), bytes, along.get(), lo_hi.get() + 1, int(n), stream));

  // 3. The raw cue per vertex.
  DeviceBuffer<double> d_fine, raw, raw_sorted;
  DeviceBuffer<float> d_visibility;
  DeviceBuffer<uint32_t> vertex, vertex_sorted;
  VPR_RETURN_IF_ERROR(d_fine.upload(fine.data(), n, ctx));
  if (visibility) VPR_RETURN_IF_ERROR(d_visibility.upload(visibility, n, ctx));
  VPR_RETURN_IF_ERROR(raw.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(raw_sorted.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(vertex.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(vertex_sorted.allocate(n, ctx));
  RawInputs in;
  in.fine = d_fine.get();
  in.coarse = coarse;
  in.density = density;
  in.visibility = visibility ? d_visibility.get() : nullptr;
  in.along = along.get();
  in.lo_hi = lo_hi.get();
  in.refs = refs.get();
  in.cap = double(o.curvature_cap);
  in.view_bias = double(o.view_bias);
  raw_kernel<<<blocks_for(n), kBlock, 0, stream>>>(in, n, raw.get(), vertex.get());
  VPR_CUDA_LAUNCHED("raw_kernel");

  // 4. Ranks over a stable sort; equal values share their run's mean rank.
  bytes = temp_bytes;
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(temp.get(), bytes, raw.get(), raw_sorted.get(), vertex.get(),
                                               vertex_sorted.get(), int(n), 0, 64, stream));
  DeviceBuffer<uint32_t> head, run, first, end;
  VPR_RETURN_IF_ERROR(head.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(run.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(first.allocate(n, ctx));
  VPR_RETURN_IF_ERROR(end.allocate(n, ctx));
  run_head_kernel<<<blocks_for(n), kBlock, 0, stream>>>(raw_sorted.get(), n, head.get());
  VPR_CUDA_LAUNCHED("run_head_kernel");
  bytes = temp_bytes;
  VPR_CUDA_TRY(cub::DeviceScan::InclusiveSum(temp.get(), bytes, head.get(), run.get(), int(n), stream));
  run_bounds_kernel<<<blocks_for(n), kBlock, 0, stream>>>(raw_sorted.get(), run.get(), n, first.get(), end.get());
  VPR_CUDA_LAUNCHED("run_bounds_kernel");
  DeviceBuffer<float> d_importance;
  VPR_RETURN_IF_ERROR(d_importance.allocate(n, ctx));
  const double min_importance = double(o.min_importance);
  rank_kernel<<<blocks_for(n), kBlock, 0, stream>>>(vertex_sorted.get(), run.get(), first.get(), end.get(), n,
                                                    min_importance, 1.0 - min_importance, d_importance.get());
  VPR_CUDA_LAUNCHED("rank_kernel");
  importance->resize(n);
  VPR_RETURN_IF_ERROR(d_importance.download(importance->data(), n));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

}  // namespace vpr::cuda
