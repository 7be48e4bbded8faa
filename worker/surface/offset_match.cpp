#include "surface/offset_match.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace vpr::cpu {

Status match_offset_samples(const OffsetSamples& s, std::vector<OffsetMatch>* matches) {
  const size_t nf = s.mesh->face_count(), sf = s.surface->face_count();
  std::vector<Vec3d> unit_normal(nf);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t g = r.begin(); g != r.end(); ++g)
      unit_normal[g] = triangle_unit_normal(s.mesh->positions.data(), s.mesh->indices.data(), g);
  });
  const OffsetMatchView view{s.surface->positions.data(), s.surface->indices.data(), s.label->data(), s.cells,
                             s.mesh->positions.data(),    s.mesh->indices.data(),    unit_normal.data(),
                             s.vert_start->data(),        s.verts_of->data(),        s.face_start->data(),
                             s.faces_of->data()};
  matches->assign(sf, OffsetMatch{});
  tbb::parallel_for(tbb::blocked_range<size_t>(0, sf, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f) (*matches)[f] = match_offset_sample(view, f);
  });
  return Status::Ok();
}

}  // namespace vpr::cpu
