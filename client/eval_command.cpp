// `vpremesh eval REFERENCE CANDIDATE`: geometric distance, visual similarity
// (SSIM of renderings and line drawings from the same 14 cameras), triangle
// quality and topology of a remeshed model against its reference. With
// --views-dir, the gray renderings the SSIM compares are written as PNGs, so
// that other image metrics (scripts/quality.sh runs NVIDIA's FLIP on them)
// judge exactly the same pictures.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "commands.h"
#include "eval/hausdorff.h"
#include "eval/mesh_quality.h"
#include "eval/visual_similarity.h"
#include "exit_codes.h"
#include "io/mesh_io.h"
#include "io/png_io.h"

namespace vpr::cli {
namespace {

struct EvalArgs {
  std::string reference, candidate;
  bool json = false;
  HausdorffOptions hausdorff;
  bool visual = true;
  VisualSimilarityOptions visual_options;
  std::string renderer = "auto";
  std::string views_dir;  // "": write no renderings
};

// DIR/reference-NN.png and DIR/candidate-NN.png for view NN (make_views'
// order), the gray renderings of both meshes.
Status write_view_pngs(const std::string& dir, const std::vector<Snapshot>& reference,
                       const std::vector<Snapshot>& candidate) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return internal_error("cannot create " + dir + ": " + ec.message());
  for (size_t v = 0; v < reference.size(); ++v) {
    char name[32];
    std::snprintf(name, sizeof name, "%02zu.png", v);
    if (Status s = write_png(dir + "/reference-" + name, reference[v].gray); !s.ok()) return s;
    if (Status s = write_png(dir + "/candidate-" + name, candidate[v].gray); !s.ok()) return s;
  }
  return Status::Ok();
}

nlohmann::json visual_json(const VisualSimilarity& v) {
  nlohmann::json per_view = nlohmann::json::array();
  for (const auto& p : v.per_view) per_view.push_back({{"view", p.view}, {"ssim", p.ssim}, {"line_ssim", p.line_ssim}});
  return {
      {"ssim_mean", v.ssim_mean},      {"ssim_worst", v.ssim_worst},      {"ssim_worst_view", v.ssim_worst_view},
      {"line_ssim_mean", v.line_mean}, {"line_ssim_worst", v.line_worst}, {"line_ssim_worst_view", v.line_worst_view},
      {"per_view", per_view}};
}

nlohmann::json quality_json(const MeshQuality& q) {
  return {{"vertices", q.vertices},
          {"faces", q.faces},
          {"min_angle_deg", q.min_angle_deg},
          {"share_angles_below_30", q.share_angles_below_30},
          {"degenerate_faces", q.degenerate_faces},
          {"non_manifold_edges", q.non_manifold_edges},
          {"non_manifold_vertices", q.non_manifold_vertices},
          {"boundary_edges", q.boundary_edges},
          {"boundary_loops", q.boundary_loops},
          {"components", q.components},
          {"sheets", q.sheets},
          {"closed", q.closed},
          {"euler_characteristic", q.euler_characteristic},
          {"welded", {{"boundary_loops", q.welded_boundary_loops},
                      {"components", q.welded_components},
                      {"sheets", q.welded_sheets},
                      {"closed", q.welded_closed}}}};
}

void print_quality(const char* label, const MeshQuality& q) {
  std::printf("%-10s %9zu %9zu %9.2f %9.2f%% %8zu %8zu %8zu %8zu\n", label, q.vertices, q.faces, q.min_angle_deg,
              100.0 * q.share_angles_below_30, q.non_manifold_edges, q.non_manifold_vertices, q.boundary_loops,
              q.components);
}

int run_eval(const EvalArgs& a) {
  if (!a.visual && !a.views_dir.empty()) {
    std::fprintf(stderr, "vpremesh: error: --views-dir needs the renderings that --no-visual skips\n");
    return kExitUsage;
  }
  auto ref = read_mesh(a.reference);
  if (!ref.ok()) {
    std::fprintf(stderr, "vpremesh: error: %s: %s\n", a.reference.c_str(), ref.status().to_string().c_str());
    return exit_code_for(ref.status());
  }
  auto cand = read_mesh(a.candidate);
  if (!cand.ok()) {
    std::fprintf(stderr, "vpremesh: error: %s: %s\n", a.candidate.c_str(), cand.status().to_string().c_str());
    return exit_code_for(cand.status());
  }
  auto h = hausdorff_distance(*ref, *cand, a.hausdorff);
  if (!h.ok()) {
    std::fprintf(stderr, "vpremesh: error: %s\n", h.status().to_string().c_str());
    return exit_code_for(h.status());
  }
  std::optional<VisualSimilarity> visual;
  if (a.visual) {
    auto kind = parse_renderer_kind(a.renderer);
    if (!kind.ok()) {
      std::fprintf(stderr, "vpremesh: error: %s\n", kind.status().to_string().c_str());
      return exit_code_for(kind.status());
    }
    auto renderer = create_renderer(*kind);
    if (!renderer.ok()) {
      std::fprintf(stderr, "vpremesh: error: %s\n", renderer.status().to_string().c_str());
      return exit_code_for(renderer.status());
    }
    auto reference = VisualReference::create(*ref, renderer->get(), a.visual_options);
    StatusOr<VisualSimilarity> v = reference.ok() ? reference->compare(*cand) : StatusOr<VisualSimilarity>(reference.status());
    if (!v.ok()) {
      std::fprintf(stderr, "vpremesh: error: visual similarity: %s\n", v.status().to_string().c_str());
      return exit_code_for(v.status());
    }
    visual = *v;
    if (!a.views_dir.empty()) {
      std::vector<Snapshot> snaps;
      Status s = (*renderer)->render(*cand, reference->views(), &snaps);
      if (s.ok()) s = write_view_pngs(a.views_dir, reference->snapshots(), snaps);
      if (!s.ok()) {
        std::fprintf(stderr, "vpremesh: error: --views-dir: %s\n", s.to_string().c_str());
        return exit_code_for(s);
      }
    }
  }
  const MeshQuality qr = mesh_quality(*ref), qc = mesh_quality(*cand);
  if (a.json) {
    nlohmann::json j = {{"hausdorff",
                         {{"max", h->max},
                          {"mean", h->mean},
                          {"rms", h->rms},
                          {"reference_to_candidate_max", h->forward_max},
                          {"candidate_to_reference_max", h->backward_max},
                          {"unit", "reference bounding-box diagonal"},
                          {"diagonal", h->diagonal}}},
                        {"reference", quality_json(qr)},
                        {"candidate", quality_json(qc)}};
    if (visual) j["visual"] = visual_json(*visual);
    std::printf("%s\n", j.dump(2).c_str());
    return kExitOk;
  }
  std::printf("Hausdorff (units of the reference bbox diagonal %.6g): max %.6f  mean %.6f  rms %.6f\n", h->diagonal,
              h->max, h->mean, h->rms);
  std::printf("  reference->candidate max %.6f, candidate->reference max %.6f\n", h->forward_max, h->backward_max);
  if (visual)
    std::printf("SSIM over %zu views: mean %.4f  worst %.4f (%s); line drawings: mean %.4f  worst %.4f (%s)\n",
                visual->per_view.size(), visual->ssim_mean, visual->ssim_worst, visual->ssim_worst_view.c_str(),
                visual->line_mean, visual->line_worst, visual->line_worst_view.c_str());
  std::printf("\n");
  std::printf("%-10s %9s %9s %9s %10s %8s %8s %8s %8s\n", "mesh", "vertices", "faces", "min-angle", "<30deg",
              "nm-edges", "nm-verts", "holes", "parts");
  print_quality("reference", qr);
  print_quality("candidate", qc);
  return kExitOk;
}

}  // namespace

Command add_eval_command(CLI::App& app) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand("eval", "Compare a remeshed model with its reference");
  cmd->add_option("reference", args->reference, "Reference mesh")->required();
  cmd->add_option("candidate", args->candidate, "Candidate mesh")->required();
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->add_option("--samples", args->hausdorff.samples_per_mesh, "Area-uniform samples per mesh")
      ->capture_default_str();
  cmd->add_flag("!--no-visual", args->visual, "Skip the rendered visual similarity (SSIM)");
  cmd->add_option("--views", args->visual_options.views, "SSIM views: 6 or 14")->capture_default_str();
  cmd->add_option("--resolution", args->visual_options.resolution, "SSIM image size in pixels")->capture_default_str();
  cmd->add_option("--renderer", args->renderer, "auto, egl or osmesa")->capture_default_str();
  cmd->add_option("--views-dir", args->views_dir,
                  "Write the gray renderings SSIM compares here: reference-NN.png and candidate-NN.png per view");
  return [args]() { return run_eval(*args); };
}

}  // namespace vpr::cli
