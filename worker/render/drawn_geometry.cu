// GPU twin of the drawn geometry (drawn_geometry.h): the host's steps, each
// a kernel or a CUB pass, with the host's arithmetic (this file is compiled
// without FMA contraction) and the host's orders, so the same bits:
// - drawable faces and their normals, compacted by a prefix sum (face order);
// - the weld by exact position: vertex ids sorted by their coordinates' bits,
//   z first then (x, y), both radix sorts stable, so ties stay by id as the
//   host's comparison sort orders them;
// - the corners at each welded vertex, by a stable sort of corner ids by
//   welded vertex: in corner order, as the host sorts each list;
// - per welded vertex, one thread: its corners' smooth normals and (indexed)
//   which corners share a drawn vertex, the host's loops as they are.
#include <cub/cub.cuh>

#include <algorithm>
#include <cmath>
#include <string>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "render/corner_normals.h"
#include "render/drawn_geometry.h"

namespace vpr::cuda {
namespace {

__global__ void face_kernel(const float* pos, const uint32_t* idx, uint32_t nf, Vec3d centre, Vec3d* normal,
                            uint32_t* keep) {
  const uint32_t f = blockIdx.x * blockDim.x + threadIdx.x;
  if (f >= nf) return;
  const Vec3d a = load3d(pos, idx[3 * size_t(f)]) - centre;
  const Vec3d b = load3d(pos, idx[3 * size_t(f) + 1]) - centre;
  const Vec3d c = load3d(pos, idx[3 * size_t(f) + 2]) - centre;
  const Vec3d n = cross(b - a, c - a);
  normal[f] = n;
  const double len = norm(n);
  keep[f] = (len > 0.0) && isfinite(len);
}

__global__ void compact_kernel(const Vec3d* normal, const uint32_t* keep, const uint32_t* slot, uint32_t nf,
                               Vec3* face_normal, Vec3d* area_normal, uint32_t* kept_faces) {
  const uint32_t f = blockIdx.x * blockDim.x + threadIdx.x;
  if (f >= nf || !keep[f]) return;
  const uint32_t k = slot[f];
  const Vec3d n = normal[f];
  const double len = norm(n);
  face_normal[k] = Vec3{float(n.x / len), float(n.y / len), float(n.z / len)};
  area_normal[k] = n;
  kept_faces[k] = f;
}

__global__ void z_keys_kernel(const float* pos, uint32_t nv, uint32_t* key, uint32_t* id) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= nv) return;
  key[v] = __float_as_uint(pos[3 * size_t(v) + 2]);
  id[v] = v;
}

__global__ void xy_keys_kernel(const float* pos, const uint32_t* order, uint32_t nv, unsigned long long* key) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= nv) return;
  const size_t v = order[i];
  key[i] = (static_cast<unsigned long long>(__float_as_uint(pos[3 * v])) << 32) | __float_as_uint(pos[3 * v + 1]);
}

// 1 where the i-th vertex in weld order starts a new position.
__global__ void weld_starts_kernel(const float* pos, const uint32_t* order, uint32_t nv, uint32_t* start) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= nv) return;
  if (i == 0) {
    start[i] = 0;
    return;
  }
  const size_t a = order[i], b = order[i - 1];
  start[i] = __float_as_uint(pos[3 * a]) != __float_as_uint(pos[3 * b]) ||
             __float_as_uint(pos[3 * a + 1]) != __float_as_uint(pos[3 * b + 1]) ||
             __float_as_uint(pos[3 * a + 2]) != __float_as_uint(pos[3 * b + 2]);
}

__global__ void weld_scatter_kernel(const uint32_t* order, const uint32_t* group, uint32_t nv, uint32_t* weld) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < nv) weld[order[i]] = group[i];
}

// Each corner's welded vertex, and the corners per welded vertex (count[g + 1]).
__global__ void corner_keys_kernel(const uint32_t* idx, const uint32_t* kept_faces, const uint32_t* weld, uint32_t nc,
                                   uint32_t* key, uint32_t* id, uint32_t* count) {
  const uint32_t c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= nc) return;
  const uint32_t g = weld[idx[3 * size_t(kept_faces[c / 3]) + c % 3]];
  key[c] = g;
  id[c] = c;
  atomicAdd(&count[g + 1], 1u);
}

