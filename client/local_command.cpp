// `vpremesh local INPUT -o OUTPUT --target-vertices N ...`: the whole pipeline
// in this process, without the service.
#include <tbb/global_control.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.h"
#include "exit_codes.h"
#include "io/mesh_io.h"
#include "pipeline_flags.h"
#include "stage_table.h"

namespace vpr::cli {
namespace {

struct LocalArgs {
  std::string input, output, field_out, attention_map, renderer = "auto";
  bool json = false;
  bool no_draco = false;  // .glb/.gltf output with plain accessors
  int threads = 0;
  PipelineFlagValues flags;
  PipelineOptions options;
};

double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

int fail(const Status& s) {
  std::fprintf(stderr, "vpremesh: error: %s\n", s.to_string().c_str());
  return exit_code_for(s);
}

int run_local(LocalArgs& a) {
  std::unique_ptr<tbb::global_control> threads;
  if (a.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, a.threads);

  PipelineOptions& o = a.options;
  auto renderer = parse_renderer_kind(a.renderer);
  if (!renderer.ok()) return fail(renderer.status());
  o.renderer = *renderer;
  if (Status s = apply_pipeline_flags(a.flags, &o); !s.ok()) return fail(s);
  if (!a.attention_map.empty()) {
    auto map = read_saliency(a.attention_map);
    if (!map.ok()) return fail(map.status());
    if (map->empty()) return fail(invalid_argument("attention map " + a.attention_map + " has no 'saliency' values"));
    o.attention_map = std::make_shared<const std::vector<float>>(std::move(*map));
  }
  auto levels = levels_from_flags(a.flags, o);
  if (!levels.ok()) return fail(levels.status());
  const bool chain = levels->size() > 1;  // one file per level
  if (o.target_vertices != 0) {
    if (Status s = validate_options(o); !s.ok()) return fail(s);
  }
  // Check the output format before hours of work are spent.
  if (auto f = format_from_path(a.output); !f.ok()) return fail(f.status());

  RunSummary summary;
  summary.target_vertices = o.target_vertices;
  auto start = std::chrono::steady_clock::now();
  auto mesh = read_mesh(a.input);
  if (!mesh.ok()) return fail(mesh.status());  // read_mesh names the file
  summary.read_ms = ms_since(start);
  summary.input_vertices = mesh->vertex_count();
  summary.input_faces = mesh->face_count();

  // Each level is written, and reported, as soon as it is done.
  nlohmann::json reports = nlohmann::json::array();
  auto write_level = [&](PipelineResult&& result) -> Status {
    const std::string path = chain ? level_path(a.output, size_t(result.level)) : a.output;
    auto written_at = std::chrono::steady_clock::now();
    DracoOptions written;
    written.gltf_draco = !a.no_draco;
    VPR_RETURN_IF_ERROR(write_mesh(path, result.mesh, result.saliency.data(), written));
    RunSummary s = summary;
    s.target_vertices = result.target;
    s.write_ms = ms_since(written_at);
    s.output_vertices = result.mesh.vertex_count();
    s.output_faces = result.mesh.face_count();
    if (!a.field_out.empty() && result.level == 0) {
      // The field shows as the saliency ramp, not behind the input's colors
      // (a copy: the next levels still take their colors from the input).
      Mesh field = *mesh;
      field.colors.clear();
      VPR_RETURN_IF_ERROR(write_mesh(a.field_out, field, result.input_importance.data()));
    }
    if (result.level > 0) s.read_ms = 0;  // read once, reported with level 0
    if (a.json) {
      nlohmann::json j = report_json(result, s);
      if (chain) {
        j["level"] = result.level;
        j["output_file"] = path;
      }
      if (result.search.min_ssim > 0)
        j["visual_target"] = {
            {"min_ssim", result.search.min_ssim}, {"ssim", result.search.ssim}, {"tries", result.search.tries}};
      reports.push_back(j);
    } else {
      if (chain) std::printf("level %d -> %s\n", result.level, path.c_str());
      std::printf("%s", format_stage_table(result, s).c_str());
      if (chain) std::printf("\n");
    }
    return Status::Ok();
  };
  if (Status s = run_pipeline_levels(*mesh, o, *levels, write_level); !s.ok()) return fail(s);
  if (a.json) std::printf("%s\n", (chain ? reports : reports[0]).dump(2).c_str());
  return kExitOk;
}

}  // namespace

Command add_local_command(CLI::App& app) {
  auto args = std::make_shared<LocalArgs>();
  PipelineOptions& o = args->options;
  CLI::App* cmd = app.add_subcommand("local", "Remesh a file in this process (no server)");
  cmd->add_option("input", args->input, "Input mesh (.drc .glb .gltf .obj .ply .off .stl)")->required();
  cmd->add_option("-o,--output", args->output,
                  "Output mesh (.drc .glb .gltf .ply .obj); with several levels OUT.lod0.EXT, OUT.lod1.EXT, ...")
      ->required();
  cmd->add_flag("--no-draco", args->no_draco, "Write .glb/.gltf output without KHR_draco_mesh_compression");
  add_pipeline_flags(cmd, o, args->flags);
  cmd->add_option("--renderer", args->renderer, "auto, egl or osmesa")->capture_default_str();
  cmd->add_option("--field-out", args->field_out, "Write the input mesh colored by its saliency field (.ply)");
  cmd->add_option("--attention-map", args->attention_map,
                  "Use this map instead of the attention field: a PLY or Draco file with a 'saliency' value per "
                  "vertex of the input, in its order (for example measured fixation: scripts/gaze-score.py "
                  "fixation-field)");
  cmd->add_option("--debug-dir", o.debug_dir, "Write per-view snapshots, feature images and points here");
  cmd->add_flag("--json", args->json, "Print a JSON report instead of the table");
  cmd->add_option("--threads", args->threads, "Worker threads (0 = all cores)")->capture_default_str();
  const std::map<std::string, CvtSweeps> sweeps = {
      {"auto", CvtSweeps::kAuto}, {"rounds", CvtSweeps::kColourRounds}, {"slabs", CvtSweeps::kSlabs}};
  cmd->add_option("--cvt-sweeps", args->options.cvt_sweeps,
                  "How the CVT sweeps: auto (in colour rounds on a GPU, else the CPU's sweeps alone), rounds (in "
                  "colour rounds on either: the GPU path's mesh without a GPU) or slabs (the CPU's sweeps alone: "
                  "the CPU path's mesh on a GPU too)")
      ->transform(CLI::CheckedTransformer(sweeps))
      ->default_str("auto");
  return [args]() { return run_local(*args); };
}

}  // namespace vpr::cli
