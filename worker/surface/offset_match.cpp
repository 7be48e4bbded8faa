#include "surface/offset_match.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace vpr::cpu {
namespace {

// The output's unit normals, and the view of the arrays the matching reads.
OffsetMatchView match_view(const OffsetSamples& s, std::vector<Vec3d>* unit_normal) {
  const size_t nf = s.mesh->face_count();
  unit_normal->resize(nf);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t g = r.begin(); g != r.end(); ++g)
      (*unit_normal)[g] = triangle_unit_normal(s.mesh->positions.data(), s.mesh->indices.data(), g);
  });
  return {s.surface->positions.data(), s.surface->indices.data(), s.label->data(), s.cells,
          s.mesh->positions.data(),    s.mesh->indices.data(),    unit_normal->data(), s.vert_start->data(),
          s.verts_of->data(),          s.face_start->data(),      s.faces_of->data()};
}

// Samples [begin, end) matched into out[0, end - begin), in parallel.
void match_range(const OffsetMatchView& view, size_t begin, size_t end, OffsetMatch* out) {
  tbb::parallel_for(tbb::blocked_range<size_t>(begin, end, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f) out[f - begin] = match_offset_sample(view, f);
  });
}

class HostSampleSet : public OffsetSampleSet {
 public:
  explicit HostSampleSet(const OffsetSamples& samples) : samples_(samples) {}

  // Block by block: the block matched in parallel, then its samples added to
  // their triangles' sums in sample order, and its RMS blocks' sums (each
  // kOffsetRmsBlock samples in order) to the totals in order, as the GPU
  // twin sums them.
  Status match(std::vector<OffsetFaceSums>* per_face, double* wr2, double* w) override {
    std::vector<Vec3d> unit_normal;
    const OffsetMatchView view = match_view(samples_, &unit_normal);
    const size_t sf = samples_.surface->face_count();
    per_face->assign(samples_.mesh->face_count(), OffsetFaceSums{});
    *wr2 = *w = 0;
    std::vector<OffsetMatch> block(std::min(sf, kOffsetMatchBlock));
    for (size_t begin = 0; begin < sf; begin += kOffsetMatchBlock) {
      const size_t end = std::min(sf, begin + kOffsetMatchBlock);
      match_range(view, begin, end, block.data());
      for (size_t i = 0; i < end - begin; ++i)
        if (block[i].face >= 0) add_offset_sample(block[i], (*per_face)[size_t(block[i].face)].data());
      for (size_t b = 0; b < end - begin; b += kOffsetRmsBlock) {
        double block_wr2 = 0, block_w = 0;
        for (size_t i = b; i < std::min(end - begin, b + kOffsetRmsBlock); ++i) {
          const OffsetMatch& m = block[i];
          if (m.face < 0) continue;
          block_wr2 += m.weight * m.residual * m.residual;
          block_w += m.weight;
        }
        *wr2 += block_wr2, *w += block_w;
      }
    }
    return Status::Ok();
  }

 private:
  OffsetSamples samples_;
};

}  // namespace

Status match_offset_samples(const OffsetSamples& s, std::vector<OffsetMatch>* matches) {
  std::vector<Vec3d> unit_normal;
  const OffsetMatchView view = match_view(s, &unit_normal);
  matches->assign(s.surface->face_count(), OffsetMatch{});
  match_range(view, 0, matches->size(), matches->data());
  return Status::Ok();
}

std::unique_ptr<OffsetSampleSet> offset_sample_set(const OffsetSamples& samples) {
  return std::make_unique<HostSampleSet>(samples);
}

}  // namespace vpr::cpu
