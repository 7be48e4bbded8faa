// libFuzzer harness for the pipeline on tiny meshes and point sets (the input
// format is in pipeline_input.h): the whole pipeline on the CPU with OSMesa at
// 64-124 px with either back half (the surface CVT with each density, or the
// paper's AWLOP and advancing front), the advancing-front meshing stage on a
// point set, or its repair half on a soup.
// Each must return an error or a result that keeps its promises (pipeline.h,
// meshing.h): indices in range, finite positions, no non-manifold edge or
// vertex, one saliency value in [min_importance, 1] per output vertex.
// One TBB thread: runs are reproducible and leave the machine's other core free.
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include "eval/mesh_quality.h"
#include "fuzz/pipeline_input.h"
#include "surface/meshing.h"
#include "pipeline/pipeline.h"

namespace {

using namespace vpr;

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "pipeline_fuzzer: broken promise: %s\n", what);
  std::abort();
}

// What mesh_points and repair_triangle_soup promise about a result.
void check_surface(const Mesh& out, size_t points, const std::vector<uint32_t>& source) {
  if (!validate_mesh(out).ok()) fail(validate_mesh(out).to_string().c_str());
  const MeshQuality q = mesh_quality(out);
  if (q.non_manifold_edges != 0) fail("non-manifold edge");
  if (q.non_manifold_vertices != 0) fail("non-manifold vertex");
  if (source.size() != out.vertex_count()) fail("source_point is not one per output vertex");
  for (uint32_t s : source)
    if (s >= points) fail("source_point out of range");
}

Renderer* renderer() {
  static std::unique_ptr<Renderer> r = [] {
    auto created = create_renderer(RendererKind::kOsmesa);
    if (!created.ok()) {
      std::fprintf(stderr, "pipeline_fuzzer: %s\n", created.status().to_string().c_str());
      std::abort();
    }
    return std::move(created).value();
  }();
  return r.get();
}

void run_pipeline_case(const fuzz::PipelineInput& in) {
  PipelineOptions o;
  o.target_vertices = in.target;
  o.views.count = in.fourteen_views ? 14 : 6;
  o.views.resolution = in.resolution;
  o.views.pca_align = in.pca_align;
  o.device = DevicePolicy::kCpu;
  o.shared_renderer = renderer();
  o.density = in.density;
  o.sampling.seed = in.seed;
  if (in.uniform_sampling) o.sampling.adaptive_min_samples = UINT32_MAX;
  auto result = run_pipeline(in.mesh, o);
  if (in.target < kMinTargetVertices && result.ok()) fail("a target under the minimum was accepted");
  if (!result.ok()) return;
  const Mesh& out = result->mesh;
  if (!validate_mesh(out).ok()) fail(validate_mesh(out).to_string().c_str());
  const MeshQuality q = mesh_quality(out);
  if (q.non_manifold_edges != 0) fail("non-manifold edge");
  if (q.non_manifold_vertices != 0) fail("non-manifold vertex");
  if (result->saliency.size() != out.vertex_count()) fail("saliency is not one value per vertex");
  for (float s : result->saliency)
    if (!(s >= o.field.min_importance - 1e-6f && s <= 1.0f + 1e-6f)) fail("saliency outside [min_importance, 1]");
  if (result->input_importance.size() != in.mesh.vertex_count()) fail("input importance is not one per vertex");
}

MeshingOptions meshing_options(const fuzz::PipelineInput& in) {
  MeshingOptions o;
  // Small slabs, so that a few hundred points exercise the parallel seams;
  // spacing from the box as if the points covered its faces.
  o.points_per_slab = in.seed == 0 ? 0 : 16 + 2 * size_t(in.seed);
  const Aabb box = bounding_box(in.mesh);
  o.spacing = double(box.diagonal()) / std::sqrt(double(in.mesh.vertex_count()));
  return o;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  const auto in = fuzz::decode(data, size);
  if (!in) return 0;
  const size_t n = in->mesh.vertex_count();
  Mesh out;
  std::vector<uint32_t> source;
  MeshingStats stats;
  switch (in->mode) {
    case fuzz::Mode::kPipeline:
      run_pipeline_case(*in);
      break;
    case fuzz::Mode::kPoints:
      if (mesh_points(in->mesh.positions.data(), n, meshing_options(*in), &out, &source, &stats).ok())
        check_surface(out, n, source);
      break;
    case fuzz::Mode::kSoup:
      if (repair_triangle_soup(in->mesh.positions.data(), n, in->mesh.indices.data(), in->mesh.face_count(),
                               meshing_options(*in), &out, &source, &stats)
              .ok())
        check_surface(out, n, source);
      break;
  }
  return 0;
}