// corner_normals' per-vertex loop (corner_normals.cpp), one thread a welded vertex.
__global__ void corner_normal_kernel(const uint32_t* start, const uint32_t* corners, const Vec3* face_normal,
                                     const Vec3d* area_normal, uint32_t groups, float min_cos, Vec3* normal) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= groups) return;
  const uint32_t first = start[v], k = start[v + 1] - first;
  for (uint32_t i = 0; i < k; ++i) {
    const Vec3 own = face_normal[corners[first + i] / 3];
    Vec3d acc{0, 0, 0};
    for (uint32_t j = 0; j < k; ++j) {
      const float cosine = dot(face_normal[corners[first + j] / 3], own);
      if (fabsf(cosine) < min_cos) continue;
      acc = acc + (cosine < 0 ? -1.0 : 1.0) * area_normal[corners[first + j] / 3];
    }
    const double len = norm(acc);
    normal[corners[first + i]] = len > 0 ? Vec3{float(acc.x / len), float(acc.y / len), float(acc.z / len)} : own;
  }
}

__device__ bool same_gray(Vec3 a, Vec3 b) {
  return (a.x == b.x && a.y == b.y && a.z == b.z) || (a.x == -b.x && a.y == -b.y && a.z == -b.z);
}

// share_corners' first loop (corner_normals.cpp): each corner's first equal
// corner at its position, and how many distinct ones (distinct[v + 1]).
__global__ void share_first_kernel(const uint32_t* start, const uint32_t* corners, const Vec3* normal, uint32_t groups,
                                   uint32_t* first, uint32_t* distinct) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= groups) return;
  uint32_t count = 0;
  for (uint32_t i = start[v]; i < start[v + 1]; ++i) {
    const uint32_t c = corners[i];
    uint32_t j = start[v];
    while (j < i && !(first[corners[j]] == corners[j] && same_gray(normal[corners[j]], normal[c]))) ++j;
    first[c] = j < i ? corners[j] : c;
    count += first[c] == c;
  }
  distinct[v + 1] = count;
}

// share_corners' second loop: the shared vertices numbered by position, then by first corner.
__global__ void share_fill_kernel(const uint32_t* start, const uint32_t* corners, const uint32_t* first,
                                  const uint32_t* distinct, uint32_t groups, uint32_t* shared_corner, uint32_t* index) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= groups) return;
  uint32_t next = distinct[v];
  for (uint32_t i = start[v]; i < start[v + 1]; ++i) {
    const uint32_t c = corners[i];
    if (first[c] != c) continue;
    shared_corner[next] = c;
    index[c] = next++;
  }
  for (uint32_t i = start[v]; i < start[v + 1]; ++i) {
    const uint32_t c = corners[i];
    if (first[c] != c) index[c] = index[first[c]];
  }
}

// The drawn vertices' positions (and, indexed, their normals).
__global__ void drawn_kernel(const float* pos, const uint32_t* idx, const uint32_t* kept_faces,
                             const uint32_t* shared_corner, const Vec3* normal, uint32_t drawn, Vec3d centre,
                             float* positions, Vec3* drawn_normal) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= drawn) return;
  const uint32_t c = shared_corner ? shared_corner[i] : i;
  if (shared_corner) drawn_normal[i] = normal[c];
  const Vec3d p = load3d(pos, idx[3 * size_t(kept_faces[c / 3]) + c % 3]) - centre;
  positions[3 * size_t(i)] = float(p.x);
  positions[3 * size_t(i) + 1] = float(p.y);
  positions[3 * size_t(i) + 2] = float(p.z);
}

// CUB's scratch space, grown to the largest pass's need.
class Scratch {
 public:
  explicit Scratch(const ExecContext& ctx) : ctx_(ctx) {}
  Status reserve(size_t bytes) {
    if (bytes <= buffer_.size()) return Status::Ok();
    return buffer_.allocate(bytes, ctx_);
  }
  void* get() { return buffer_.get(); }
  size_t size() const { return buffer_.size(); }

 private:
  const ExecContext& ctx_;
  DeviceBuffer<uint8_t> buffer_;
};

