#include "pipeline.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#include "color_transfer.h"
#include "core/mesh_parts.h"
#include "core/running_jobs.h"
#include "core/step_marks.h"
#include "debug_output.h"
#include "eval/visual_similarity.h"
#include "job_device.h"
#include "part_fallback.h"
#include "surface/surface_refine.h"
#include "visual_target.h"
#ifdef VPR_HAVE_CUDA
#include "saliency/gpu_saliency.h"
#endif
#include "saliency/attention_field.h"
#include "saliency/unproject.h"
#include "saliency/visibility.h"

namespace vpr {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The refinement's edge rows on the job's GPU, on its stream for work beside
// the stages (the refinement runs on a thread of its own); none on the CPU.
// The rows are the host's (integers), so the job's bits do not change.
MeshEdgesTwin edge_rows_twin(const JobDevice& device) {
#ifdef VPR_HAVE_CUDA
  if (device.on_gpu())
    return
        [&device](const std::vector<uint32_t>& indices, size_t vertex_count, MeshEdges* edges, VertexCorners* corners) {
          VPR_RETURN_IF_ERROR(device.use_on_this_thread());
          return cuda::mesh_edges(indices, vertex_count, edges, corners, device.beside_context());
        };
#endif
  (void)device;
  return {};
}

// A stage's twin for the context it is called with: the GPU twin (vpr::cuda,
// same signature) on a CUDA context, the CPU twin otherwise.
#ifdef VPR_HAVE_CUDA
#define VPR_TWIN(ctx, fn) ((ctx).device == Device::kCuda ? &cuda::fn : &cpu::fn)
#else
#define VPR_TWIN(ctx, fn) (&cpu::fn)
#endif

// Runs one stage, records its wall time, and checks for cancellation first.
class StageRunner {
 public:
  // level: stamped on every timing (kFrontHalf or the level's index).
  StageRunner(const PipelineOptions& options, PipelineResult* result, int level)
      : options_(options), result_(result), level_(level) {}

  // note (may be null): read after fn, for the stage's timing.
  template <class Fn>
  Status run(const char* name, const std::string& device, Fn&& fn, const std::string* note = nullptr) {
    VPR_RETURN_IF_ERROR(check_cancelled(name));
    begin(name);
    const auto start = Clock::now();
    Status status = fn();
    record(name, start, device, note ? *note : "");
    if (!status.ok()) return {status.code(), std::string(name) + ": " + status.message()};
    return Status::Ok();
  }

  // A stage with a GPU twin: fn(ctx) runs on the job's device; when it fails
  // on the GPU (out of memory, a CUDA error) it reruns on the CPU, the job goes
  // on, and the stage's timing says "cpu" and why.
  // cpu_note: recorded when the stage runs on the CPU (e.g. why the GPU
  // version of a fused step could not be used).
  // note (may be null): read after fn, recorded on either device (after
  // cpu_note or the reason for a rerun, when there is one).
  template <class Fn>
  Status run_twin(const char* name, const JobDevice& device, Fn&& fn, const std::string& cpu_note = "",
                  const std::string* note = nullptr) {
    auto with_note = [&](const std::string& first) {
      if (!note || note->empty()) return first;
      return first.empty() ? *note : first + "; " + *note;
    };
    VPR_RETURN_IF_ERROR(check_cancelled(name));
    begin(name);
    const auto start = Clock::now();
    const ExecContext cpu_ctx;
    if (!device.on_gpu()) {
      Status status = fn(cpu_ctx);
      record(name, start, "cpu", with_note(cpu_note));
      if (!status.ok()) return {status.code(), std::string(name) + ": " + status.message()};
      return Status::Ok();
    }
    Status status = fn(device.context());
    if (status.ok()) status = device.synchronize();  // the timing includes the stream's work
    if (status.ok()) {
      record(name, start, "cuda", with_note(""));
      return Status::Ok();
    }
    const std::string why = "GPU failed (" + status.to_string() + "), reran on the CPU";
    status = fn(cpu_ctx);
    record(name, start, "cpu", with_note(why));
    if (!status.ok()) return {status.code(), std::string(name) + ": " + status.message()};
    return Status::Ok();
  }

  Status check_cancelled(const char* name) const {
    if (options_.keep_going && !options_.keep_going())
      return {StatusCode::kCancelled, std::string("job cancelled before stage ") + name};
    return Status::Ok();
  }
  void begin(const char* name) const {
    if (options_.on_stage_begin) options_.on_stage_begin(name);
  }
  void record(const char* name, Clock::time_point start, const std::string& device, const std::string& note) {
    record_ms(name, ms_since(start), device, note);
  }
  void record_ms(const char* name, double ms, const std::string& device, const std::string& note) {
    result_->stages.push_back({name, ms, device, note, level_});
    if (options_.on_stage) options_.on_stage(result_->stages.back());
  }

 private:
  const PipelineOptions& options_;
  PipelineResult* result_;
  int level_;
};

// Spacing of a regular triangle mesh with `count` vertices covering `area`:
// F ~ 2V triangles of area (sqrt 3 / 4) l^2 each.
double target_spacing(double area, uint32_t count) {
  return std::sqrt(2.0 * area / (std::sqrt(3.0) * count));
}

// The attention field's curvature (mean_curvatures: |H| with each concave
// edge's term times options.concave_weight), as floats; *mean gets |H| itself,
// which the density's curvature term uses.
// device: where a GPU job's curvature runs (its stream for work ahead, on
// the calling thread), or null for the host; *where (when not null) says
// which ran, and why the host did when the GPU failed. Both twins give the
// same bits (curvature_terms.h).
std::vector<float> attention_curvature(const Mesh& input, const AttentionFieldOptions& options,
                                       std::vector<double>* mean, const JobDevice* device = nullptr,
                                       std::string* where = nullptr) {
  std::vector<double> weighted;
  std::string ran = "curvature on the host";
#ifdef VPR_HAVE_CUDA
  if (device && device->on_gpu()) {
    Status s = device->use_on_this_thread();
    if (s.ok()) s = cuda::mean_curvatures(input, options.concave_weight, mean, &weighted, device->ahead_context());
    if (s.ok()) {
      if (where) *where = "curvature on the GPU";
      return std::vector<float>(weighted.begin(), weighted.end());
    }
    ran = "curvature on the host (GPU failed: " + s.to_string() + ")";
  }
#else
  (void)device;
#endif
  mean_curvatures(input, options.concave_weight, mean, &weighted);
  if (where) *where = ran;
  return std::vector<float>(weighted.begin(), weighted.end());
}

// The back half's refinement for a level: elements the output spacing over
// sqrt(cvt_elements_per_vertex) apart, over sqrt(cvt_rim_elements_per_vertex)
// within cvt_rim_band output spacings of an open edge; and its bound.
EdgeBounds refine_bounds(double spacing_out, const PipelineOptions& options) {
  EdgeBounds b;
  b.max_edge = spacing_out / std::sqrt(options.cvt_elements_per_vertex);
  if (options.cvt_rim_elements_per_vertex > options.cvt_elements_per_vertex && options.cvt_rim_band > 0) {
    b.rim_max_edge = spacing_out / std::sqrt(options.cvt_rim_elements_per_vertex);
    b.rim_band = options.cvt_rim_band * spacing_out;
  }
  return b;
}
double most_elements_per_vertex(const PipelineOptions& options) {
  return std::max(options.cvt_elements_per_vertex, options.cvt_rim_elements_per_vertex);
}
size_t refine_limit(const Mesh& input, uint32_t target, const PipelineOptions& options) {
  return input.vertex_count() + size_t(64 * most_elements_per_vertex(options)) * target;
}

// The pipeline runs on a copy of the input centred on its bounding box and
// scaled to a unit diagonal, so that no tolerance anywhere (CGAL, FLANN,
// AWLOP's guards, the renderer's depth range) depends on the model's units:
// a model in micrometres or in light years remeshes like one in metres. The
// input's positions are already relative to its origin (mesh.h), so a model
// far from zero loses nothing either.
struct Normalization {
  double center[3] = {0, 0, 0};           // relative to origin
  double scale = 1;                       // model units per normalized unit
  std::array<double, 3> origin{0, 0, 0};  // the input's frame (mesh.h)
  double frame_scale = 1;
};

StatusOr<Mesh> normalized_copy(const Mesh& input, Normalization* norm) {
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = input.positions[a];
  for (size_t v = 0; v < input.vertex_count(); ++v)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(input.positions[3 * v + a]));
      hi[a] = std::max(hi[a], double(input.positions[3 * v + a]));
    }
  double diag2 = 0;
  for (int a = 0; a < 3; ++a) {
    norm->center[a] = 0.5 * (lo[a] + hi[a]);
    diag2 += (hi[a] - lo[a]) * (hi[a] - lo[a]);
  }
  norm->scale = std::sqrt(diag2);
  norm->origin = input.origin;
  norm->frame_scale = input.scale;
  if (!(norm->scale > 0)) return invalid_argument("degenerate mesh: all vertices coincide");
  Mesh out;
  out.indices = input.indices;
  out.positions.resize(input.positions.size());
  for (size_t i = 0; i < input.positions.size(); ++i)
    out.positions[i] = float((double(input.positions[i]) - norm->center[i % 3]) / norm->scale);
  return out;
}

