// Metro-style Hausdorff distance (Cignoni, Rocchini, Scopigno, "Metro: measuring
// error on simplified surfaces", 1998). Each direction samples the source surface
// area-uniformly and measures every sample's exact distance to the target surface
// through a CGAL AABB tree (surface/closest_point.h).
#include "eval/hausdorff.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/rng.h"
#include "core/vec3.h"
#include "surface/closest_point.h"

namespace vpr {
namespace {

struct DirectedStats {
  double max = 0;   // over area samples and vertices, model units
  double mean = 0;  // over area samples
  double rms = 0;
};

// Distances from `source` (area samples, then referenced vertices) to `target`.
DirectedStats directed_distance(const Mesh& source, const ClosestPointTree& target, size_t samples, uint64_t seed) {
  const size_t nf = source.face_count();
  const float* p = source.positions.data();
  const std::vector<double> areas = face_areas(source);

  // Sample counts by prefix-sum rounding: face f gets offset[f+1] - offset[f]
  // samples, offset[f] = floor(S_f + 0.5) with S_f = samples * (area before f) / total.
  // The counts sum to `samples` exactly and depend on nothing but the mesh.
  std::vector<size_t> offset(nf + 1);
  double total = 0;
  for (double a : areas) total += a;
  double prefix = 0;
  for (size_t f = 0; f < nf; ++f) {
    offset[f] = size_t(std::floor(double(samples) * (prefix / total) + 0.5));
    prefix += areas[f];
  }
  offset[nf] = samples;  // prefix / total == 1 exactly here, written out to be safe

  std::vector<uint32_t> vertices;
  {
    std::vector<char> referenced(source.vertex_count(), 0);
    for (uint32_t v : source.indices) referenced[v] = 1;
    for (size_t v = 0; v < referenced.size(); ++v)
      if (referenced[v]) vertices.push_back(uint32_t(v));
  }

  std::vector<double> area_distance(samples);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 256), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f) {
      const Vec3d a = load3d(p, source.indices[3 * f]);
      const Vec3d b = load3d(p, source.indices[3 * f + 1]);
      const Vec3d c = load3d(p, source.indices[3 * f + 2]);
      for (size_t j = 0; j < offset[f + 1] - offset[f]; ++j) {
        const Philox4 bits = random4(seed, f, j);
        // Uniform on the triangle: sqrt warps the first coordinate so that the
        // density does not pile up at corner a (Osada et al. 2002, Eq. 1).
        const double r1 = std::sqrt(double(uniform01(bits.v[0])));
        const double r2 = double(uniform01(bits.v[1]));
        const Vec3d q = a * (1.0 - r1) + b * (r1 * (1.0 - r2)) + c * (r1 * r2);
        area_distance[offset[f] + j] = std::sqrt(target.squared_distance(q));
      }
    }
  });

  std::vector<double> vertex_distance(vertices.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, vertices.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i)
      vertex_distance[i] = std::sqrt(target.squared_distance(load3d(p, vertices[i])));
  });

  // Serial sums in sample order: the result does not depend on the thread count.
  DirectedStats s;
  double sum = 0, sum2 = 0;
  for (double d : area_distance) {
    s.max = std::max(s.max, d);
    sum += d;
    sum2 += d * d;
  }
  for (double d : vertex_distance) s.max = std::max(s.max, d);
  s.mean = sum / double(samples);
  s.rms = std::sqrt(sum2 / double(samples));
  return s;
}

}  // namespace

StatusOr<HausdorffResult> hausdorff_distance(const Mesh& reference, const Mesh& given_candidate,
                                             const HausdorffOptions& options) {
  // Both in the reference's frame (their origins may differ: mesh.h).
  Mesh moved;
  const bool same_frame = given_candidate.origin == reference.origin && given_candidate.scale == reference.scale;
  if (!same_frame) moved = rebased(given_candidate, reference.origin, reference.scale);
  const Mesh& candidate = same_frame ? given_candidate : moved;
  if (Status s = validate_mesh(reference); !s.ok()) return Status(s.code(), "reference mesh: " + s.message());
  if (Status s = validate_mesh(candidate); !s.ok()) return Status(s.code(), "candidate mesh: " + s.message());
  if (options.samples_per_mesh == 0 || options.samples_per_mesh > kMaxHausdorffSamples)
    return invalid_argument("samples_per_mesh is " + std::to_string(options.samples_per_mesh) + ", it must be in [1, " +
                            std::to_string(kMaxHausdorffSamples) + "]");

  // validate_mesh's floating-point area test can miss faces CGAL finds
  // exactly collinear.
  const ClosestPointTree reference_tree(reference), candidate_tree(candidate);
  if (reference_tree.empty()) return invalid_argument("reference mesh: every face is degenerate (collinear corners)");
  if (candidate_tree.empty()) return invalid_argument("candidate mesh: every face is degenerate (collinear corners)");

  const DirectedStats forward = directed_distance(reference, candidate_tree, options.samples_per_mesh, options.seed);
  const DirectedStats backward = directed_distance(candidate, reference_tree, options.samples_per_mesh, options.seed);

  const Aabb box = bounding_box(reference);
  double diagonal2 = 0;
  for (int a = 0; a < 3; ++a) diagonal2 += (double(box.hi[a]) - box.lo[a]) * (double(box.hi[a]) - box.lo[a]);
  HausdorffResult r;
  const double diagonal = std::sqrt(diagonal2);  // > 0: validate_mesh demands a positive area
  r.diagonal = diagonal * reference.scale;        // in the model's units
  r.forward_max = forward.max / diagonal;
  r.backward_max = backward.max / diagonal;
  r.max = std::max(r.forward_max, r.backward_max);
  r.mean = 0.5 * (forward.mean + backward.mean) / diagonal;
  r.rms = 0.5 * (forward.rms + backward.rms) / diagonal;
  return r;
}

}  // namespace vpr
