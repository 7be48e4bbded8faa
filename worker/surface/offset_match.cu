// GPU twin of the L2 fit's matching (offset_match.h): one thread a triangle
// for the unit normals, then one a sample, with the arithmetic of
// match_offset_sample: the host's matches, bit for bit.
#include <algorithm>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "surface/offset_match.h"

namespace vpr::cuda {
namespace {

__global__ void normal_kernel(const float* positions, const uint32_t* indices, uint32_t triangles, Vec3d* unit_normal) {
  const uint32_t g = blockIdx.x * blockDim.x + threadIdx.x;
  if (g < triangles) unit_normal[g] = triangle_unit_normal(positions, indices, g);
}

__global__ void match_kernel(OffsetMatchView view, uint32_t samples, OffsetMatch* matches) {
  const uint32_t f = blockIdx.x * blockDim.x + threadIdx.x;
  if (f < samples) matches[f] = match_offset_sample(view, f);
}

template <class T>
Status upload(DeviceBuffer<T>* buffer, const std::vector<T>& host, const ExecContext& ctx) {
  return buffer->upload(host.data(), std::max<size_t>(host.size(), 1), ctx);  // one element for an empty list
}

}  // namespace

Status match_offset_samples(const OffsetSamples& s, std::vector<OffsetMatch>* matches, const ExecContext& ctx) {
  const size_t nf = s.mesh->face_count(), sf = s.surface->face_count();
  matches->assign(sf, OffsetMatch{});
  if (sf == 0 || nf == 0) return Status::Ok();
  const cudaStream_t stream = stream_of(ctx);
  DeviceBuffer<float> surface_positions, positions;
  DeviceBuffer<uint32_t> surface_indices, label, indices, vert_start, verts_of, face_start, faces_of;
  DeviceBuffer<Vec3d> unit_normal;
  DeviceBuffer<OffsetMatch> d_matches;
  VPR_RETURN_IF_ERROR(upload(&surface_positions, s.surface->positions, ctx));
  VPR_RETURN_IF_ERROR(upload(&surface_indices, s.surface->indices, ctx));
  VPR_RETURN_IF_ERROR(upload(&label, *s.label, ctx));
  VPR_RETURN_IF_ERROR(upload(&positions, s.mesh->positions, ctx));
  VPR_RETURN_IF_ERROR(upload(&indices, s.mesh->indices, ctx));
  VPR_RETURN_IF_ERROR(upload(&vert_start, *s.vert_start, ctx));
  VPR_RETURN_IF_ERROR(upload(&verts_of, *s.verts_of, ctx));
  VPR_RETURN_IF_ERROR(upload(&face_start, *s.face_start, ctx));
  VPR_RETURN_IF_ERROR(upload(&faces_of, *s.faces_of, ctx));
  VPR_RETURN_IF_ERROR(unit_normal.allocate(nf, ctx));
  VPR_RETURN_IF_ERROR(d_matches.allocate(sf, ctx));
  normal_kernel<<<blocks_for(nf), kBlock, 0, stream>>>(positions.get(), indices.get(), uint32_t(nf), unit_normal.get());
  VPR_CUDA_LAUNCHED("normal_kernel");
  const OffsetMatchView view{surface_positions.get(), surface_indices.get(), label.get(),      s.cells,
                             positions.get(),         indices.get(),         unit_normal.get(), vert_start.get(),
                             verts_of.get(),          face_start.get(),      faces_of.get()};
  match_kernel<<<blocks_for(sf), kBlock, 0, stream>>>(view, uint32_t(sf), d_matches.get());
  VPR_CUDA_LAUNCHED("match_kernel");
  VPR_RETURN_IF_ERROR(d_matches.download(matches->data(), sf));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

}  // namespace vpr::cuda