// True when every edge of the mesh is shared by exactly two faces (in either
// orientation), i.e. the surface has no boundary: only then can the meshing
// stage expect its parallel slabs to close at the seams. Edges as sorted
// 64-bit keys, sorted in parallel.
bool has_no_boundary(const Mesh& mesh) {
  std::vector<uint64_t> edges(mesh.indices.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh.face_count(), 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f < r.end(); ++f)
      for (int c = 0; c < 3; ++c) {
        const uint64_t a = mesh.indices[3 * f + c], b = mesh.indices[3 * f + (c + 1) % 3];
        edges[3 * f + c] = a < b ? (a << 32 | b) : (b << 32 | a);
      }
  });
  tbb::parallel_sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i != 2) return false;
    i = j;
  }
  return true;
}

// Back to the input's frame: relative to its origin.
void denormalize(const Normalization& norm, std::vector<float>* positions) {
  for (size_t i = 0; i < positions->size(); ++i)
    (*positions)[i] = float(double((*positions)[i]) * norm.scale + norm.center[i % 3]);
}

// Back to the input's units, origin included (points handed out as floats).
void to_model_units(const Normalization& norm, std::vector<float>* positions) {
  for (size_t i = 0; i < positions->size(); ++i)
    (*positions)[i] =
        float((double((*positions)[i]) * norm.scale + norm.center[i % 3]) * norm.frame_scale + norm.origin[i % 3]);
}

// The output in the input's frame, and the field on every input vertex again
// (used: input vertex of each compacted one, empty when none was dropped;
// dropped vertices get the field's floor).
void finish_output(const Normalization& norm, const std::vector<uint32_t>& used, size_t input_vertices,
                   float floor_value, PipelineResult* result) {
  denormalize(norm, &result->mesh.positions);
  result->mesh.origin = norm.origin;
  result->mesh.scale = norm.frame_scale;
  if (used.empty()) return;
  std::vector<float> field(input_vertices, floor_value);
  for (size_t v = 0; v < used.size(); ++v) field[used[v]] = result->input_importance[v];
  result->input_importance = std::move(field);
}

}  // namespace

Status validate_options(const PipelineOptions& o) {
  if (o.target_vertices < kMinTargetVertices || o.target_vertices > kMaxTargetVertices)
    return invalid_argument("target of " + std::to_string(o.target_vertices) +
                            " vertices is outside the supported range [" + std::to_string(kMinTargetVertices) + ", " +
                            std::to_string(kMaxTargetVertices) + "]");
  VPR_RETURN_IF_ERROR(check_attention_boost(o.attention_boost));
  if (o.views.count != 6 && o.views.count != 14)
    return invalid_argument("views must be 6 or 14, got " + std::to_string(o.views.count));
  if (o.views.resolution < 64 || o.views.resolution > 4096)
    return invalid_argument("resolution " + std::to_string(o.views.resolution) +
                            " is outside the supported range [64, 4096]");
  if (o.image.median_size < 1 || o.image.median_size % 2 == 0 || o.image.median_size > 31)
    return invalid_argument("median size must be odd and in [1, 31]");
  if (o.image.gaussian_size < 1 || o.image.gaussian_size % 2 == 0 || o.image.gaussian_size > 63)
    return invalid_argument("Gaussian window must be odd and in [1, 63]");
  if (!(o.image.gaussian_sigma > 0)) return invalid_argument("Gaussian sigma must be positive");
  if (o.image.skeleton_lambda < 2 || o.image.skeleton_lambda > 64)
    return invalid_argument("skeleton lambda must be in [2, 64]");
  if (o.field.k < 1 || o.field.k > 64) return invalid_argument("field k must be in [1, 64]");
  if (!(o.field.beta > 0 && o.field.beta < 1)) return invalid_argument("beta must be in (0, 1)");
  if (!(o.field.min_importance > 0 && o.field.min_importance <= 1))
    return invalid_argument("min importance must be in (0, 1]");
  VPR_RETURN_IF_ERROR(check_attention_field_args(o.attention, 0, nullptr));
  VPR_RETURN_IF_ERROR(check_visibility_args({}, {}, o.visibility));  // its options only, before any work
  if (!(o.drop_parts_smaller_than >= 0 && o.drop_parts_smaller_than <= 1))
    return invalid_argument("drop-parts-smaller-than must be a share of the model's diagonal in [0, 1]");
  if (!(o.anisotropy >= 0 && o.anisotropy <= 0.5))
    return invalid_argument("anisotropy must be a share of the model's diagonal in [0, 0.5]");
  if (!(o.cvt_elements_per_vertex >= 4 && o.cvt_elements_per_vertex <= 64) ||
      !(o.cvt_rim_elements_per_vertex >= 4 && o.cvt_rim_elements_per_vertex <= 64))
    return invalid_argument("surface elements per output vertex must be in [4, 64]");
  if (!(o.cvt_rim_band >= 0 && o.cvt_rim_band <= 16))
    return invalid_argument("the rim band must be in [0, 16] output spacings");
  if (!(o.awlop.mu >= 0 && o.awlop.mu <= 0.5)) return invalid_argument("mu must be in [0, 0.5]");
  if (o.awlop.k < 1 || o.awlop.k > 64) return invalid_argument("AWLOP k must be in [1, 64]");
  if (o.awlop.iterations < 0 || o.awlop.iterations > 200)
    return invalid_argument("AWLOP iterations must be in [0, 200]");
  if (o.awlop.attraction_samples_per_target < 1 || o.awlop.attraction_samples_per_target > 32)
    return invalid_argument("attraction samples per target must be in [1, 32]");
  return Status::Ok();
}

