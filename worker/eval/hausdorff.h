// Symmetric Hausdorff distance between two triangle meshes, Metro-style
// (Cignoni et al. 1998): area-uniform samples on each surface, exact point to
// surface distances against a CGAL AABB tree of the other.
#pragma once

#include <cstdint>

#include "pipeline/mesh.h"
#include "pipeline/status.h"

namespace vpr {

struct HausdorffOptions {
  size_t samples_per_mesh = 200'000;  // area-uniform samples (plus every vertex)
  uint64_t seed = 7;
};

struct HausdorffResult {
  // All in units of the reference's bounding-box diagonal.
  double max = 0;      // max over both directions
  double mean = 0;     // mean of the two directed means
  double rms = 0;
  double forward_max = 0;   // reference -> candidate
  double backward_max = 0;  // candidate -> reference
  double diagonal = 0;      // reference bounding-box diagonal, model units
};

StatusOr<HausdorffResult> hausdorff_distance(const Mesh& reference, const Mesh& candidate,
                                             const HausdorffOptions& options = {});

}  // namespace vpr
