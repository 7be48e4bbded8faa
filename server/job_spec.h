// The one place where the API's JobSpec / PipelineOptions messages become
// vpr::PipelineOptions and back (STYLE.md: "server/ converts messages to
// those arrays and back, in one place"). The server validates uploads with
// job_options_from_spec; the client builds specs from its CLI flags with
// make_job_spec, so `vpremesh submit` and `vpremesh local` with the same
// flags run the same pipeline.
//
// Zero in a numeric proto field means "the pipeline's default" (proto3 cannot
// tell unset from zero). Three values therefore cannot travel: threshold_c = 0,
// seed = 0 and awlop_iterations = 0 arrive as the defaults 3, 1 and 10;
// pipeline_options_to_proto reports them as not representable.
#pragma once

#include <string>
#include <vector>

#include "core/status.h"
#include "io/mesh_io.h"
#include "pipeline/pipeline.h"
#include "vpremesh/v1/remesh.pb.h"

namespace vpr::service {

namespace v1 = ::vpremesh::v1;

// The default Draco quantization of returned meshes: the same as
// `vpremesh local -o out.drc` (DracoOptions::position_bits), so both give
// byte-identical files.
inline constexpr int kDefaultResultQuantizationBits = 14;

// The payload switches that default to yes (remesh.proto: unset = yes).
inline bool returns_mesh(const v1::JobSpec& spec) {
  return !spec.has_return_mesh() || spec.return_mesh();
}
inline bool returns_saliency(const v1::JobSpec& spec) {
  return !spec.has_return_saliency() || spec.return_saliency();
}

// What a job needs besides the mesh, in the pipeline's own terms.
struct JobOptions {
  // renderer, shared_renderer, device, keep_going and debug_dir are the
  // worker's to set; keep_saliency_points follows return_saliency_points.
  PipelineOptions pipeline;
  int priority = 0;                                               // [-10, 10], higher first
  int result_quantization_bits = kDefaultResultQuantizationBits;  // [1, 30]
  v1::DevicePreference device = v1::DEVICE_ANY;
  MeshFormat input_format = MeshFormat::kDraco;  // kDraco or kGltf (spec.input_format)
  // spec.levels (a chain); empty: one level, pipeline.target_vertices.
  std::vector<LevelTarget> levels;
};

// Checks every field and fills *out. INVALID_ARGUMENT names the field (as in
// the proto, e.g. "options.median_size") and its allowed range.
Status job_options_from_spec(const v1::JobSpec& spec, JobOptions* out);

// Only the pipeline options part (spec.options), onto *out (whose other
// fields are kept).
Status pipeline_options_from_proto(const v1::PipelineOptions& proto, PipelineOptions* out);

// The reverse: every field written explicitly. INVALID_ARGUMENT when a value
// cannot be expressed (see the top of this file) or is out of range.
StatusOr<v1::PipelineOptions> pipeline_options_to_proto(const PipelineOptions& options);

// A spec for `options.target_vertices` with these options (the client's
// helper; priority, label and return_* flags are the caller's to set);
// with more than one level, or a visual one, a chain (target_vertices 0).
StatusOr<v1::JobSpec> make_job_spec(const PipelineOptions& options, const std::vector<LevelTarget>& levels = {});

}  // namespace vpr::service
