// GPU twin of the dual's projections (dual_projection.h): the surface and
// the cells' face lists go up once per dual, with each listed face's
// bounding sphere made there; then one thread a cell places the cells'
// vertices, and one thread a vertex makes each relaxation round's moves
// (relax_move's arithmetic, compiled without FMA contraction). Only the
// positions cross over; the host's bits.
#include <algorithm>
#include <array>
#include <memory>
#include <utility>
#include <vector>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "surface/dual_projection.h"

namespace vpr::cuda {
namespace {

using Sphere = std::array<float, 4>;

// Cell c's faces in the flat lists.
struct DeviceLists {
  const uint32_t* start;
  const uint32_t* face;
  const Sphere* sphere;
  __device__ FaceList operator()(uint32_t c) const {
    return {face + start[c], sphere + start[c], start[c + 1] - start[c]};
  }
};

__global__ void sphere_kernel(const float* positions, const uint32_t* indices, const uint32_t* face, uint32_t n,
                              Sphere* sphere) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) sphere[i] = face_sphere(positions, indices, face[i]);
}

__global__ void place_kernel(DeviceLists lists, const float* positions, const uint32_t* indices, const Vec3d* x,
                             const Vec3d* start, uint32_t cells, Vec3d* placed) {
  const uint32_t c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= cells) return;
  Vec3d best = start[c];
  double best_d = INFINITY;
  const FaceList faces = lists(c);
  nearest_on_lists(x[c], &faces, 1, positions, indices, &best, &best_d);
  placed[c] = best;
}

__global__ void widen_kernel(const float* positions, uint32_t n, Vec3d* out) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < n) out[v] = load3d(positions, v);
}

__global__ void relax_kernel(RelaxView view, DeviceLists lists, uint32_t n, Vec3d* moved) {
  const uint32_t v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < n) moved[v] = relax_move(view, lists, v);
}

template <class T>
Status upload(DeviceBuffer<T>* buffer, const std::vector<T>& host, const ExecContext& ctx) {
  return buffer->upload(host.data(), std::max<size_t>(host.size(), 1), ctx);  // one element for an empty list
}

class DeviceProjector : public DualProjector {
 public:
  explicit DeviceProjector(const ExecContext& ctx) : ctx_(ctx) {}

  // The lists are read here only (the host may drop them after).
  Status init(const CellFaceLists& lists) {
    if (lists.start->empty() || lists.face->size() != lists.start->back())
      return invalid_argument("dual projector: the face lists do not match their starts");
    for (uint32_t f : *lists.face)
      if (f >= lists.surface->face_count()) return invalid_argument("dual projector: a listed face out of range");
    cells_ = uint32_t(lists.start->size() - 1);
    VPR_RETURN_IF_ERROR(upload(&surface_positions_, lists.surface->positions, ctx_));
    VPR_RETURN_IF_ERROR(upload(&surface_indices_, lists.surface->indices, ctx_));
    VPR_RETURN_IF_ERROR(upload(&start_, *lists.start, ctx_));
    VPR_RETURN_IF_ERROR(upload(&face_, *lists.face, ctx_));
    const uint32_t n = uint32_t(lists.face->size());
    VPR_RETURN_IF_ERROR(sphere_.allocate(std::max<size_t>(n, 1), ctx_));
    if (n > 0) {
      sphere_kernel<<<blocks_for(n), kBlock, 0, stream()>>>(surface_positions_.get(), surface_indices_.get(),
                                                            face_.get(), n, sphere_.get());
      VPR_CUDA_LAUNCHED("sphere_kernel");
    }
    return Status::Ok();
  }