namespace {

// What the front half leaves for the back half of every level: the input as
// the stages see it, and the field on it.
struct FrontHalf {
  Normalization norm;
  Mesh input;                  // compacted (no stray vertices, no dropped parts) and normalized
  std::vector<uint32_t> used;  // input vertex of each compacted one; empty when none was dropped
  size_t given_vertices = 0;
  std::unique_ptr<JobDevice> device;
  Renderer* renderer = nullptr;  // the shared one or own_renderer
  std::unique_ptr<Renderer> own_renderer;
  std::vector<float> saliency_points;  // normalized, x y z each
  std::vector<double> curvature;       // per vertex, for the density (not the paper's)
  std::vector<double> areas;
  double area = 0, mean_edge = 0;
  Clock::time_point start;
  // Refined surfaces (their geometry: refine_geometry) made ahead on their
  // own threads, per level count: the first level's beside the front half,
  // each next count level's while the one before it runs. Declared after
  // `input`, so an early return waits for them before `input` goes.
  std::deque<std::pair<uint32_t, std::future<StatusOr<RefinedSurface>>>> refined_ahead;
  std::mutex refined_ahead_mutex;  // levels run side by side take theirs at once
  // Front-half stage timings and everything every level reports alike
  // (renderer, device, counts, the input field except the paper's).
  PipelineResult shared;
};

// Stray vertices and parts the user asked to drop leave the input; the rest
// is normalized. Sets front->input, used, norm, the face areas and the counts.
Status prepare_input(const Mesh& given, const PipelineOptions& options, FrontHalf* front) {
  // Vertices no face uses (exporters leave them behind) take no part: not in
  // the framing, the orientation, the field or the sampling.
  // Parts the user asked to drop lose their faces first, so their vertices
  // are ignored like stray ones.
  Mesh compacted;
  size_t ignored = 0, dropped_parts = 0;
  if (options.drop_parts_smaller_than > 0) {
    compacted = given;
    dropped_parts = drop_small_parts(&compacted, options.drop_parts_smaller_than);
    if (dropped_parts == 0) compacted = Mesh();
  }
  const Mesh& source = dropped_parts > 0 ? compacted : given;
  if (unreferenced_vertex_count(source) > 0) {
    if (dropped_parts == 0) compacted = given;
    ignored = remove_unreferenced_vertices(&compacted, &front->used);
  }
  VPR_ASSIGN_OR_RETURN(front->input,
                       normalized_copy(ignored > 0 || dropped_parts > 0 ? compacted : given, &front->norm));
  front->areas = face_areas(front->input);
  for (double a : front->areas) front->area += a;
  front->given_vertices = given.vertex_count();
  front->shared.ignored_vertices = ignored;
  front->shared.dropped_parts = dropped_parts;
  return Status::Ok();
}

// PipelineOptions::attention_map: one finite value per given vertex.
Status check_attention_map(const std::vector<float>& map, size_t given_vertices) {
  if (map.size() != given_vertices)
    return invalid_argument("attention map has " + std::to_string(map.size()) + " values for a mesh of " +
                            std::to_string(given_vertices) + " vertices");
  for (size_t v = 0; v < map.size(); ++v)
    if (!std::isfinite(map[v]))
      return invalid_argument("attention map value " + std::to_string(v) + " is not a finite number");
  return Status::Ok();
}

// The given attention map in place of the field, on the compacted input's vertices.
void use_attention_map(const std::vector<float>& map, const FrontHalf& front, PipelineResult* result) {
  const size_t n = front.input.vertex_count();
  result->input_importance.resize(n);
  for (size_t v = 0; v < n; ++v) result->input_importance[v] = map[front.used.empty() ? v : front.used[v]];
}

// Stages 1-4: views, snapshots, image saliency, unprojection, and (except
// for the paper's density, whose field depends on the target) the field.
Status run_front_half(const PipelineOptions& options, FrontHalf* front) {
  const Mesh& input = front->input;
  PipelineResult& result = front->shared;
  const std::string cpu = "cpu";
  if (!front->device) {  // else chosen before the refinement ahead started
    front->start = Clock::now();
    VPR_ASSIGN_OR_RETURN(front->device, JobDevice::select(options.device, options.cuda_device, options.device_budget));
  }
  if (options.attention_map) VPR_RETURN_IF_ERROR(check_attention_map(*options.attention_map, front->given_vertices));
  const JobDevice& device = *front->device;
  result.device = device.description();
  result.cpu_reason = device.cpu_reason();
  StageRunner stage(options, &result, kFrontHalf);

  // The attention field's mean curvature, and what the field makes from it
  // alone (its vertex grid and fine cue map: prepare_attention), need only
  // the input: they run on the host beside stages 1-3 (the renderer and the
  // image saliency leave the host's cores mostly idle, on the GPU and with
  // llvmpipe alike), and stage 4 waits for them. The same bits either way.
  // An early return waits for them in the future's destructor, while `input`
  // still lives.
  struct CurvatureAhead {
    std::vector<double> curvature;
    std::vector<float> h;  // the field's curvature (concave edges weighed down), as floats
    AttentionPrep prep;    // empty when the field's options are bad (the stage reports them)
    std::string where;     // which twin made the curvature
  };
  std::future<CurvatureAhead> curvature_beside;
  if (options.density != DensityMode::kPaper && front->curvature.empty())
    curvature_beside = std::async(std::launch::async, [&input, &options, &device] {
      CurvatureAhead a;
      StepMarks marks("curvature_ahead");
      a.h = attention_curvature(input, options.attention, &a.curvature, &device, &a.where);
      marks.mark("curvature");
      if (check_attention_field_args(options.attention, input.vertex_count(), a.h.data()).ok())
        a.prep = prepare_attention(input.positions.data(), a.h.data(), input.vertex_count(), options.attention);
      marks.mark("prep");
      return a;
    });
  CurvatureAhead ahead;

  // Stage 1: cameras and snapshots.
  std::vector<View> views;
  VPR_RETURN_IF_ERROR(stage.run("views", cpu, [&]() -> Status {
    VPR_ASSIGN_OR_RETURN(views, make_views(input, options.views));
    return Status::Ok();
  }));

  front->renderer = options.shared_renderer;
  std::vector<Snapshot> snapshots;
  // On a GPU job the drawn geometry (smooth corner normals, shared corners)
  // is built on the device: the host's part was what stretched the render
  // six-fold with eight jobs at once. The twin runs inside this job's
  // render() call, so it may record its own status here: the stage's note
  // says where the geometry was built, as every other twin's stage does.
  DrawnGeometryTwin geometry_twin;
  bool twin_ran = false;
  Status twin_status = Status::Ok();
#ifdef VPR_HAVE_CUDA
  if (device.on_gpu() && options.render_prep_on_gpu)
    geometry_twin = [&](const Mesh& m, bool indexed, DrawnGeometry* g) {
      twin_ran = true;
      twin_status = cuda::drawn_geometry(m, indexed, g, device.context());
      return twin_status;
    };
  // The GPU job's snapshots, when GL hands them to CUDA (else empty).
  std::unique_ptr<cuda::DeviceSnapshots> on_device;
#endif
  {
    stage.begin("render");
    const auto start = Clock::now();
    if (!front->renderer) {
      auto created = create_renderer(options.renderer, device.on_gpu() ? options.cuda_device : -1);
      if (!created.ok()) return Status(created.status().code(), "render: " + created.status().message());
      front->own_renderer = std::move(created).value();
      front->renderer = front->own_renderer.get();
    }
    result.renderer = front->renderer->description();
    std::string pixels_note;
    bool read_back = true;
    Status status = Status::Ok();
#ifdef VPR_HAVE_CUDA
    if (device.on_gpu() && options.render_interop) {
      on_device = std::make_unique<cuda::DeviceSnapshots>(views, device.context());
      status = on_device->allocate();
      if (status.ok()) status = front->renderer->render(input, views, &snapshots, geometry_twin, on_device.get());
      // Bad input fails the same way read back; anything else (the GL
      // context on another GPU, a driver without interop) reads back.
      read_back = !status.ok() && status.code() != StatusCode::kInvalidArgument;
      pixels_note = read_back ? "pixels read back (" + status.to_string() + ")" : "pixels handed to CUDA";
      if (read_back) on_device.reset();
    }
#endif
    if (read_back) status = front->renderer->render(input, views, &snapshots, geometry_twin);
    const std::string prep_note = !twin_ran ? ""
                                  : twin_status.ok()
                                      ? "geometry prepared on the GPU"
                                      : "GPU failed (" + twin_status.to_string() + "), geometry prepared on the host";
    const std::string note =
        prep_note.empty() || pixels_note.empty() ? prep_note + pixels_note : prep_note + "; " + pixels_note;
    stage.record_ms("render", ms_since(start), result.renderer, note);
    if (!status.ok()) return Status(status.code(), "render: " + status.message());
  }
  // The snapshots on the host, for a CPU twin or debug output: copied from
  // the device when they stayed there (rendered again if that fails).
  auto host_snapshots = [&]() -> Status {
#ifdef VPR_HAVE_CUDA
    if (on_device && snapshots.size() != views.size()) {
      if (on_device->download(&snapshots).ok()) return Status::Ok();
      return front->renderer->render(input, views, &snapshots, geometry_twin);
    }
#endif
    return Status::Ok();
  };

  // Stages 2-3: image-space saliency per view, then feature pixels to 3D
  // saliency points. On the GPU one fused pass per view keeps the images on
  // the device and brings back only the points (and the feature images when
  // debug output wants them); on the CPU, or when the fused pass fails on the
  // GPU, the two stages run one after the other on the CPU.
  std::vector<FeatureImages> features(views.size());
  std::vector<float>& saliency_points = front->saliency_points;
  std::vector<std::vector<float>> view_points(views.size());
  bool fused = false;
  std::string fused_failure;
#ifdef VPR_HAVE_CUDA
  if (device.on_gpu()) {
    VPR_RETURN_IF_ERROR(stage.check_cancelled("image_saliency"));
    const bool want_images = !options.debug_dir.empty();
    const auto start = Clock::now();
    Status status = Status::Ok();
    for (size_t v = 0; v < views.size() && status.ok(); ++v)
      status = on_device ? cuda::view_saliency_points(on_device->snapshot(v), views[v], options.image, &view_points[v],
                                                      want_images ? &features[v] : nullptr, device.context())
                         : cuda::view_saliency_points(snapshots[v], views[v], options.image, &view_points[v],
                                                      want_images ? &features[v] : nullptr, device.context());
    if (status.ok()) {
      stage.record("image_saliency", start, "cuda", "");
      stage.record_ms("unproject", 0, "cuda", "fused into image_saliency on the GPU");
      fused = true;
    } else {
      fused_failure = "GPU failed (" + status.to_string() + "), reran on the CPU";
      for (auto& p : view_points) p.clear();
    }
  }
#endif
  if (!fused) {
    VPR_RETURN_IF_ERROR(host_snapshots());
    const std::unique_ptr<JobDevice> cpu_only = std::move(JobDevice::select(DevicePolicy::kCpu, 0, nullptr)).value();
    const JobDevice& twin_device = fused_failure.empty() ? device : *cpu_only;
    VPR_RETURN_IF_ERROR(stage.run_twin(
        "image_saliency", twin_device,
        [&](const ExecContext& c) -> Status {
          for (size_t v = 0; v < views.size(); ++v)
            VPR_RETURN_IF_ERROR(VPR_TWIN(c, detect_features)(snapshots[v], options.image, &features[v], c));
          return Status::Ok();
        },
        fused_failure));
    VPR_RETURN_IF_ERROR(stage.run_twin(
        "unproject", twin_device,
        [&](const ExecContext& c) -> Status {
          for (size_t v = 0; v < views.size(); ++v) {
            view_points[v].clear();
            VPR_RETURN_IF_ERROR(VPR_TWIN(c, unproject_features)(features[v].features, snapshots[v].depth, views[v],
                                                                &view_points[v], c));
          }
          return Status::Ok();
        },
        fused_failure));
  }
  for (const auto& p : view_points) saliency_points.insert(saliency_points.end(), p.begin(), p.end());
  result.saliency_points = saliency_points.size() / 3;
  if (options.keep_saliency_points) {
    result.saliency_point_positions = saliency_points;
    to_model_units(front->norm, &result.saliency_point_positions);
  }

  if (!options.debug_dir.empty()) {
    VPR_RETURN_IF_ERROR(stage.run("debug_output", cpu, [&]() -> Status {
      std::error_code ec;
      std::filesystem::create_directories(options.debug_dir, ec);
      if (ec) return invalid_argument("cannot create debug directory " + options.debug_dir + ": " + ec.message());
      VPR_RETURN_IF_ERROR(host_snapshots());
      for (size_t v = 0; v < views.size(); ++v) {
        std::vector<float> model_points = view_points[v];  // in the input's units, to overlay on it
        to_model_units(front->norm, &model_points);
        VPR_RETURN_IF_ERROR(write_view_debug(options.debug_dir, views[v], snapshots[v], features[v], model_points));
      }
      return Status::Ok();
    }));
  }
  // The attention field's visibility cue, while the depth buffers are here.
  std::vector<float> visibility;
  if (options.density != DensityMode::kPaper) {
    VPR_RETURN_IF_ERROR(stage.run_twin("visibility", device, [&](const ExecContext& c) -> Status {
#ifdef VPR_HAVE_CUDA
      if (c.device == Device::kCuda && on_device && on_device->depths())
        return cuda::view_visibility_on_device(input.positions.data(), input.vertex_count(), views, on_device->depths(),
                                               options.visibility, &visibility, c);
#endif
      VPR_RETURN_IF_ERROR(host_snapshots());
      return VPR_TWIN(c, view_visibility)(input.positions.data(), input.vertex_count(), views, snapshots,
                                          options.visibility, &visibility, c);
    }));
  }
#ifdef VPR_HAVE_CUDA
  on_device.reset();
#endif
  snapshots.clear();
  features.clear();
  view_points.clear();

  front->mean_edge = mean_edge_length(input);
  if (options.density == DensityMode::kPaper) return Status::Ok();  // its field is the back half's

  // Stage 4: the attention field (attention_field.h) on the input vertices;
  // the surface CVT's density also reuses the curvature computed here.
  std::string note;
  VPR_RETURN_IF_ERROR(stage.run_twin(
      "saliency_field", device,
      [&](const ExecContext& c) -> Status {
        std::vector<double>& curvature = front->curvature;
        if (curvature_beside.valid()) {  // once: a CPU rerun after a GPU failure keeps it
          const auto start = Clock::now();
          ahead = curvature_beside.get();
          curvature = std::move(ahead.curvature);
          char text[112];
          std::snprintf(text, sizeof text, "%.1f ms waiting for the curvature and grid (made beside stages 1-3, ",
                        ms_since(start));
          note = text + ahead.where + ")";
        }
        std::vector<float> h_own;
        if (curvature.empty() || ahead.h.size() != input.vertex_count())
          h_own = attention_curvature(input, options.attention, &curvature);
        // A given attention map takes the field's place (below): only the
        // curvature, which the density needs, is made here then.
        if (options.attention_map) return Status::Ok();
        const bool prepared =
            h_own.empty() && !ahead.prep.fine.empty() && ahead.prep.fine.size() == input.vertex_count();
        const float* h = h_own.empty() ? ahead.h.data() : h_own.data();
        // The image cue: the front half's saliency points (stage 3), in the
        // same normalized space as the input's vertices.
        const FeaturePoints points{saliency_points.data(), saliency_points.size() / 3};
        return VPR_TWIN(c, attention_field)(input.positions.data(), h, visibility.empty() ? nullptr : visibility.data(),
                                            points, input.vertex_count(), options.attention, &result.input_importance,
                                            c, prepared ? &ahead.prep : nullptr);
      },
      "", &note));
  if (options.attention_map) use_attention_map(*options.attention_map, *front, &result);
  return Status::Ok();
}

// The surface CVT's refined surface with its density (the density stage's
// work), shared by a visual target's tries that start warm.
struct SurfaceData {
  RefinedSurface refined;  // its values smoothed
  std::vector<double> area, mass;  // per surface element
  // What the CVT and the dual make of the surface alone, kept for the warm
  // tries that start from this surface (the same bits as making it again);
  // null where no try will (a single target, a chain's levels).
  struct Facts {
    CvtSurfaceCache cvt;
    std::mutex dual_mutex;
    std::shared_ptr<const DualSurface> dual;
  };
  std::shared_ptr<Facts> facts;
};

// A try's surface and CVT cells, from which a later try at a smaller count
// starts its CVT (CvtOptions::start_label).
struct WarmStart {
  uint32_t count = 0;
  std::shared_ptr<const SurfaceData> surface;
  std::vector<uint32_t> label;
  uint32_t refined_for = 0;  // the count the surface was refined for (a warm try's: its source's)
};

// A back half's warm start: from (null: a cold start) and keep (null: not
// kept; else set to this back half's surface and cells when it ran the
// surface CVT).
struct BackHalfWarm {
  const WarmStart* from = nullptr;
  std::shared_ptr<WarmStart>* keep = nullptr;
};

// Stages 5-7 for one level (options.target_vertices), from the front half.
// The result's mesh is left in the normalized frame (finish_output moves it).
Status run_back_half(FrontHalf& front, const PipelineOptions& options, int level, PipelineResult* out,
                     const BackHalfWarm& warm = {}) {
  const Mesh& input = front.input;
  const JobDevice& device = *front.device;
  const std::string cpu = "cpu";
  PipelineResult& result = *out;
  StageRunner stage(options, &result, level);
  const double spacing_out = target_spacing(front.area, options.target_vertices);

  // Stage 4 for the paper's density: Algorithm 1's field, whose depth scale
  // follows the output spacing.
  if (options.density == DensityMode::kPaper) {
    VPR_RETURN_IF_ERROR(stage.run_twin("saliency_field", device, [&](const ExecContext& c) -> Status {
      const float scale = resolve_depth_scale(options.field, spacing_out, front.mean_edge);
      return VPR_TWIN(c, saliency_field)(input.positions.data(), input.vertex_count(), front.saliency_points.data(),
                                         front.saliency_points.size() / 3, options.field, scale,
                                         &result.input_importance, c);
    }));
  }

  // Stages 5-7 on the input surface: a converged CVT with the chosen density,
  // then its dual. Polygon soups (no usable connectivity) go on below.
  if (options.density != DensityMode::kPaper) {
    // A warm start's surface is its source's; else made here.
    std::shared_ptr<SurfaceData> made;
    std::shared_ptr<const SurfaceData> data;
    bool soup = false;
    std::string note;
    if (warm.from) {
      data = warm.from->surface;
      note = "the surface and density of the try at " + std::to_string(warm.from->count) + " vertices (a warm start)";
    } else {
      made = std::make_shared<SurfaceData>();
      if (warm.keep) made->facts = std::make_shared<SurfaceData::Facts>();
      data = made;
    }
    VPR_RETURN_IF_ERROR(stage.run(
        "density", cpu,
        [&]() -> Status {
          if (!made) return Status::Ok();
          StepMarks marks("density");
          RefinedSurface& refined = made->refined;
          std::vector<double>& area = made->area;
          std::vector<double>& mass = made->mass;
          const std::vector<float> d =
              vertex_density(front.curvature, result.input_importance, options.density, options.attention_boost);
          std::vector<float> channels(2 * input.vertex_count());
          for (size_t v = 0; v < input.vertex_count(); ++v) {
            channels[2 * v] = result.input_importance[v];
            channels[2 * v + 1] = d[v];
          }
          std::future<StatusOr<RefinedSurface>> ahead;
          {
            std::lock_guard<std::mutex> lock(front.refined_ahead_mutex);
            auto it = std::find_if(front.refined_ahead.begin(), front.refined_ahead.end(),
                                   [&](const auto& a) { return a.first == options.target_vertices; });
            if (it != front.refined_ahead.end()) {
              ahead = std::move(it->second);
              front.refined_ahead.erase(it);
            }
          }
          const bool made_ahead = ahead.valid();
          marks.mark("vertex_density");
          if (made_ahead) {
            VPR_ASSIGN_OR_RETURN(refined, ahead.get());
            VPR_RETURN_IF_ERROR(carry_values(channels, 2, &refined));
          } else {
            VPR_ASSIGN_OR_RETURN(refined, refine_surface(input, channels, 2, refine_bounds(spacing_out, options),
                                                         refine_limit(input, options.target_vertices, options)));
          }
          marks.mark("refined");
          // Over about two output spacings (elements are a quarter of one
          // apart); on the GPU when the job has one (the same bits).
          ScalarEdgeSmoothing smooth_twin;
#ifdef VPR_HAVE_CUDA
          if (device.on_gpu()) {
            const ExecContext& c = device.context();
            smooth_twin = [&c](const MeshEdges& edges, int passes, std::vector<float>* values) {
              return cuda::smooth_over_edges(edges, passes, values, c);
            };
          }
#endif
          const bool smoothed_on_gpu = smooth_over_edges(refined.edges, 16, 2, 1, &refined.value, smooth_twin);
          marks.mark("smooth");
          // A soup: most edges have one face even after welding.
          const size_t entries = refined.edges.neighbor.size();  // each edge twice
          const std::vector<uint32_t>& uses = refined.edges.faces;
          const size_t single = tbb::parallel_reduce(
                                    tbb::blocked_range<size_t>(0, uses.size(), 65536), size_t(0),
                                    [&](const tbb::blocked_range<size_t>& r, size_t n) {
                                      return n + size_t(std::count(uses.begin() + r.begin(), uses.begin() + r.end(), 1u));
                                    },
                                    std::plus<size_t>()) /
                                2;
          const size_t distinct = entries / 2;
          soup = distinct == 0 || single * 4 > distinct;
          area = vertex_areas(refined.mesh, &refined.corners);
          mass.resize(area.size());
          tbb::parallel_for(tbb::blocked_range<size_t>(0, area.size(), 8192), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t v = r.begin(); v != r.end(); ++v) {
              const double dv = refined.value[2 * v + 1];
              mass[v] = area[v] * dv * dv;  // rho = D^2: point density follows D
            }
          });
          marks.mark("areas_mass");
          const std::string& rows = refined.edges_twin;
          note = std::string(density_mode_name(options.density)) + " density; " +
                 std::to_string(refined.mesh.vertex_count()) + " surface elements" +
                 (made_ahead ? " (refined ahead, beside the stages before)" : "") +
                 (rows == "gpu"   ? "; edge rows made on the GPU"
                  : !rows.empty() ? "; edge rows made on the host (GPU failed: " + rows + ")"
                                  : "") +
                 (smoothed_on_gpu ? "; smoothed on the GPU" : "") +
                 (soup ? "; a polygon soup: the paper's back half follows" : "");
          if (!refined.pinch_copies.empty())
            note +=
                "; " + std::to_string(refined.pinch_copies.size()) +
                " vertices copied where sheets met only at a vertex or at an edge of more than two faces (apart there)";
          return Status::Ok();
        },
        &note));
    if (!soup) {
      const RefinedSurface& refined = data->refined;
      const std::vector<double>& area = data->area;
      // The surface's parts and their shapes (the part fallback's reference)
      // depend on the surface alone: made on their own thread while the CVT,
      // whose serial steps leave cores idle, runs.
      std::future<SurfaceParts> parts_beside =
          std::async(std::launch::async, [&refined] { return surface_parts(refined.mesh, refined.edges); });
      // So are the dual's facts of the surface (its boundary and sharp
      // edges, the faces' planes): made while a GPU runs the CVT's sweeps
      // and the host would wait (igea at 10,000 on an H200: 18 ms of them
      // beside 38 ms of sweeps). Made beside the CVT's own host steps they
      // only slow those down: on 2 cores horse's job took 4-10% longer.
      std::future<DualSurface> dual_beside;
      SurfaceData::Facts* facts = data->facts.get();
      std::shared_ptr<const DualSurface> dual_kept;  // an earlier try's, on this surface
      if (facts) {
        std::lock_guard<std::mutex> lock(facts->dual_mutex);
        dual_kept = facts->dual;
      }
      auto make_dual = [&refined] { return dual_surface(refined.mesh, refined.edges, true); };
      auto make_dual_beside = [&dual_beside, &dual_kept, &make_dual] {
        if (!dual_beside.valid() && !dual_kept) dual_beside = std::async(std::launch::async, make_dual);
      };
      std::vector<uint32_t> label;
      CvtOptions cvt = options.cvt;
      cvt.seed = options.sampling.seed;
      cvt.anisotropy = options.anisotropy;         // the input has a unit diagonal here
      cvt.joined_elements = refined.pinch_copies;  // parts split at a pinch share one equal share
      cvt.corners = &refined.corners;
      if (warm.from) cvt.start_label = &warm.from->label;
      if (facts) cvt.surface_cache = &facts->cvt;
      // The sweeps in colour rounds (PipelineOptions::cvt_sweeps) on the
      // context's device: a GPU failure reruns the CVT on the CPU with the
      // rounds' CPU reference, the same labels.
      const bool rounds =
          options.cvt_sweeps == CvtSweeps::kColourRounds || (options.cvt_sweeps == CvtSweeps::kAuto && device.on_gpu());
      auto run_cvt = [&](const ExecContext& c) -> Status {
        CvtOptions twin = cvt;
        if (rounds) twin.device_sweeps = cpu::cvt_colour_sweeps;
#ifdef VPR_HAVE_CUDA
        if (rounds && c.device == Device::kCuda) {
          // The dual's facts start once the rounds' inputs are uploaded: their
          // parallel loops would hold the threads that copy the upload's
          // chunks (igea: 7.4 ms for 55 MB beside them, 1.8 ms alone).
          twin.device_sweeps = [&c, &make_dual_beside](const CvtSweepInput& in, std::vector<uint32_t>* l,
                                                       CvtSweepOutput* o) {
            CvtSweepInput with = in;
            with.uploaded = make_dual_beside;
            const Status s = cuda::cvt_colour_sweeps(with, l, o, c);
            make_dual_beside();  // once only: a failure before the upload still makes them
            return s;
          };
          twin.device_smoothing = [&c](const MeshEdges& edges, int passes, std::vector<Vec3d>* values) {
            return cuda::smooth_over_edges(edges, passes, values, c);
          };
          twin.device_growth = [&c](const CellGrowthInput& in, std::vector<uint32_t>* l) {
            return cuda::grow_cells(in, l, c);
          };
        }
#else
        (void)c;
        (void)make_dual_beside;
#endif
        VPR_RETURN_IF_ERROR(
            surface_cvt(refined.mesh, refined.edges, data->mass, options.target_vertices, twin, &label, &result.cvt));
        const auto& e = result.cvt.energy;
        char text[200];
        std::snprintf(text, sizeof text, "%d sweeps%s%s, energy %.4g -> %.4g", result.cvt.sweeps,
                      result.cvt.device_sweeps > 0
                          ? (" (" + std::to_string(result.cvt.device_sweeps) + " in colour rounds)").c_str()
                          : "",
                      result.cvt.converged ? " (converged)" : " (sweep limit)", e.front(), e.back());
        note = warm.from ? "from the cells of the try at " + std::to_string(warm.from->count) + " vertices, " +
                               (result.cvt.warm_split > 0 ? std::to_string(result.cvt.warm_split) + " cut in two; "
                                                          : std::to_string(result.cvt.warm_merged) + " merged; ") +
                               text
                         : std::string(text);
        if (result.cvt.parts_below_minimum > 0)
          note += "; " + std::to_string(result.cvt.parts_below_minimum) + " of " + std::to_string(result.cvt.parts) +
                  " parts got fewer than " + std::to_string(cvt.min_per_part) + " vertices (target too small)";
        if (result.cvt.cells_split > 0)
          note += "; " + std::to_string(result.cvt.cells_split) + " cells split for topology, " +
                  std::to_string(result.cvt.cells_merged) + " merged";
        if (result.cvt.defective_cells > 0)
          note += "; " + std::to_string(result.cvt.defective_cells) + " cells still non-manifold";
        return Status::Ok();
      };
      if (device.on_gpu() && rounds)
        VPR_RETURN_IF_ERROR(stage.run_twin("cvt", device, run_cvt, "", &note));
      else
        VPR_RETURN_IF_ERROR(stage.run(
            "cvt", cpu, [&] { return run_cvt(ExecContext{}); }, &note));
      VPR_RETURN_IF_ERROR(stage.run(
          "meshing", cpu,
          [&]() -> Status {
            std::vector<uint32_t> cell;
            const uint32_t cells = result.cvt.clusters;
            ClusterMeshOptions mesh_options = options.cluster_mesh;
            // The dual's facts of the surface: an earlier try's, made beside
            // the GPU's sweeps, or made here and kept when later tries will
            // start from this surface (else mesh_clusters makes them).
            std::shared_ptr<const DualSurface> dual = dual_kept;
            if (!dual && dual_beside.valid()) {
              dual = std::make_shared<const DualSurface>(dual_beside.get());
            } else if (!dual && facts) {
              dual = std::make_shared<const DualSurface>(make_dual());
            }
            if (dual) mesh_options.surface_facts = dual.get();
            if (facts && !dual_kept) {
              std::lock_guard<std::mutex> lock(facts->dual_mutex);
              facts->dual = dual;
            }
#ifdef VPR_HAVE_CUDA
            // The L2 fit's samples matched and summed on the GPU (the host's
            // bits; the host fits if the device fails).
            if (device.on_gpu()) {
              const ExecContext& c = device.context();
              mesh_options.offset.device_samples = [&c](const OffsetSamples& s) {
                return cuda::offset_sample_set(s, c);
              };
              // The projections onto the cells' faces too (the host's bits).
              if (options.dual_projection_on_gpu)
                mesh_options.device_projector = [&c](const CellFaceLists& lists) {
                  return cuda::dual_projector(lists, c);
                };
            }
#endif
            StepMarks marks("meshing");
            VPR_RETURN_IF_ERROR(mesh_clusters(refined.mesh, refined.edges, label, cells, &result.mesh, &cell,
                                              &result.cluster_mesh, mesh_options));
            marks.mark("dual");
            PartFallbackStats fallback;
            const SurfaceParts& parts = parts_beside.get();
            marks.mark("parts_wait");
            VPR_RETURN_IF_ERROR(replace_broken_parts(refined.mesh, refined.edges, parts, label, options.target_vertices,
                                                     &result.mesh, &cell, &fallback));
            marks.mark("fallback");
            // A surface of scattered triangles that meet every which way (the
            // pipeline fuzzer makes them) can leave the dual no face: the job
            // fails with that, never returns an empty mesh as a result.
            if (result.mesh.face_count() == 0)
              return invalid_argument(
                  "the dual of the CVT cells has no face: the input is too broken a "
                  "surface (scattered or crossing triangles) to remesh to " +
                  std::to_string(options.target_vertices) + " vertices");
            // Each output vertex: its cell's mean importance (area-weighted).
            std::vector<double> sum(cells, 0.0), weight(cells, 0.0);
            for (size_t v = 0; v < label.size(); ++v)
              if (label[v] != UINT32_MAX) {
                sum[label[v]] += area[v] * refined.value[2 * v];
                weight[label[v]] += area[v];
              }
            result.saliency.resize(cell.size());
            for (size_t v = 0; v < cell.size(); ++v)
              result.saliency[v] = weight[cell[v]] > 0 ? float(sum[cell[v]] / weight[cell[v]]) : 1.0f;
            marks.mark("carry");
            result.meshing = result.cluster_mesh.repair;
            note = "dual of the CVT cells; " + std::to_string(result.cluster_mesh.holes_closed) +
                   " dual holes closed, " + std::to_string(result.cluster_mesh.boundary_loops) + " boundary loops kept";
            if (fallback.parts_replaced > 0)
              note += "; " + std::to_string(fallback.parts_replaced) + " of " +
                      std::to_string(fallback.closed_parts + fallback.open_parts) +
                      " parts decimated instead (their dual lost the part's shape: opened, closed, in pieces or gone)";
            if (fallback.parts_left > 0) note += "; " + std::to_string(fallback.parts_left) + " parts came out broken";
            const OffsetFitStats& fit = result.cluster_mesh.offset;
            if (fit.free_vertices > 0) {
              char text[200];
              std::snprintf(text, sizeof text,
                            "; L2 offsets of %zu vertices (%zu held, %zu at the bound, %zu dropped): RMS distance "
                            "%.4f%% -> %.4f%% of the diagonal",
                            fit.free_vertices, fit.held_vertices, fit.clamped, fit.dropped, 100 * fit.rms_before,
                            100 * fit.rms_after);
              note += text;
              if (fit.device_rounds > 0) note += " (samples matched and summed on the GPU)";
              if (!fit.device_failure.empty())
                note += " (fitted on the CPU: the GPU failed: " + fit.device_failure + ")";
            }
            if (result.cluster_mesh.projected_on_device)
              note += "; vertices placed and relaxed on the GPU";
            else if (!result.cluster_mesh.projection_fallback.empty())
              note += "; vertices placed and relaxed on the CPU: the GPU failed: " +
                      result.cluster_mesh.projection_fallback;
            return Status::Ok();
          },
          &note));
      result.back_half = std::string("surface CVT (") + density_mode_name(options.density) + " density)";
      if (warm.keep)
        *warm.keep = std::make_shared<WarmStart>(WarmStart{options.target_vertices, data, std::move(label),
                                                           warm.from ? warm.from->refined_for : options.target_vertices});
      return Status::Ok();
    }
  }
  result.back_half = "paper (adaptive sampling, AWLOP, advancing front)";

  // Stage 5: adaptive sampling of the target count (Eq. 7-16).
  std::vector<float> particles, particle_importance;
  VPR_RETURN_IF_ERROR(stage.run_twin("sampling", device, [&](const ExecContext& c) -> Status {
    std::vector<double> quantity;
    std::vector<uint32_t> counts, offsets;
    VPR_RETURN_IF_ERROR(VPR_TWIN(c, visual_quantity)(input, result.input_importance.data(), &quantity, c));
    VPR_RETURN_IF_ERROR(VPR_TWIN(c, distribute_counts)(quantity.data(), quantity.size(), options.target_vertices,
                                                       &counts, &offsets, c));
    return VPR_TWIN(c, sample_triangles)(input, result.input_importance.data(), counts.data(), offsets.data(),
                                         options.sampling, &particles, &particle_importance, c);
  }));

  // Stage 6: AWLOP. Its input points are area-uniform samples of the input
  // surface rather than its vertices, so that CAD meshes with long thin
  // triangles (vertices only on creases) do not pull the particles to edges.
  const std::vector<float> sampled_particles = particles;  // a CPU rerun after a GPU failure starts from these
  VPR_RETURN_IF_ERROR(stage.run_twin("awlop", device, [&](const ExecContext& c) -> Status {
    particles = sampled_particles;
    const uint64_t count = uint64_t(options.target_vertices) * options.awlop.attraction_samples_per_target;
    std::vector<uint32_t> counts, offsets;
    VPR_RETURN_IF_ERROR(
        VPR_TWIN(c, distribute_counts)(front.areas.data(), front.areas.size(), uint32_t(count), &counts, &offsets, c));
    std::vector<float> ones(input.vertex_count(), 1.0f), surface_points, unused;
    SamplingOptions uniform = options.sampling;
    uniform.seed = options.sampling.seed ^ 0x5EEDA77AC7ull;  // independent of the particles' stream
    uniform.adaptive_min_samples = UINT32_MAX;
    VPR_RETURN_IF_ERROR(VPR_TWIN(c, sample_triangles)(input, ones.data(), counts.data(), offsets.data(), uniform,
                                                      &surface_points, &unused, c));
    VPR_ASSIGN_OR_RETURN(const double h, awlop_support_radius(options.awlop.support, options.awlop.h_factor,
                                                              front.mean_edge, front.area, options.target_vertices));
    return VPR_TWIN(c, awlop)(surface_points.data(), surface_points.size() / 3, particles.data(),
                              particle_importance.data(), particle_importance.size(), h, options.awlop, &result.awlop,
                              c);
  }));

  // Stage 7: mesh the optimized points; each output vertex keeps its
  // particle's importance as its saliency value.
  return stage.run("meshing", cpu, [&]() -> Status {
    std::vector<uint32_t> source;
    // Parallel slabs only where their seams can close: a surface without
    // boundary (an open one would fail the seam check and cost a second run).
    MeshingOptions meshing = options.meshing;
    if (!(meshing.spacing > 0)) meshing.spacing = spacing_out;
    const bool slabs_possible = meshing.points_per_slab > 0 && particles.size() / 3 >= 2 * meshing.points_per_slab;
    if (slabs_possible && !has_no_boundary(input)) meshing.points_per_slab = 0;
    VPR_RETURN_IF_ERROR(
        mesh_points(particles.data(), particles.size() / 3, meshing, &result.mesh, &source, &result.meshing));
    result.saliency.resize(source.size());
    for (size_t v = 0; v < source.size(); ++v) result.saliency[v] = particle_importance[source[v]];
    return Status::Ok();
  });
}

