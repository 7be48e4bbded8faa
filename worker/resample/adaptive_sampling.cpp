// Stage 5 (Section IV-B, Eq. 7-16): visual quantity, exact integer sample
// counts, and uniform / inverse-CDF sampling of each triangle. The per-element
// math lives in sampling_kernels.h, shared with the GPU twin.
#include "resample/adaptive_sampling.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace vpr {

Status check_importance(const float* importance, size_t vertex_count) {
  for (size_t v = 0; v < vertex_count; ++v) {
    if (!(importance[v] >= 0.0f) || !std::isfinite(importance[v]))
      return invalid_argument("visual quantity: vertex " + std::to_string(v) + " has importance " +
                              std::to_string(importance[v]) + ", it must be finite and >= 0");
  }
  return Status::Ok();
}

Status check_quantities(const double* quantity, size_t face_count, double* max_quantity) {
  double largest = 0.0;
  for (size_t f = 0; f < face_count; ++f) {
    const double q = quantity[f];
    if (!(q >= 0.0) || !std::isfinite(q))
      return invalid_argument("sample counts: face " + std::to_string(f) + " has visual quantity " + std::to_string(q) +
                              ", it must be finite and >= 0");
    largest = std::max(largest, q);
  }
  if (!(largest > 0.0)) return invalid_argument("zero visual quantity: all faces degenerate");
  *max_quantity = largest;
  return Status::Ok();
}

Status check_offsets(const uint32_t* counts, const uint32_t* offsets, size_t face_count) {
  if (offsets[0] != 0) return invalid_argument("sampling: offsets[0] = " + std::to_string(offsets[0]) + ", not 0");
  for (size_t f = 0; f < face_count; ++f) {
    if (uint64_t(offsets[f]) + counts[f] != offsets[f + 1])
      return invalid_argument("sampling: offsets[" + std::to_string(f + 1) + "] = " + std::to_string(offsets[f + 1]) +
                              " is not offsets[" + std::to_string(f) + "] + counts[" + std::to_string(f) +
                              "] = " + std::to_string(uint64_t(offsets[f]) + counts[f]));
  }
  return Status::Ok();
}

namespace cpu {

Status visual_quantity(const Mesh& mesh, const float* importance, std::vector<double>* quantity, const ExecContext&) {
  assert(quantity != nullptr && importance != nullptr);
  const size_t nf = mesh.face_count();
  VPR_RETURN_IF_ERROR(check_importance(importance, mesh.vertex_count()));
  quantity->resize(nf);
  double* out = quantity->data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f)
      out[f] = face_visual_quantity(mesh.positions.data(), mesh.indices.data(), importance, f);
  });
  return Status::Ok();
}

Status distribute_counts(const double* quantity, size_t face_count, uint32_t target, std::vector<uint32_t>* counts,
                         std::vector<uint32_t>* offsets, const ExecContext&) {
  assert(counts != nullptr && offsets != nullptr);
  double max_quantity = 0.0;
  VPR_RETURN_IF_ERROR(check_quantities(quantity, face_count, &max_quantity));

  // Eq. (9) in fixed point (sampling_kernels.h): exact integer prefix sums, so
  // the order of additions (here sequential, a scan on the GPU) cannot change
  // the counts.
  std::vector<QuantitySum> prefix(face_count + 1);
  prefix[0] = 0;
  for (size_t f = 0; f < face_count; ++f) prefix[f + 1] = prefix[f] + quantize_quantity(quantity[f], max_quantity);
  const QuantitySum total = prefix[face_count];  // >= 2^52: the largest face alone

  // offsets[i] = round(S_i), S_i = target * P_i / T: monotone in P, so every
  // count is >= 0, and exactly target at i = F.
  offsets->resize(face_count + 1);
  uint32_t* off = offsets->data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, face_count + 1, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) off[i] = rounded_offset(prefix[i], total, target);
  });
  counts->resize(face_count);
  for (size_t f = 0; f < face_count; ++f) (*counts)[f] = off[f + 1] - off[f];
  return Status::Ok();
}

Status sample_triangles(const Mesh& mesh, const float* importance, const uint32_t* counts, const uint32_t* offsets,
                        const SamplingOptions& options, std::vector<float>* points,
                        std::vector<float>* point_importance, const ExecContext&) {
  assert(points != nullptr && point_importance != nullptr);
  const size_t nf = mesh.face_count();
  VPR_RETURN_IF_ERROR(check_offsets(counts, offsets, nf));
  const size_t total = offsets[nf];
  points->resize(3 * total);
  point_importance->resize(total);
  float* p = points->data();
  float* pi = point_importance->data();
  const float* positions = mesh.positions.data();
  const uint32_t* indices = mesh.indices.data();
  // Faces are independent and each sample's numbers come from (seed, face, j),
  // so the output does not depend on how faces are split among threads.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f) {
      // Section IV-B: too few samples to follow a density; uniform is unbiased.
      const bool adaptive = counts[f] >= options.adaptive_min_samples;
      for (uint32_t j = 0; j < counts[f]; ++j) {
        const size_t out = size_t(offsets[f]) + j;
        sample_point(positions, indices, importance, f, j, options.seed, adaptive, p + 3 * out, pi + out);
      }
    }
  });
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
