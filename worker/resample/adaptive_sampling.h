// Stage 5 (Section IV-B, Eq. 7-16): adaptive sampling of the target count.
//   visual quantity per triangle (Eq. 7-8) -> integer counts whose quantization
//   error is carried forward so they sum exactly to the target (Eq. 9) ->
//   uniform sampling for n_i < 5, inverse-CDF sampling of the linearly
//   interpolated importance otherwise (Eq. 11-16).
// Random numbers: Philox keyed by (seed, triangle), counter = sample index.
#pragma once

#include <cstdint>
#include <vector>

#include "core/exec_context.h"
#include "core/mesh.h"
#include "resample/sampling_kernels.h"
#include "core/status.h"

namespace vpr {

struct SamplingOptions {
  uint64_t seed = 1;                  // Philox key: same seed, same points on every device and thread count
  uint32_t adaptive_min_samples = 5;  // Section IV-B: n_i < 5 -> uniform sampling
};

// The inverse CDFs of the adaptive sampler, exposed for tests and the GPU twin,
// are inline VPR_HD in sampling_kernels.h (same signatures as before):
//   float adaptive_s(float r, float ia, float ib, float ic);           // Eq. (14)
//   float adaptive_t(float r, float s, float ia, float ib, float ic);  // Eq. (16)
// with the slice parametrisation p = A + s ((1 - t)(B - A) + t (C - A)).

// Argument checks shared by the CPU and GPU twins, so both fail alike.
// importance: #V values, finite and >= 0.
Status check_importance(const float* importance, size_t vertex_count);
// quantity: #F values, finite and >= 0 with a positive sum; *max_quantity gets
// the largest (exact, so the same on every device).
Status check_quantities(const double* quantity, size_t face_count, double* max_quantity);
// offsets: #F + 1, the exclusive prefix sum of counts (#F).
Status check_offsets(const uint32_t* counts, const uint32_t* offsets, size_t face_count);

namespace cpu {

// Eq. (7-8): q_i = area_i * (I_a + I_b + I_c) / 3 (#F doubles).
// importance: #V values, finite and >= 0 (else INVALID_ARGUMENT).
Status visual_quantity(const Mesh& mesh, const float* importance, std::vector<double>* quantity,
                       const ExecContext& ctx);

// Eq. (9): counts (#F) that sum exactly to target; offsets (#F + 1) is their
// exclusive prefix sum. n_i = round(S_{i+1}) - round(S_i) with S the scaled
// prefix sum of q (S_0 = 0, S_F = target exactly, round(x) = floor(x + 0.5)),
// which is the sequential error diffusion in closed form: the emitted total
// offsets[i] never drifts more than 1/2 from S_i. S is computed in fixed point
// (quantize_quantity and rounded_offset in sampling_kernels.h): exact integer
// sums, so the counts are identical on every device and in any scan order;
// the fixed point shifts S by at most F 2^-53 target (1e-5 for a million
// faces and 10^5 samples), so "1/2" holds up to that.
// quantity: #F values, finite and >= 0 with a positive sum (else
// INVALID_ARGUMENT; a zero sum means every face is degenerate).
Status distribute_counts(const double* quantity, size_t face_count, uint32_t target, std::vector<uint32_t>* counts,
                         std::vector<uint32_t>* offsets, const ExecContext& ctx);

// Eq. (11-16): writes offsets[F] points (3 floats each) and their interpolated
// importance; sample j of face f is stored at offsets[f] + j. Faces with
// counts[f] < adaptive_min_samples are sampled uniformly in area, the others by
// the inverse CDFs (sample_point in sampling_kernels.h). offsets must be the
// exclusive prefix sum of counts (else INVALID_ARGUMENT).
Status sample_triangles(const Mesh& mesh, const float* importance, const uint32_t* counts, const uint32_t* offsets,
                        const SamplingOptions& options, std::vector<float>* points,
                        std::vector<float>* point_importance, const ExecContext& ctx);

}  // namespace cpu

// GPU twins, built when VPR_HAVE_CUDA (adaptive_sampling.cu): same contracts.
// Quantities and sample points are bit-identical to the CPU twins (the same
// double math of sampling_kernels.h, compiled without FMA contraction), counts
// identical by construction. Host arrays in and out; the work runs on ctx's
// stream, device memory is charged to ctx.budget.
namespace cuda {

Status visual_quantity(const Mesh& mesh, const float* importance, std::vector<double>* quantity,
                       const ExecContext& ctx);

Status distribute_counts(const double* quantity, size_t face_count, uint32_t target, std::vector<uint32_t>* counts,
                         std::vector<uint32_t>* offsets, const ExecContext& ctx);

Status sample_triangles(const Mesh& mesh, const float* importance, const uint32_t* counts, const uint32_t* offsets,
                        const SamplingOptions& options, std::vector<float>* points,
                        std::vector<float>* point_importance, const ExecContext& ctx);

}  // namespace cuda
}  // namespace vpr
