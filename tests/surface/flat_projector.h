// A DualProjector on the host over the flat lists a device is given
// (dual_projection.h's shared arithmetic, each listed face's sphere made by
// face_sphere as the device makes it): what the GPU twin computes, on any
// machine. fail_at: the call (0 the first) that returns an error instead,
// as a device that fails part way would; -1 never. The calls that answered
// are counted in *counts (which outlives the projector).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "surface/dual_projection.h"

namespace vpr::testing {

struct ProjectorCalls {
  int places = 0, relaxes = 0;
};

class FlatProjector : public DualProjector {
 public:
  FlatProjector(const CellFaceLists& lists, int fail_at, ProjectorCalls* counts)
      : surface_(lists.surface), start_(*lists.start), face_(*lists.face), fail_at_(fail_at), counts_(counts) {
    for (uint32_t f : face_) sphere_.push_back(face_sphere(surface_->positions.data(), surface_->indices.data(), f));
  }

  Status place(const std::vector<Vec3d>& x, const std::vector<Vec3d>& start, std::vector<Vec3d>* placed) override {
    VPR_RETURN_IF_ERROR(call("place"));
    ++counts_->places;
    placed->resize(x.size());
    for (uint32_t c = 0; c < x.size(); ++c) {
      Vec3d best = start[c];
      double best_d = INFINITY;
      const FaceList faces = (*this)(c);
      nearest_on_lists(x[c], &faces, 1, surface_->positions.data(), surface_->indices.data(), &best, &best_d);
      (*placed)[c] = best;
    }
    return Status::Ok();
  }

  Status relax(const RelaxMesh& m, std::vector<Vec3d>* moved) override {
    VPR_RETURN_IF_ERROR(call("relax"));
    ++counts_->relaxes;
    const size_t n = m.mesh->vertex_count();
    std::vector<Vec3d> start(n);
    for (size_t v = 0; v < n; ++v) start[v] = load3d(m.mesh->positions.data(), v);
    const RelaxView view{start.data(),       m.mesh->indices.data(),     m.face_start->data(),
                         m.faces_of->data(), m.freedom->data(),          m.source->data(),
                         m.line->data(),     surface_->positions.data(), surface_->indices.data()};
    moved->resize(n);
    for (uint32_t v = 0; v < n; ++v) (*moved)[v] = relax_move(view, *this, v);
    return Status::Ok();
  }

  FaceList operator()(uint32_t c) const {
    return {face_.data() + start_[c], sphere_.data() + start_[c], start_[c + 1] - start_[c]};
  }

 private:
  Status call(const std::string& what) {
    if (calls_++ == fail_at_) return resource_exhausted("flat projector: " + what + " refused (test)");
    return Status::Ok();
  }

  const Mesh* surface_;
  std::vector<uint32_t> start_, face_;
  std::vector<std::array<float, 4>> sphere_;
  int fail_at_;
  ProjectorCalls* counts_;
  int calls_ = 0;
};

}  // namespace vpr::testing