// A level's result: the shared part of the front half, then its back half
// (level 0 also carries the front half's stage timings).
PipelineResult level_result(const FrontHalf& front, int level, uint32_t target) {
  PipelineResult r;
  r.level = level;
  r.target = target;
  r.input_importance = front.shared.input_importance;
  r.saliency_points = front.shared.saliency_points;
  r.ignored_vertices = front.shared.ignored_vertices;
  r.dropped_parts = front.shared.dropped_parts;
  r.renderer = front.shared.renderer;
  r.device = front.shared.device;
  r.cpu_reason = front.shared.cpu_reason;
  if (level == 0) {
    r.stages = front.shared.stages;
    r.saliency_point_positions = front.shared.saliency_point_positions;
  }
  return r;
}

// The options with their callbacks (keep_going, on_stage, on_stage_begin)
// called under `lock`, for back halves that run on several threads at once.
PipelineOptions with_locked_callbacks(const PipelineOptions& options, std::mutex* lock) {
  PipelineOptions o = options;
  if (options.keep_going)
    o.keep_going = [&options, lock]() {
      std::lock_guard<std::mutex> held(*lock);
      return options.keep_going();
    };
  if (options.on_stage)
    o.on_stage = [&options, lock](const StageTiming& t) {
      std::lock_guard<std::mutex> held(*lock);
      options.on_stage(t);
    };
  if (options.on_stage_begin)
    o.on_stage_begin = [&options, lock](const char* name) {
      std::lock_guard<std::mutex> held(*lock);
      options.on_stage_begin(name);
    };
  return o;
}

