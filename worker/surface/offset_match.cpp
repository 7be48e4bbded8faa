#include "surface/offset_match.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace vpr::cpu {
namespace {

// sum w r^2 and sum w over blocks of kOffsetRmsBlock samples, then the blocks
// in order; residual(i): sample i's residual.
template <class Residual>
void rms_sums(const std::vector<OffsetMatch>& m, Residual&& residual, double* wr2, double* w) {
  const size_t blocks = (m.size() + kOffsetRmsBlock - 1) / kOffsetRmsBlock;
  std::vector<double> block_wr2(blocks, 0.0), block_w(blocks, 0.0);
  tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
    for (size_t i = b * kOffsetRmsBlock; i < std::min(m.size(), (b + 1) * kOffsetRmsBlock); ++i) {
      if (m[i].face < 0) continue;
      const double r = residual(i);
      block_wr2[b] += m[i].weight * r * r;
      block_w[b] += m[i].weight;
    }
  });
  *wr2 = 0;
  *w = 0;
  for (size_t b = 0; b < blocks; ++b) *wr2 += block_wr2[b], *w += block_w[b];
}

class HostSampleSet : public OffsetSampleSet {
 public:
  explicit HostSampleSet(const OffsetSamples& samples) : samples_(samples) {}

  Status match(std::vector<OffsetFaceSums>* per_face, double* wr2, double* w) override {
    VPR_RETURN_IF_ERROR(match_offset_samples(samples_, &matches_));
    // Per triangle in sample order: one loop (the samples of a triangle lie
    // scattered; a sort by triangle first cost more than it saved).
    per_face->assign(samples_.mesh->face_count(), OffsetFaceSums{});
    for (const OffsetMatch& m : matches_)
      if (m.face >= 0) add_offset_sample(m, (*per_face)[size_t(m.face)].data());
    rms_sums(matches_, [&](size_t i) { return matches_[i].residual; }, wr2, w);
    return Status::Ok();
  }

  Status sums_after(const std::vector<Vec3d>& vertex_normal, const std::vector<double>& delta, double* wr2,
                    double* w) override {
    const uint32_t* indices = samples_.mesh->indices.data();
    rms_sums(
        matches_, [&](size_t i) { return residual_after(matches_[i], indices, vertex_normal.data(), delta.data()); },
        wr2, w);
    return Status::Ok();
  }

 private:
  OffsetSamples samples_;
  std::vector<OffsetMatch> matches_;
};

}  // namespace

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

std::unique_ptr<OffsetSampleSet> offset_sample_set(const OffsetSamples& samples) {
  return std::make_unique<HostSampleSet>(samples);
}

}  // namespace vpr::cpu
