// `vpremesh local INPUT -o OUTPUT --target-vertices N ...`: the whole pipeline
// in this process, without the service.
#include <tbb/global_control.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "exit_codes.h"
#include "io/mesh_io.h"
#include "stage_table.h"

namespace vpr::cli {
namespace {

struct LocalArgs {
  std::string input, output, field_out, renderer = "auto", awlop_support = "target";
  bool json = false;
  int threads = 0;
  bool no_pca = false;
  std::vector<double> rotation;
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
  if (a.awlop_support == "paper") o.awlop.support = AwlopSupport::kPaper;
  o.views.pca_align = !a.no_pca;
  if (!a.rotation.empty()) {
    if (a.rotation.size() != 9) return fail(invalid_argument("--rotation needs 9 numbers (row-major 3x3)"));
    std::array<double, 9> r{};
    for (int i = 0; i < 9; ++i) r[i] = a.rotation[i];
    o.views.user_rotation = r;
  }
  if (Status s = validate_options(o); !s.ok()) return fail(s);
  // Check the output format before hours of work are spent.
  if (auto f = format_from_path(a.output); !f.ok()) return fail(f.status());

  RunSummary summary;
  summary.target_vertices = o.target_vertices;
  auto start = std::chrono::steady_clock::now();
  auto mesh = read_mesh(a.input);
  if (!mesh.ok()) return fail(Status(mesh.status().code(), a.input + ": " + mesh.status().message()));
  summary.read_ms = ms_since(start);
  summary.input_vertices = mesh->vertex_count();
  summary.input_faces = mesh->face_count();

  auto result = run_pipeline(*mesh, o);
  if (!result.ok()) return fail(result.status());

  start = std::chrono::steady_clock::now();
  if (Status s = write_mesh(a.output, result->mesh, result->saliency.data()); !s.ok()) return fail(s);
  summary.write_ms = ms_since(start);
  summary.output_vertices = result->mesh.vertex_count();
  summary.output_faces = result->mesh.face_count();
  if (!a.field_out.empty()) {
    if (Status s = write_mesh(a.field_out, *mesh, result->input_importance.data()); !s.ok()) return fail(s);
  }

  if (a.json)
    std::printf("%s\n", report_json(*result, summary).dump(2).c_str());
  else
    std::printf("%s", format_stage_table(*result, summary).c_str());
  return kExitOk;
}

}  // namespace

Command add_local_command(CLI::App& app) {
  auto args = std::make_shared<LocalArgs>();
  PipelineOptions& o = args->options;
  CLI::App* cmd = app.add_subcommand("local", "Remesh a file in this process (no server)");
  cmd->add_option("input", args->input, "Input mesh (.drc .obj .ply .off .stl)")->required();
  cmd->add_option("-o,--output", args->output, "Output mesh (.drc .ply .obj)")->required();
  cmd->add_option("-n,--target-vertices", o.target_vertices, "Output vertex count (within 2%)")->required();
  cmd->add_option("--views", o.views.count, "Number of views: 6 (axes) or 14 (axes + diagonals)")
      ->check(CLI::IsMember({6, 14}))
      ->capture_default_str();
  cmd->add_option("--resolution", o.views.resolution, "Snapshot resolution in pixels")->capture_default_str();
  cmd->add_option("--seed", o.sampling.seed, "Random seed of the sampler")->capture_default_str();
  cmd->add_option("--renderer", args->renderer, "auto, egl or osmesa")->capture_default_str();
  cmd->add_option("--field-out", args->field_out, "Write the input mesh colored by its saliency field (.ply)");
  cmd->add_option("--debug-dir", o.debug_dir, "Write per-view snapshots, feature images and points here");
  cmd->add_flag("--json", args->json, "Print a JSON report instead of the table");
  cmd->add_option("--threads", args->threads, "Worker threads (0 = all cores)")->capture_default_str();
  cmd->add_flag("--no-pca", args->no_pca, "Use the model's own axes instead of its principal axes");
  cmd->add_option("--rotation", args->rotation, "User rotation, 9 numbers (row-major 3x3)")->expected(9);
  // The paper's constants (Sections III-V), each with its default.
  cmd->add_option("--median-size", o.image.median_size, "Median pre-filter window")->capture_default_str();
  cmd->add_option("--gaussian-size", o.image.gaussian_size, "Eq. (1) Gaussian window n")->capture_default_str();
  cmd->add_option("--gaussian-sigma", o.image.gaussian_sigma, "Eq. (1) Gaussian sigma")->capture_default_str();
  cmd->add_option("--threshold-c", o.image.threshold_c, "Eq. (3) threshold C")->capture_default_str();
  cmd->add_option("--skeleton-lambda", o.image.skeleton_lambda, "Eq. (5) lambda")->capture_default_str();
  cmd->add_option("--thin-feature-px", o.image.thin_feature_px, "Thin feature size at 512 px")->capture_default_str();
  cmd->add_option("--knn", o.field.k, "Algorithm 1: k of the k-NN graph")->capture_default_str();
  cmd->add_option("--beta", o.field.beta, "Algorithm 1: I = beta^depth")->capture_default_str();
  cmd->add_option("--min-importance", o.field.min_importance, "Floor of the importance")->capture_default_str();
  cmd->add_option("--depth-scale", o.field.depth_scale, "Field depth per output spacing (0 = automatic)")
      ->capture_default_str();
  cmd->add_option("--mu", o.awlop.mu, "Eq. (17) repulsion strength")->capture_default_str();
  cmd->add_option("--awlop-samples", o.awlop.attraction_samples_per_target,
                  "Surface samples AWLOP attracts to, per target vertex")
      ->capture_default_str();
  cmd->add_option("--awlop-k", o.awlop.k, "AWLOP neighbours")->capture_default_str();
  cmd->add_option("--awlop-iterations", o.awlop.iterations, "AWLOP iterations")->capture_default_str();
  cmd->add_option("--awlop-support", args->awlop_support, "h from 'target' spacing or 'paper' (input edges)")
      ->check(CLI::IsMember({"target", "paper"}))
      ->capture_default_str();
  return [args]() { return run_local(*args); };
}

}  // namespace vpr::cli