// One level's back half at `count` vertices: its result, the front half's
// shared part first (level_result).
Status back_half_at(FrontHalf& front, const PipelineOptions& options, int level, uint32_t count, PipelineResult* out,
                    const BackHalfWarm& warm = {}) {
  PipelineOptions o = options;
  o.target_vertices = count;
  *out = level_result(front, level, count);
  return run_back_half(front, o, level, out, warm);
}

// A back half made ahead for a visual target's search (run_visual_target).
struct AheadTry {
  std::atomic<bool> cancel{false};
  std::future<void> done;
  Status status;
  PipelineResult attempt;
  std::vector<StageTiming> held;  // its stage events, sent when the search takes it
};

// A level with a visual target: back halves at the counts the search picks,
// each judged by SSIM against the input from the job's own views (count and
// resolution); the level is the smallest count that reached the bound (or the
// largest tried, when none did, which its note says).
StatusOr<PipelineResult> run_visual_target(FrontHalf& front, const PipelineOptions& options, int level,
                                           const LevelTarget& target) {
  const double min_ssim = target.min_ssim;
  VisualSimilarityOptions judge;
  judge.views = options.views.count;
  judge.resolution = target.screen_px > 0 ? int(target.screen_px) : options.views.resolution;
  judge.line_drawings = false;  // the bound is on the shaded SSIM alone
  VPR_ASSIGN_OR_RETURN(const VisualReference reference, VisualReference::create(front.input, front.renderer, judge));
  VisualTargetOptions search_options;
  search_options.min_ssim = min_ssim;
  search_options.lowest = kMinTargetVertices;
  search_options.highest = uint32_t(std::clamp<size_t>(front.input.vertex_count(), kMinTargetVertices,
                                               std::min(kMaxTargetVertices, options.max_level_vertices)));

  // Tries made ahead (PipelineOptions::visual_target_ahead): while the try at
  // n runs, the try the search makes next when n passes (asked of a copy of
  // the search given a score just above the bound: after a pass the next
  // count does not depend on the score) runs beside it on its own thread,
  // its parallel loops on the cores the try at n leaves idle; with 2, also
  // the next after a failure (a copy given a score just below the bound:
  // there the next count depends on the score, and on the H100 machine the
  // guess was right for 3 of horse's 14 and the search no faster). Every
  // back half is deterministic, so the search sees the same scores and asks
  // for the same counts: the outcome is the same either way. Once n's score
  // is in, the tries made ahead that the search does not ask for next are
  // cancelled at their next stage. The callbacks are called under one lock.
  // (vpremesh-visual-replay --ahead replays this on measured curves.)
  const bool ahead_on =
      options.density != DensityMode::kPaper &&
      (options.visual_target_ahead > 0 || (options.visual_target_ahead < 0 && !options.visual_target_warm &&
                                           tbb::this_task_arena::max_concurrency() >= 8));
  // Warm starts (PipelineOptions::visual_target_warm): once a try has
  // passed, a try below it by at most kWarmRange takes the smallest passing
  // try's refined surface and density, and starts its CVT from that try's
  // cells, the surplus merged away (CvtOptions::start_label): near the bound,
  // where the search spends most, a try then costs the merges, a few sweeps
  // and the dual instead of a whole back half. A try's outcome then depends
  // on the tries before it, so none is made ahead (the tries ahead would
  // change which try starts from which). The elements per cell rise by the
  // range at most (16 per output vertex at the source's count).
  // Before the first pass, a try above the largest failing one starts from
  // that failure's surface and cells in the same way, its largest cells
  // cut in two, when its count is at most kCutRange above the count that
  // surface was refined for (the elements per cell fall by that at most:
  // 14.5 per output vertex). The search closes on the bound from below
  // there, and its last cold tries were each a whole back half. (Past 10%
  // the fewer elements cost score: nefertiti's cut at 12% above its
  // surface's count scored 0.9690 against 0.9702 cold, and the next cut,
  // 22% above, 0.9708 against 0.9720.)
  constexpr double kWarmRange = 1.15;
  constexpr double kCutRange = 1.10;
  const bool warm_on = options.visual_target_warm && options.density != DensityMode::kPaper && !ahead_on;
  std::shared_ptr<WarmStart> source;  // the smallest passing try's, when warm_on
  std::shared_ptr<WarmStart> below;   // the largest failing try's, when warm_on, until the first pass
  // Near the bound a failing score lies about this far below it (SSIM moves
  // by about 0.001 between counts 1% apart there).
  constexpr double kFailingMargin = 0.0005;
  std::mutex callbacks;
  const PipelineOptions live = ahead_on ? with_locked_callbacks(options, &callbacks) : options;
  std::map<uint32_t, std::unique_ptr<AheadTry>> ahead;
  std::vector<std::unique_ptr<AheadTry>> stopped;  // cancelled, perhaps still running
  // However the search ends, the tries still made ahead stop and are waited for.
  struct Drain {
    std::map<uint32_t, std::unique_ptr<AheadTry>>& tries;
    std::vector<std::unique_ptr<AheadTry>>& stopped;
    ~Drain() {
      for (auto& entry : tries) entry.second->cancel = true;
      for (auto& entry : tries)
        if (entry.second->done.valid()) entry.second->done.wait();
      for (auto& a : stopped)
        if (a->done.valid()) a->done.wait();
    }
  } drain{ahead, stopped};
  int made_ahead = 0, taken = 0, confirmed = 0;
  auto make_ahead = [&](uint32_t count) {
    auto made = std::make_unique<AheadTry>();
    AheadTry* a = made.get();
    PipelineOptions o = live;
    o.on_stage = [a](const StageTiming& t) { a->held.push_back(t); };
    o.on_stage_begin = nullptr;
    o.keep_going = [&live, a]() { return !a->cancel.load() && (!live.keep_going || live.keep_going()); };
    ++made_ahead;
    a->done = std::async(std::launch::async, [&front, o, a, level, count] {
      a->status = back_half_at(front, o, level, count, &a->attempt);
    });
    ahead[count] = std::move(made);
  };

  // A try's score, as a stage event on its result (`how`: how it started).
  auto judge_try = [&](uint32_t count, PipelineResult* a, const char* how) -> StatusOr<double> {
    const auto start = Clock::now();
    VPR_ASSIGN_OR_RETURN(const VisualSimilarity similarity, reference.compare(a->mesh));
    char note[128];
    std::snprintf(note, sizeof note, "%u vertices: SSIM %.4f (bound %.4f)%s", count, similarity.ssim_mean, min_ssim,
                  how);
    a->stages.push_back({"visual_target", ms_since(start), "cpu", note, level});
    if (live.on_stage) live.on_stage(a->stages.back());
    return similarity.ssim_mean;
  };

  VPR_ASSIGN_OR_RETURN(VisualSearch search, VisualSearch::start(search_options));
  std::optional<PipelineResult> best;  // the smallest passing count's, else the largest count's
  bool best_passed = false;
  for (uint32_t count = search.next(); count != 0; count = search.next()) {
    std::unique_ptr<AheadTry> made;
    if (auto it = ahead.find(count); it != ahead.end()) {
      made = std::move(it->second);
      ahead.erase(it);
    }
    if (ahead_on) {
      for (const double s : {std::min(min_ssim + kFailingMargin, 1.0), min_ssim - kFailingMargin}) {
        if (s < min_ssim && options.visual_target_ahead != 2) continue;  // the pass's try only
        const uint32_t next = search.next_after(count, s);
        if (next != 0 && next != count && !ahead.count(next)) make_ahead(next);
      }
    }
    PipelineResult attempt;
    std::shared_ptr<WarmStart> kept;
    BackHalfWarm warm;
    if (warm_on) {
      warm.keep = &kept;
      if (source && count < source->count && double(count) * kWarmRange >= double(source->count))
        warm.from = source.get();
      else if (below && count > below->count && double(below->refined_for) * kCutRange >= double(count))
        warm.from = below.get();
    }
    if (made) {
      ++taken;
      made->done.wait();
      VPR_RETURN_IF_ERROR(made->status);
      attempt = std::move(made->attempt);
      for (const StageTiming& t : made->held)
        if (live.on_stage) live.on_stage(t);
    } else {
      VPR_RETURN_IF_ERROR(back_half_at(front, live, level, count, &attempt, warm));
    }
    const bool cut_start = warm.from && warm.from == below.get();
    VPR_ASSIGN_OR_RETURN(double ssim, judge_try(count, &attempt, cut_start ? " (a cut start)" : ""));
    // A cut start that fails near the bound is confirmed from scratch
    // (PipelineOptions::visual_target_confirm): its failure would raise the
    // bracket's low end, and every later try lies above it.
    if (cut_start && ssim < min_ssim && ssim >= min_ssim - options.visual_target_confirm) {
      BackHalfWarm cold;
      cold.keep = &kept;
      attempt = PipelineResult();
      VPR_RETURN_IF_ERROR(back_half_at(front, live, level, count, &attempt, cold));
      VPR_ASSIGN_OR_RETURN(ssim, judge_try(count, &attempt, " (the cut start's count again, from scratch)"));
      ++confirmed;
    }
    const bool passes = ssim >= min_ssim;
    // One source held at a time besides the running try (two surfaces at
    // most): the failure's only until the first pass.
    if (passes && kept && (!source || count < source->count)) source = std::move(kept), below.reset();
    if (!passes && kept && !source && (!below || count > below->count)) below = std::move(kept);
    const bool better = !best || (passes && (!best_passed || count < best->target)) ||
                        (!passes && !best_passed && count > best->target);
    if (better) {
      attempt.search.ssim = ssim;
      best = std::move(attempt);
      best_passed = passes;
    }
    search.record(count, ssim);
    for (auto it = ahead.begin(); it != ahead.end();) {  // not the search's next: stopped
      if (it->first == search.next()) {
        ++it;
        continue;
      }
      it->second->cancel = true;
      stopped.push_back(std::move(it->second));
      it = ahead.erase(it);
    }
  }
  const VisualTargetOutcome outcome = search.outcome();
  PipelineResult result = std::move(*best);
  result.search.min_ssim = min_ssim;
  result.search.tries = int(outcome.tries.size()) + confirmed;
  result.search.confirmed = confirmed;
  result.search.made_ahead = made_ahead;
  result.search.taken = taken;
  char note[200];
  std::snprintf(note, sizeof note, "%u vertices chosen after %zu tries: SSIM %.4f %s %.4f", result.target,
                size_t(result.search.tries), result.search.ssim, outcome.reached ? ">=" : "< (not reached)", min_ssim);
  if (confirmed > 0)
    std::snprintf(note + std::strlen(note), sizeof note - std::strlen(note), "; %d cut start%s confirmed from scratch",
                  confirmed, confirmed > 1 ? "s" : "");
  if (made_ahead > 0)
    std::snprintf(note + std::strlen(note), sizeof note - std::strlen(note), "; %d of them made ahead (of %d)", taken,
                  made_ahead);
  result.stages.push_back({"visual_target", 0, "cpu", note, level});
  if (options.on_stage) options.on_stage(result.stages.back());
  return result;
}

