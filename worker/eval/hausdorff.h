// Symmetric Hausdorff distance between two triangle meshes, Metro-style
// (Cignoni et al. 1998): area-uniform samples on each surface, exact point to
// surface distances against a CGAL AABB tree of the other.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/mesh.h"
#include "core/status.h"

namespace vpr {

// One distance (8 bytes) is kept per sample, so this bounds the memory of a call
// to about 400 MB per direction.
constexpr size_t kMaxHausdorffSamples = 50'000'000;

struct HausdorffOptions {
  // Area-uniform samples per surface, in [1, kMaxHausdorffSamples]. Every vertex
  // referenced by a face is sampled in addition (it catches spikes that sit
  // exactly on a vertex); those extra samples count towards the maxima only.
  size_t samples_per_mesh = 200'000;
  // Both directions draw from the same stream, vpr::random4(seed, face, j), so
  // hausdorff_distance(A, B) and hausdorff_distance(B, A) sample identically and
  // their maxima agree in model units, at any thread count.
  uint64_t seed = 7;
};

struct HausdorffResult {
  // All in units of the reference's bounding-box diagonal.
  double max = 0;           // max over both directions
  double mean = 0;          // mean of the two directed means (area samples only: unbiased surface mean)
  double rms = 0;           // mean of the two directed root-mean-square distances (area samples only)
  double forward_max = 0;   // reference -> candidate
  double backward_max = 0;  // candidate -> reference
  double diagonal = 0;      // reference bounding-box diagonal, model units
};

// reference, candidate: must pass validate_mesh; the error names the mesh that fails.
// Degenerate faces are accepted: they get no area samples and are left out of the
// distance trees (their vertices are still sampled).
StatusOr<HausdorffResult> hausdorff_distance(const Mesh& reference, const Mesh& candidate,
                                             const HausdorffOptions& options = {});

}  // namespace vpr