Status fetch_scalar(const uint32_t* device, uint32_t* host, cudaStream_t stream) {
  VPR_CUDA_TRY(cudaMemcpyAsync(host, device, sizeof(uint32_t), cudaMemcpyDeviceToHost, stream));
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

// In-place inclusive prefix sum of n values.
Status inclusive_sum(uint32_t* values, size_t n, Scratch* scratch, cudaStream_t stream) {
  size_t bytes = 0;
  VPR_CUDA_TRY(cub::DeviceScan::InclusiveSum(nullptr, bytes, values, values, int(n), stream));
  VPR_RETURN_IF_ERROR(scratch->reserve(bytes));
  bytes = scratch->size();
  VPR_CUDA_TRY(cub::DeviceScan::InclusiveSum(scratch->get(), bytes, values, values, int(n), stream));
  return Status::Ok();
}

template <class Key>
Status sort_pairs(const Key* key_in, Key* key_out, const uint32_t* value_in, uint32_t* value_out, size_t n,
                  int end_bit, Scratch* scratch, cudaStream_t stream) {
  size_t bytes = 0;
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(nullptr, bytes, key_in, key_out, value_in, value_out, int(n), 0,
                                               end_bit, stream));
  VPR_RETURN_IF_ERROR(scratch->reserve(bytes));
  bytes = scratch->size();
  VPR_CUDA_TRY(cub::DeviceRadixSort::SortPairs(scratch->get(), bytes, key_in, key_out, value_in, value_out, int(n), 0,
                                               end_bit, stream));
  return Status::Ok();
}

int bits_for(uint32_t largest) {
  int bits = 1;
  while (bits < 32 && (largest >> bits) != 0) ++bits;
  return bits;
}

}  // namespace