  Status place(const std::vector<Vec3d>& x, const std::vector<Vec3d>& start, std::vector<Vec3d>* placed) override {
    const uint32_t cells = cell_count();
    if (x.size() != cells || start.size() != cells)
      return invalid_argument("dual projector: one point per cell expected");
    placed->assign(cells, Vec3d{});
    if (cells == 0) return Status::Ok();
    DeviceBuffer<Vec3d> x_on, start_on, placed_on;
    VPR_RETURN_IF_ERROR(upload(&x_on, x, ctx_));
    VPR_RETURN_IF_ERROR(upload(&start_on, start, ctx_));
    VPR_RETURN_IF_ERROR(placed_on.allocate(cells, ctx_));
    place_kernel<<<blocks_for(cells), kBlock, 0, stream()>>>(lists(), surface_positions_.get(), surface_indices_.get(),
                                                             x_on.get(), start_on.get(), cells, placed_on.get());
    VPR_CUDA_LAUNCHED("place_kernel");
    VPR_RETURN_IF_ERROR(placed_on.download(placed->data(), cells));
    VPR_CUDA_TRY(cudaStreamSynchronize(stream()));
    return Status::Ok();
  }

  Status relax(const RelaxMesh& m, std::vector<Vec3d>* moved) override {
    const uint32_t n = uint32_t(m.mesh->vertex_count());
    if (m.face_start->size() != size_t(n) + 1 || m.freedom->size() != n || m.source->size() != n ||
        m.line->size() != cell_count())
      return invalid_argument("dual projector: the relaxation's arrays do not match its mesh");
    for (uint32_t cell : *m.source)
      if (cell >= cell_count()) return invalid_argument("dual projector: a vertex of a cell it was not given");
    moved->assign(n, Vec3d{});
    if (n == 0) return Status::Ok();
    DeviceBuffer<float> positions;
    DeviceBuffer<uint32_t> indices, face_start, faces_of, source;
    DeviceBuffer<Freedom> freedom;
    DeviceBuffer<Vec3d> line, start, moved_on;
    VPR_RETURN_IF_ERROR(upload(&positions, m.mesh->positions, ctx_));
    VPR_RETURN_IF_ERROR(upload(&indices, m.mesh->indices, ctx_));
    VPR_RETURN_IF_ERROR(upload(&face_start, *m.face_start, ctx_));
    VPR_RETURN_IF_ERROR(upload(&faces_of, *m.faces_of, ctx_));
    VPR_RETURN_IF_ERROR(upload(&source, *m.source, ctx_));
    VPR_RETURN_IF_ERROR(upload(&freedom, *m.freedom, ctx_));
    VPR_RETURN_IF_ERROR(upload(&line, *m.line, ctx_));
    VPR_RETURN_IF_ERROR(start.allocate(n, ctx_));
    VPR_RETURN_IF_ERROR(moved_on.allocate(n, ctx_));
    widen_kernel<<<blocks_for(n), kBlock, 0, stream()>>>(positions.get(), n, start.get());
    VPR_CUDA_LAUNCHED("widen_kernel");
    const RelaxView view{start.get(),  indices.get(), face_start.get(),         faces_of.get(),        freedom.get(),
                         source.get(), line.get(),    surface_positions_.get(), surface_indices_.get()};
    relax_kernel<<<blocks_for(n), kBlock, 0, stream()>>>(view, lists(), n, moved_on.get());
    VPR_CUDA_LAUNCHED("relax_kernel");
    VPR_RETURN_IF_ERROR(moved_on.download(moved->data(), n));
    VPR_CUDA_TRY(cudaStreamSynchronize(stream()));
    return Status::Ok();
  }

 private:
  uint32_t cell_count() const { return cells_; }
  DeviceLists lists() const { return {start_.get(), face_.get(), sphere_.get()}; }
  cudaStream_t stream() const { return stream_of(ctx_); }

  ExecContext ctx_;
  uint32_t cells_ = 0;
  DeviceBuffer<float> surface_positions_;
  DeviceBuffer<uint32_t> surface_indices_, start_, face_;
  DeviceBuffer<Sphere> sphere_;
};

}  // namespace

StatusOr<std::unique_ptr<DualProjector>> dual_projector(const CellFaceLists& lists, const ExecContext& ctx) {
  auto projector = std::make_unique<DeviceProjector>(ctx);
  VPR_RETURN_IF_ERROR(projector->init(lists));
  return std::unique_ptr<DualProjector>(std::move(projector));
}

}  // namespace vpr::cuda