// A level's colors (from the given mesh, when it has colors or textures:
// color_transfer.h) and its time since the job began.
Status finish_level(const FrontHalf& front, const Mesh& given, const PipelineOptions& options, PipelineResult* result) {
  finish_output(front.norm, front.used, front.given_vertices, options.field.min_importance, result);
  if (has_appearance(given)) {
    StageRunner stage(options, result, result->level);
    VPR_RETURN_IF_ERROR(
        stage.run("colors", "cpu", [&] { return transfer_colors(given, result->mesh, &result->mesh.colors); }));
  }
  return Status::Ok();
}

// Count levels of the surface CVT, run side by side (PipelineOptions::
// levels_side_by_side): each level's back half is one task of a task group,
// so TBB runs one level's parallel loops on the cores another's serial steps
// leave idle, as many levels at once as fit the memory one at a time holds.
// Each stage is deterministic on any thread count, so every level has the
// bits it has alone. A level is delivered as soon as it and the levels before
// it are done, and its stage events stream in level order (as one at a
// time); the callbacks are called under one lock, never two at once; a
// failure (the first in level order) stops the later levels at their next
// stage.
Status run_levels_side_by_side(FrontHalf& front, const Mesh& given, const PipelineOptions& options,
                               const std::vector<uint32_t>& counts, const LevelCallback& on_level) {
  struct Slot {
    bool done = false;
    Status status;
    PipelineResult result;
    std::vector<StageTiming> held;  // its stage events, until the levels before it are delivered
  };
  std::vector<Slot> slots(counts.size());
  size_t next = 0;  // the first level not yet delivered
  Status failed;
  std::mutex callbacks;
  std::atomic<bool> stop{false};
  const PipelineOptions locked = with_locked_callbacks(options, &callbacks);
  PipelineOptions shared = locked;
  shared.keep_going = [&]() { return !stop.load() && (!locked.keep_going || locked.keep_going()); };
  // Stage events stream in level order, as one at a time: the first level
  // not yet delivered reports live, a later one's are held until its turn.
  shared.on_stage = [&](const StageTiming& t) {
    std::lock_guard<std::mutex> lock(callbacks);
    if (!options.on_stage) return;
    if (t.level == int(next))
      options.on_stage(t);
    else if (t.level > int(next) && size_t(t.level) < slots.size())
      slots[size_t(t.level)].held.push_back(t);
  };
  // With `callbacks` held: from `next` on, each level's held events, then
  // the level itself if it is done.
  auto deliver = [&]() {
    for (; next < slots.size() && failed.ok(); ++next) {
      Slot& slot = slots[next];
      for (const StageTiming& t : slot.held) options.on_stage(t);
      slot.held.clear();
      if (!slot.done) break;
      failed = slot.status;
      if (!failed.ok()) break;
      slot.result.total_ms = ms_since(front.start);
      failed = on_level(std::move(slot.result));
      slot.result = PipelineResult();
    }
    if (!failed.ok()) stop.store(true);
  };
  // Levels start in order while their surfaces' estimates (the input's
  // vertices plus the elements per vertex times the count) fit in twice the
  // largest level's: one at a time holds a level's surface and the next
  // one's refinement made ahead, up to two such surfaces, so side by side
  // holds no more than that bound (sixteen levels of one size run two at a
  // time; a chain whose largest level dominates runs whole). A level that
  // ends makes room for the next ones; after a failure none starts. Each
  // level is isolated: a thread waiting inside one level's parallel loop
  // takes work of that level only, never a whole other level (which would
  // hold the first one up, or run a callback under the lock it waits on).
  std::vector<double> size(counts.size());
  for (size_t i = 0; i < counts.size(); ++i)
    size[i] = double(front.input.vertex_count()) + most_elements_per_vertex(options) * double(counts[i]);
  const double budget = 2 * *std::max_element(size.begin(), size.end());
  std::mutex admit;
  size_t started = 0;
  double running = 0;
  tbb::task_group group;
  std::function<void()> start_more = [&]() {  // with `admit` held
    while (!stop.load() && started < counts.size() && (running == 0 || running + size[started] <= budget)) {
      const size_t i = started++;
      running += size[i];
      group.run([&, i] {
        Slot& slot = slots[i];
        tbb::this_task_arena::isolate([&] {
          slot.status = back_half_at(front, shared, int(i), counts[i], &slot.result);
          if (slot.status.ok()) slot.status = finish_level(front, given, shared, &slot.result);
        });
        {
          std::lock_guard<std::mutex> lock(admit);
          running -= size[i];
          start_more();
        }
        std::lock_guard<std::mutex> lock(callbacks);
        slot.done = true;
        tbb::this_task_arena::isolate([&] { deliver(); });
      });
    }
  };
  {
    std::lock_guard<std::mutex> lock(admit);
    start_more();
  }
  group.wait();
  return failed;
}

}  // namespace