Status drawn_geometry(const Mesh& mesh, bool indexed, DrawnGeometry* out, const ExecContext& ctx) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (nv >= (size_t(1) << 31) || 3 * nf >= (size_t(1) << 31))
    return resource_exhausted("drawn geometry on the GPU: at most 2^31 vertices and corners");
  *out = DrawnGeometry{};
  out->indexed = indexed;
  const Aabb box = bounding_box(mesh);
  const Vec3d centre{0.5 * (double(box.lo[0]) + box.hi[0]), 0.5 * (double(box.lo[1]) + box.hi[1]),
                     0.5 * (double(box.lo[2]) + box.hi[2])};
  out->centre = centre;
  if (nv == 0 || nf == 0) return Status::Ok();
  const cudaStream_t stream = stream_of(ctx);
  Scratch scratch(ctx);

  DeviceBuffer<float> pos;
  DeviceBuffer<uint32_t> idx;
  VPR_RETURN_IF_ERROR(pos.upload(mesh.positions.data(), 3 * nv, ctx));
  VPR_RETURN_IF_ERROR(idx.upload(mesh.indices.data(), 3 * nf, ctx));

  // Drawable faces, compacted in face order.
  DeviceBuffer<Vec3d> all_normals;
  DeviceBuffer<uint32_t> slot;  // nf + 1: keep flags, then their inclusive sums shifted by one
  VPR_RETURN_IF_ERROR(all_normals.allocate(nf, ctx));
  VPR_RETURN_IF_ERROR(slot.allocate(nf + 1, ctx));
  VPR_CUDA_TRY(cudaMemsetAsync(slot.get(), 0, sizeof(uint32_t), stream));
  face_kernel<<<blocks_for(nf), kBlock, 0, stream>>>(pos.get(), idx.get(), uint32_t(nf), centre, all_normals.get(),
                                                     slot.get() + 1);
  VPR_CUDA_LAUNCHED("face_kernel");
  DeviceBuffer<uint32_t> keep;
  VPR_RETURN_IF_ERROR(keep.allocate(nf, ctx));
  VPR_CUDA_TRY(cudaMemcpyAsync(keep.get(), slot.get() + 1, nf * sizeof(uint32_t), cudaMemcpyDeviceToDevice, stream));
  VPR_RETURN_IF_ERROR(inclusive_sum(slot.get() + 1, nf, &scratch, stream));
  uint32_t kept = 0;
  VPR_RETURN_IF_ERROR(fetch_scalar(slot.get() + nf, &kept, stream));
  if (kept == 0) return Status::Ok();
  DeviceBuffer<Vec3> face_normals;
  DeviceBuffer<Vec3d> area_normals;
  DeviceBuffer<uint32_t> kept_faces;
  VPR_RETURN_IF_ERROR(face_normals.allocate(kept, ctx));
  VPR_RETURN_IF_ERROR(area_normals.allocate(kept, ctx));
  VPR_RETURN_IF_ERROR(kept_faces.allocate(kept, ctx));
  compact_kernel<<<blocks_for(nf), kBlock, 0, stream>>>(all_normals.get(), keep.get(), slot.get(), uint32_t(nf),
                                                        face_normals.get(), area_normals.get(), kept_faces.get());
  VPR_CUDA_LAUNCHED("compact_kernel");
  all_normals = {};
  slot = {};
  keep = {};

  // The weld: vertex ids in the order of their coordinates' bits, ties by id.
  DeviceBuffer<uint32_t> weld;
  uint32_t groups = 0;
  {
    DeviceBuffer<uint32_t> z_key, z_key_sorted, id, order_z, order;
    DeviceBuffer<unsigned long long> xy_key, xy_key_sorted;
    VPR_RETURN_IF_ERROR(z_key.allocate(nv, ctx));
    VPR_RETURN_IF_ERROR(z_key_sorted.allocate(nv, ctx));
    VPR_RETURN_IF_ERROR(id.allocate(nv, ctx));
    VPR_RETURN_IF_ERROR(order_z.allocate(nv, ctx));
    z_keys_kernel<<<blocks_for(nv), kBlock, 0, stream>>>(pos.get(), uint32_t(nv), z_key.get(), id.get());
    VPR_CUDA_LAUNCHED("z_keys_kernel");
    VPR_RETURN_IF_ERROR(sort_pairs(z_key.get(), z_key_sorted.get(), id.get(), order_z.get(), nv, 32, &scratch, stream));
    z_key = {};
    z_key_sorted = {};
    VPR_RETURN_IF_ERROR(xy_key.allocate(nv, ctx));
    VPR_RETURN_IF_ERROR(xy_key_sorted.allocate(nv, ctx));
    VPR_RETURN_IF_ERROR(order.allocate(nv, ctx));
    xy_keys_kernel<<<blocks_for(nv), kBlock, 0, stream>>>(pos.get(), order_z.get(), uint32_t(nv), xy_key.get());
    VPR_CUDA_LAUNCHED("xy_keys_kernel");
    VPR_RETURN_IF_ERROR(
        sort_pairs(xy_key.get(), xy_key_sorted.get(), order_z.get(), order.get(), nv, 64, &scratch, stream));
    xy_key = {};
    xy_key_sorted = {};
    DeviceBuffer<uint32_t>& group = id;  // reused: the welded vertex of each position in weld order
    weld_starts_kernel<<<blocks_for(nv), kBlock, 0, stream>>>(pos.get(), order.get(), uint32_t(nv), group.get());
    VPR_CUDA_LAUNCHED("weld_starts_kernel");
    VPR_RETURN_IF_ERROR(inclusive_sum(group.get(), nv, &scratch, stream));
    VPR_RETURN_IF_ERROR(weld.allocate(nv, ctx));
    weld_scatter_kernel<<<blocks_for(nv), kBlock, 0, stream>>>(order.get(), group.get(), uint32_t(nv), weld.get());
    VPR_CUDA_LAUNCHED("weld_scatter_kernel");
    VPR_RETURN_IF_ERROR(fetch_scalar(group.get() + nv - 1, &groups, stream));
    ++groups;
  }

  // The corners at each welded vertex (CSR), in corner order.
  const size_t nc = 3 * size_t(kept);
  DeviceBuffer<uint32_t> start, corners;
  {
    DeviceBuffer<uint32_t> key, key_sorted, id;
    VPR_RETURN_IF_ERROR(key.allocate(nc, ctx));
    VPR_RETURN_IF_ERROR(key_sorted.allocate(nc, ctx));
    VPR_RETURN_IF_ERROR(id.allocate(nc, ctx));
    VPR_RETURN_IF_ERROR(start.allocate(size_t(groups) + 1, ctx));
    VPR_RETURN_IF_ERROR(start.zero());
    corner_keys_kernel<<<blocks_for(nc), kBlock, 0, stream>>>(idx.get(), kept_faces.get(), weld.get(), uint32_t(nc),
                                                             key.get(), id.get(), start.get());
    VPR_CUDA_LAUNCHED("corner_keys_kernel");
    VPR_RETURN_IF_ERROR(inclusive_sum(start.get(), size_t(groups) + 1, &scratch, stream));
    VPR_RETURN_IF_ERROR(corners.allocate(nc, ctx));
    VPR_RETURN_IF_ERROR(
        sort_pairs(key.get(), key_sorted.get(), id.get(), corners.get(), nc, bits_for(groups - 1), &scratch, stream));
  }
  weld = {};

  DeviceBuffer<Vec3> normal;
  VPR_RETURN_IF_ERROR(normal.allocate(nc, ctx));
  const float min_cos = float(std::cos(gl::kSmoothingAngleDeg * M_PI / 180.0));
  corner_normal_kernel<<<blocks_for(groups), kBlock, 0, stream>>>(start.get(), corners.get(), face_normals.get(),
                                                                  area_normals.get(), groups, min_cos, normal.get());
  VPR_CUDA_LAUNCHED("corner_normal_kernel");
  face_normals = {};
  area_normals = {};

  uint32_t drawn = uint32_t(nc);
  DeviceBuffer<uint32_t> shared_corner, index;
  if (indexed) {
    DeviceBuffer<uint32_t> first, distinct;
    VPR_RETURN_IF_ERROR(first.allocate(nc, ctx));
    VPR_RETURN_IF_ERROR(distinct.allocate(size_t(groups) + 1, ctx));
    VPR_CUDA_TRY(cudaMemsetAsync(distinct.get(), 0, sizeof(uint32_t), stream));
    share_first_kernel<<<blocks_for(groups), kBlock, 0, stream>>>(start.get(), corners.get(), normal.get(), groups,
                                                                  first.get(), distinct.get());
    VPR_CUDA_LAUNCHED("share_first_kernel");
    VPR_RETURN_IF_ERROR(inclusive_sum(distinct.get(), size_t(groups) + 1, &scratch, stream));
    VPR_RETURN_IF_ERROR(fetch_scalar(distinct.get() + groups, &drawn, stream));
    VPR_RETURN_IF_ERROR(shared_corner.allocate(std::max<uint32_t>(drawn, 1), ctx));
    VPR_RETURN_IF_ERROR(index.allocate(nc, ctx));
    share_fill_kernel<<<blocks_for(groups), kBlock, 0, stream>>>(start.get(), corners.get(), first.get(),
                                                                 distinct.get(), groups, shared_corner.get(),
                                                                 index.get());
    VPR_CUDA_LAUNCHED("share_fill_kernel");
  }
  start = {};
  corners = {};

  DeviceBuffer<float> positions;
  DeviceBuffer<Vec3> drawn_normal;
  VPR_RETURN_IF_ERROR(positions.allocate(3 * size_t(drawn), ctx));
  if (indexed) VPR_RETURN_IF_ERROR(drawn_normal.allocate(std::max<uint32_t>(drawn, 1), ctx));
  drawn_kernel<<<blocks_for(drawn), kBlock, 0, stream>>>(pos.get(), idx.get(), kept_faces.get(),
                                                         indexed ? shared_corner.get() : nullptr, normal.get(), drawn,
                                                         centre, positions.get(), drawn_normal.get());
  VPR_CUDA_LAUNCHED("drawn_kernel");

  out->corners = nc;
  out->positions.resize(3 * size_t(drawn));
  out->normals.resize(drawn);
  VPR_RETURN_IF_ERROR(positions.download(out->positions.data(), out->positions.size()));
  VPR_RETURN_IF_ERROR((indexed ? drawn_normal : normal).download(out->normals.data(), drawn));
  if (indexed) {
    out->indices.resize(nc);
    VPR_RETURN_IF_ERROR(index.download(out->indices.data(), nc));
  }
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

}  // namespace vpr::cuda
