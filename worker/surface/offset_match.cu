// GPU twin of the L2 fit's samples (offset_match.h): one thread a triangle
// for the unit normals, one a sample for the matches (match_offset_sample's
// arithmetic), then the samples sorted by triangle (a stable radix sort, so
// each triangle's run is in sample order) and one thread a triangle summing
// its run (add_offset_sample), and one a block of kOffsetRmsBlock samples for
// the RMS sums. The samples stay on the device; the triangles' sums and the
// blocks' sums come back, the host's bits.
#include <cub/device/device_radix_sort.cuh>

#include <algorithm>
#include <memory>
#include <utility>
#include <vector>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "surface/offset_match.h"

namespace vpr::cuda {
namespace {

__global__ void normal_kernel(const float* positions, const uint32_t* indices, uint32_t triangles, Vec3d* unit_normal) {
  const uint32_t g = blockIdx.x * blockDim.x + threadIdx.x;
  if (g < triangles) unit_normal[g] = triangle_unit_normal(positions, indices, g);
}

// The match, and the sort's key (its triangle; unmatched samples after every
// triangle) and value (the sample).
__global__ void match_kernel(OffsetMatchView view, uint32_t samples, uint32_t triangles, OffsetMatch* matches,
                             uint32_t* key, uint32_t* sample) {
  const uint32_t f = blockIdx.x * blockDim.x + threadIdx.x;
  if (f >= samples) return;
  const OffsetMatch m = match_offset_sample(view, f);
  matches[f] = m;
  key[f] = m.face >= 0 ? uint32_t(m.face) : triangles;
  sample[f] = f;
}

// The first position in sorted[0, n) not below x.
__device__ uint32_t lower_bound(const uint32_t* sorted, uint32_t n, uint32_t x) {
  uint32_t lo = 0, hi = n;
  while (lo < hi) {
    const uint32_t mid = lo + (hi - lo) / 2;
    if (sorted[mid] < x) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

__global__ void face_sums_kernel(const OffsetMatch* matches, const uint32_t* key, const uint32_t* sample,
                                 uint32_t samples, uint32_t triangles, OffsetFaceSums* per_face) {
  const uint32_t g = blockIdx.x * blockDim.x + threadIdx.x;
  if (g >= triangles) return;
  double s[15] = {};
  const uint32_t end = lower_bound(key, samples, g + 1);
  for (uint32_t i = lower_bound(key, samples, g); i < end; ++i) add_offset_sample(matches[sample[i]], s);
  for (int k = 0; k < 15; ++k) per_face[g][k] = s[k];
}

// One block of samples in order: sum w r^2 and sum w.
__global__ void rms_kernel(const OffsetMatch* matches, uint32_t samples, double* block_wr2, double* block_w) {
  const uint32_t b = blockIdx.x * blockDim.x + threadIdx.x;
  const uint32_t begin = b * uint32_t(kOffsetRmsBlock);
  if (begin >= samples) return;
  const uint32_t end = min(samples, begin + uint32_t(kOffsetRmsBlock));
  double wr2 = 0, w = 0;
  for (uint32_t i = begin; i < end; ++i) {
    const OffsetMatch& m = matches[i];
    if (m.face < 0) continue;
    wr2 += m.weight * m.residual * m.residual;
    w += m.weight;
  }
  block_wr2[b] = wr2;
  block_w[b] = w;
}

template <class T>
Status upload(DeviceBuffer<T>* buffer, const std::vector<T>& host, const ExecContext& ctx) {
  return buffer->upload(host.data(), std::max<size_t>(host.size(), 1), ctx);  // one element for an empty list
}

class DeviceSampleSet : public OffsetSampleSet {
 public:
  DeviceSampleSet(const OffsetSamples& samples, const ExecContext& ctx) : s_(samples), ctx_(ctx) {}

  // Everything but the output's positions, once.
  Status init() {
    VPR_RETURN_IF_ERROR(upload(&surface_positions_, s_.surface->positions, ctx_));
    VPR_RETURN_IF_ERROR(upload(&surface_indices_, s_.surface->indices, ctx_));
    VPR_RETURN_IF_ERROR(upload(&label_, *s_.label, ctx_));
    VPR_RETURN_IF_ERROR(upload(&indices_, s_.mesh->indices, ctx_));
    VPR_RETURN_IF_ERROR(upload(&vert_start_, *s_.vert_start, ctx_));
    VPR_RETURN_IF_ERROR(upload(&verts_of_, *s_.verts_of, ctx_));
    VPR_RETURN_IF_ERROR(upload(&face_start_, *s_.face_start, ctx_));
    VPR_RETURN_IF_ERROR(upload(&faces_of_, *s_.faces_of, ctx_));
    const size_t nf = triangles(), sf = samples(), blocks = (sf + kOffsetRmsBlock - 1) / kOffsetRmsBlock;
    VPR_RETURN_IF_ERROR(unit_normal_.allocate(std::max<size_t>(nf, 1), ctx_));
    VPR_RETURN_IF_ERROR(per_face_.allocate(std::max<size_t>(nf, 1), ctx_));
    VPR_RETURN_IF_ERROR(matches_.allocate(std::max<size_t>(sf, 1), ctx_));
    VPR_RETURN_IF_ERROR(block_wr2_.allocate(std::max<size_t>(blocks, 1), ctx_));
    VPR_RETURN_IF_ERROR(block_w_.allocate(std::max<size_t>(blocks, 1), ctx_));
    for (DeviceBuffer<uint32_t>* b : {&key_, &key_sorted_, &sample_, &sample_sorted_})
      VPR_RETURN_IF_ERROR(b->allocate(std::max<size_t>(sf, 1), ctx_));
    size_t bytes = 0;
    VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(nullptr, bytes, key_.get(), key_sorted_.get(), sample_.get(),
                                                 sample_sorted_.get(), int(sf), 0, key_bits(), stream()));
    return sort_temp_.allocate(std::max<size_t>(bytes, 1), ctx_);
  }

  Status match(std::vector<OffsetFaceSums>* per_face, double* wr2, double* w) override {
    const uint32_t nf = uint32_t(triangles()), sf = uint32_t(samples());
    per_face->assign(nf, OffsetFaceSums{});
    *wr2 = *w = 0;
    if (nf == 0 || sf == 0) return Status::Ok();
    VPR_RETURN_IF_ERROR(upload(&positions_, s_.mesh->positions, ctx_));
    normal_kernel<<<blocks_for(nf), kBlock, 0, stream()>>>(positions_.get(), indices_.get(), nf, unit_normal_.get());
    VPR_CUDA_LAUNCHED("normal_kernel");
    const OffsetMatchView view{surface_positions_.get(), surface_indices_.get(), label_.get(),      s_.cells,
                               positions_.get(),         indices_.get(),         unit_normal_.get(), vert_start_.get(),
                               verts_of_.get(),          face_start_.get(),      faces_of_.get()};
    match_kernel<<<blocks_for(sf), kBlock, 0, stream()>>>(view, sf, nf, matches_.get(), key_.get(), sample_.get());
    VPR_CUDA_LAUNCHED("match_kernel");
    size_t bytes = sort_temp_.size();
    VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(sort_temp_.get(), bytes, key_.get(), key_sorted_.get(),
                                                 sample_.get(), sample_sorted_.get(), int(sf), 0, key_bits(),
                                                 stream()));
    face_sums_kernel<<<blocks_for(nf), kBlock, 0, stream()>>>(matches_.get(), key_sorted_.get(),
                                                              sample_sorted_.get(), sf, nf, per_face_.get());
    VPR_CUDA_LAUNCHED("face_sums_kernel");
    VPR_RETURN_IF_ERROR(per_face_.download(per_face->data(), nf));
    return rms_sums(wr2, w);
  }

  // The last match's samples, for match_offset_samples.
  Status download_matches(std::vector<OffsetMatch>* matches) {
    VPR_RETURN_IF_ERROR(matches_.download(matches->data(), samples()));
    VPR_CUDA_TRY(cudaStreamSynchronize(stream()));
    return Status::Ok();
  }

 private:
  size_t triangles() const { return s_.mesh->face_count(); }
  size_t samples() const { return s_.surface->face_count(); }
  cudaStream_t stream() const { return stream_of(ctx_); }
  int key_bits() const {  // keys run to triangles() (unmatched)
    int bits = 1;
    while (bits < 32 && (uint64_t(1) << bits) <= triangles()) ++bits;
    return bits;
  }
  // The blocks' sums on the device, then summed in block order here.
  Status rms_sums(double* wr2, double* w) {
    const uint32_t sf = uint32_t(samples());
    const size_t blocks = (sf + kOffsetRmsBlock - 1) / kOffsetRmsBlock;
    rms_kernel<<<blocks_for(blocks), kBlock, 0, stream()>>>(matches_.get(), sf, block_wr2_.get(), block_w_.get());
    VPR_CUDA_LAUNCHED("rms_kernel");
    std::vector<double> host_wr2(blocks), host_w(blocks);
    VPR_RETURN_IF_ERROR(block_wr2_.download(host_wr2.data(), blocks));
    VPR_RETURN_IF_ERROR(block_w_.download(host_w.data(), blocks));
    VPR_CUDA_TRY(cudaStreamSynchronize(stream()));
    for (size_t b = 0; b < blocks; ++b) *wr2 += host_wr2[b], *w += host_w[b];
    return Status::Ok();
  }

  OffsetSamples s_;
  ExecContext ctx_;
  DeviceBuffer<float> surface_positions_, positions_;
  DeviceBuffer<uint32_t> surface_indices_, label_, indices_, vert_start_, verts_of_, face_start_, faces_of_;
  DeviceBuffer<uint32_t> key_, key_sorted_, sample_, sample_sorted_;
  DeviceBuffer<uint8_t> sort_temp_;
  DeviceBuffer<Vec3d> unit_normal_;
  DeviceBuffer<OffsetMatch> matches_;
  DeviceBuffer<OffsetFaceSums> per_face_;
  DeviceBuffer<double> block_wr2_, block_w_;
};

}  // namespace

StatusOr<std::unique_ptr<OffsetSampleSet>> offset_sample_set(const OffsetSamples& samples, const ExecContext& ctx) {
  auto set = std::make_unique<DeviceSampleSet>(samples, ctx);
  VPR_RETURN_IF_ERROR(set->init());
  return std::unique_ptr<OffsetSampleSet>(std::move(set));
}

Status match_offset_samples(const OffsetSamples& s, std::vector<OffsetMatch>* matches, const ExecContext& ctx) {
  const size_t sf = s.surface->face_count();
  matches->assign(sf, OffsetMatch{});
  if (sf == 0 || s.mesh->face_count() == 0) return Status::Ok();
  DeviceSampleSet set(s, ctx);
  VPR_RETURN_IF_ERROR(set.init());
  std::vector<OffsetFaceSums> per_face;
  double wr2 = 0, w = 0;
  VPR_RETURN_IF_ERROR(set.match(&per_face, &wr2, &w));
  return set.download_matches(matches);
}

}  // namespace vpr::cuda