Status check_levels(const std::vector<LevelTarget>& levels) {
  if (levels.empty()) return invalid_argument("the level list is empty: give at least one target");
  if (levels.size() > kMaxLevels)
    return invalid_argument(std::to_string(levels.size()) + " levels asked; at most " + std::to_string(kMaxLevels));
  for (size_t i = 0; i < levels.size(); ++i) {
    const LevelTarget& l = levels[i];
    const std::string name = "level " + std::to_string(i) + ": ";
    const int set = (l.vertices != 0) + (l.fraction != 0) + (l.min_ssim != 0 || l.screen_px != 0);
    if (set == 0) return invalid_argument(name + "no target (a vertex count, a fraction or a minimum SSIM; 0 is none)");
    if (set > 1)
      return invalid_argument(name + "give one of a vertex count, a fraction or a minimum SSIM, not several");
    if (l.vertices != 0 && (l.vertices < kMinTargetVertices || l.vertices > kMaxTargetVertices))
      return invalid_argument(name + "target of " + std::to_string(l.vertices) +
                              " vertices is outside the supported range [" + std::to_string(kMinTargetVertices) + ", " +
                              std::to_string(kMaxTargetVertices) + "]");
    if (l.fraction != 0 && !(l.fraction > 0 && l.fraction <= 1))
      return invalid_argument(name + "fraction " + std::to_string(l.fraction) + " of the input is outside (0, 1]");
    if (l.min_ssim != 0 && !(l.min_ssim > 0 && l.min_ssim < 1))
      return invalid_argument(name + "minimum SSIM " + std::to_string(l.min_ssim) + " is outside (0, 1)");
    if (l.screen_px != 0 && l.min_ssim == 0)
      return invalid_argument(name + "a screen size needs a minimum SSIM to keep at that size");
    if (l.screen_px != 0 && (l.screen_px < 64 || l.screen_px > 4096))
      return invalid_argument(name + "screen size of " + std::to_string(l.screen_px) +
                              " px is outside the supported range [64, 4096]");
  }
  return Status::Ok();
}

StatusOr<std::vector<uint32_t>> level_counts(const std::vector<LevelTarget>& levels, size_t input_vertices,
                                             uint32_t max_vertices) {
  max_vertices = std::min(max_vertices, kMaxTargetVertices);
  VPR_RETURN_IF_ERROR(check_levels(levels));
  std::vector<uint32_t> counts;
  for (size_t i = 0; i < levels.size(); ++i) {
    const LevelTarget& l = levels[i];
    if (l.fraction == 0) {
      counts.push_back(l.vertices);
      continue;
    }
    const double n = std::round(l.fraction * double(input_vertices));
    if (n < kMinTargetVertices || n > max_vertices)
      return invalid_argument("level " + std::to_string(i) + ": fraction " + std::to_string(l.fraction) + " of " +
                              std::to_string(input_vertices) + " input vertices is " + std::to_string(int64_t(n)) +
                              ", outside the supported range [" + std::to_string(kMinTargetVertices) + ", " +
                              std::to_string(max_vertices) + "]");
    counts.push_back(uint32_t(n));
  }
  return counts;
}

Status run_pipeline_levels(const Mesh& given, const PipelineOptions& options, const std::vector<LevelTarget>& levels,
                           const LevelCallback& on_level) {
  const RunningJob counted;  // loops split by the job's share of the threads (core/running_jobs.h)
  VPR_RETURN_IF_ERROR(check_levels(levels));
  PipelineOptions checked = options;
  checked.target_vertices = kMinTargetVertices;  // each level's count is checked by level_counts
  VPR_RETURN_IF_ERROR(validate_options(checked));
  VPR_RETURN_IF_ERROR(validate_mesh(given));
  FrontHalf front;
  VPR_RETURN_IF_ERROR(prepare_input(given, options, &front));
  VPR_ASSIGN_OR_RETURN(const std::vector<uint32_t> counts,
                       level_counts(levels, front.input.vertex_count(), options.max_level_vertices));
  // A count level's refinement needs only the input and the count: the first
  // level's runs beside the front half (as the curvature does), each next
  // one's beside the level before it, and the level's density stage takes
  // it, the same bits as refining there.
  auto refine_ahead = [&](size_t level) {
    if (level >= levels.size() || levels[level].min_ssim > 0 || options.density == DensityMode::kPaper) return;
    const EdgeBounds bounds = refine_bounds(target_spacing(front.area, counts[level]), options);
    const size_t limit = refine_limit(front.input, counts[level], options);
    const Mesh* input = &front.input;
    const JobDevice* device = front.device.get();
    front.refined_ahead.emplace_back(counts[level], std::async(std::launch::async, [input, bounds, limit, device] {
                                       return refine_geometry(*input, bounds, limit, edge_rows_twin(*device));
                                     }));
  };
  // The device first: the refinement ahead makes its edge rows there.
  front.start = Clock::now();
  VPR_ASSIGN_OR_RETURN(front.device, JobDevice::select(options.device, options.cuda_device, options.device_budget));
  refine_ahead(0);
  VPR_RETURN_IF_ERROR(run_front_half(options, &front));
  const bool all_counts =
      std::all_of(levels.begin(), levels.end(), [](const LevelTarget& l) { return l.min_ssim == 0; });
  if (options.levels_side_by_side && levels.size() > 1 && all_counts && options.density != DensityMode::kPaper)
    return run_levels_side_by_side(front, given, options, counts, on_level);

  for (size_t i = 0; i < levels.size(); ++i) {
    refine_ahead(i + 1);
    PipelineResult result;
    if (levels[i].min_ssim > 0) {
      VPR_ASSIGN_OR_RETURN(result, run_visual_target(front, options, int(i), levels[i]));
    } else {
      VPR_RETURN_IF_ERROR(back_half_at(front, options, int(i), counts[i], &result));
    }
    VPR_RETURN_IF_ERROR(finish_level(front, given, options, &result));
    result.total_ms = ms_since(front.start);
    VPR_RETURN_IF_ERROR(on_level(std::move(result)));
  }
  return Status::Ok();
}

StatusOr<PipelineResult> run_pipeline(const Mesh& given, const PipelineOptions& options) {
  VPR_RETURN_IF_ERROR(validate_options(options));
  LevelTarget one;
  one.vertices = options.target_vertices;
  PipelineResult out;
  VPR_RETURN_IF_ERROR(run_pipeline_levels(given, options, {one}, [&](PipelineResult&& r) {
    out = std::move(r);
    return Status::Ok();
  }));
  return out;
}

}  // namespace vpr
