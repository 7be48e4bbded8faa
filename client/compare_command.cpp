// `vpremesh compare INPUT --target-vertices N [--out DIR] [--json]`: our
// pipeline and each peer (worker/peers) on the same input to the same vertex
// count, measured alike, as in the paper's Table I: time, counts, visual
// similarity (SSIM of renderings and of line drawings), Hausdorff distance,
// triangle quality and topology. With --out: table.md, table.csv and
// contact_sheet.png (rows: views; columns: saliency field on the input, the
// input, ours, then each peer).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "commands.h"
#include "contact_sheet.h"
#include "eval/hausdorff.h"
#include "eval/mesh_quality.h"
#include "eval/visual_similarity.h"
#include "exit_codes.h"
#include "io/mesh_io.h"
#include "peers/peers.h"
#include "pipeline/pipeline.h"

namespace vpr::cli {
namespace {

constexpr const char* kOurs = "vpremesh (ours)";
// Contact sheet views, by make_views' order: +z, +y, +x+y+z of the aligned
// model (the flattest side, a side and a diagonal).
constexpr int kSheetViews[] = {4, 2, 6};

struct CompareArgs {
  std::string input, out_dir, renderer = "auto";
  uint32_t target = 0;
  bool json = false;
  int views = 14, resolution = 512, tile = 256;
  int awlop_iterations = -1;  // -1: the pipeline's default
  size_t samples = 200'000;
  bool no_peers = false;
};

struct Row {
  std::string method;
  std::string error;  // empty when the method ran
  double ms = 0;
  Mesh mesh;
  std::string note;
  VisualSimilarity visual;
  HausdorffResult hausdorff;
  MeshQuality quality;
};

using Clock = std::chrono::steady_clock;

int fail(const std::string& what, const Status& s) {
  std::fprintf(stderr, "vpremesh: error: %s%s\n", what.empty() ? "" : (what + ": ").c_str(), s.to_string().c_str());
  return exit_code_for(s);
}

std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

const char* kHeader[] = {"method",
                         "time ms",
                         "vertices",
                         "faces",
                         "SSIM mean",
                         "SSIM worst",
                         "line SSIM mean",
                         "line SSIM worst",
                         "Hausdorff max %",
                         "Hausdorff mean %",
                         "angles < 30° %",
                         "min angle °",
                         "non-manifold edges",
                         "note"};

std::vector<std::string> cells(const Row& r) {
  if (!r.error.empty()) {
    std::vector<std::string> c(std::size(kHeader), "");
    c.front() = r.method;
    c.back() = "failed: " + r.error;
    return c;
  }
  return {r.method,
          fixed(r.ms, 0),
          std::to_string(r.quality.vertices),
          std::to_string(r.quality.faces),
          fixed(r.visual.ssim_mean, 4),
          fixed(r.visual.ssim_worst, 4),
          fixed(r.visual.line_mean, 4),
          fixed(r.visual.line_worst, 4),
          fixed(100 * r.hausdorff.max, 3),
          fixed(100 * r.hausdorff.mean, 4),
          fixed(100 * r.quality.share_angles_below_30, 2),
          fixed(r.quality.min_angle_deg, 2),
          std::to_string(r.quality.non_manifold_edges),
          r.note};
}

std::string markdown(const std::vector<Row>& rows) {
  std::ostringstream s;
  s << "|";
  for (const char* h : kHeader) s << ' ' << h << " |";
  s << "\n|";
  for (size_t i = 0; i < std::size(kHeader); ++i) s << (i == 0 || i + 1 == std::size(kHeader) ? "---|" : "---:|");
  s << "\n";
  for (const Row& r : rows) {
    s << "|";
    for (const std::string& c : cells(r)) s << ' ' << c << " |";
    s << "\n";
  }
  return s.str();
}

std::string csv_field(const std::string& v) {
  if (v.find_first_of(",\"\n") == std::string::npos) return v;
  std::string q = "\"";
  for (char c : v) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string csv(const std::vector<Row>& rows) {
  std::ostringstream s;
  for (size_t i = 0; i < std::size(kHeader); ++i) s << (i ? "," : "") << csv_field(kHeader[i]);
  s << "\n";
  for (const Row& r : rows) {
    const auto c = cells(r);
    for (size_t i = 0; i < c.size(); ++i) s << (i ? "," : "") << csv_field(c[i]);
    s << "\n";
  }
  return s.str();
}

nlohmann::json row_json(const Row& r) {
  if (!r.error.empty()) return {{"method", r.method}, {"ok", false}, {"error", r.error}};
  nlohmann::json per_view = nlohmann::json::array();
  for (const auto& v : r.visual.per_view)
    per_view.push_back({{"view", v.view}, {"ssim", v.ssim}, {"line_ssim", v.line_ssim}});
  return {{"method", r.method},
          {"ok", true},
          {"time_ms", r.ms},
          {"vertices", r.quality.vertices},
          {"faces", r.quality.faces},
          {"ssim_mean", r.visual.ssim_mean},
          {"ssim_worst", r.visual.ssim_worst},
          {"ssim_worst_view", r.visual.ssim_worst_view},
          {"line_ssim_mean", r.visual.line_mean},
          {"line_ssim_worst", r.visual.line_worst},
          {"line_ssim_worst_view", r.visual.line_worst_view},
          {"per_view", per_view},
          {"hausdorff_max", r.hausdorff.max},
          {"hausdorff_mean", r.hausdorff.mean},
          {"hausdorff_rms", r.hausdorff.rms},
          {"share_angles_below_30", r.quality.share_angles_below_30},
          {"min_angle_deg", r.quality.min_angle_deg},
          {"non_manifold_edges", r.quality.non_manifold_edges},
          {"non_manifold_vertices", r.quality.non_manifold_vertices},
          {"boundary_loops", r.quality.boundary_loops},
          {"components", r.quality.components},
          {"note", r.note}};
}

Status write_text(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
  f.close();
  if (!f) return internal_error("cannot write " + path);
  return Status::Ok();
}

// Contact sheet: one row per view of kSheetViews, columns heat map, input,
// then every method that ran.
Status write_sheet(const std::string& path, const Mesh& input, const std::vector<float>& importance,
                   const std::vector<Row>& rows, Renderer* renderer, int tile) {
  auto all = comparison_views(input, 14, tile);
  if (!all.ok()) return all.status();
  std::vector<View> views;
  for (int v : kSheetViews) views.push_back((*all)[size_t(v)]);
  std::vector<std::vector<RgbImage>> tiles(views.size());
  std::vector<Snapshot> snaps;
  if (Status s = renderer->render(input, views, &snaps); !s.ok()) return s;
  for (size_t v = 0; v < views.size(); ++v) {
    auto heat = heat_map(snaps[v], views[v], input, importance);
    if (!heat.ok()) return heat.status();
    tiles[v].push_back(std::move(*heat));
    tiles[v].push_back(gray_to_rgb(snaps[v].gray));
  }
  for (const Row& r : rows) {
    if (!r.error.empty()) continue;
    if (Status s = renderer->render(r.mesh, views, &snaps); !s.ok()) return s;
    for (size_t v = 0; v < views.size(); ++v) tiles[v].push_back(gray_to_rgb(snaps[v].gray));
  }
  return write_contact_sheet(path, tiles);
}

int run_compare(const CompareArgs& a) {
  auto input = read_mesh(a.input);
  if (!input.ok()) return fail(a.input, input.status());
  auto kind = parse_renderer_kind(a.renderer);
  if (!kind.ok()) return fail("", kind.status());
  if (a.tile < 16 || a.tile > 2048) return fail("", invalid_argument("--tile must be in [16, 2048]"));

  PipelineOptions options;
  options.target_vertices = a.target;
  options.renderer = *kind;
  if (a.awlop_iterations >= 0) options.awlop.iterations = a.awlop_iterations;
  if (Status s = validate_options(options); !s.ok()) return fail("", s);

  std::vector<Row> rows;
  auto start = Clock::now();
  auto ours = run_pipeline(*input, options);
  if (!ours.ok()) return fail("our pipeline", ours.status());
  Row own;
  own.method = kOurs;
  own.ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  own.mesh = std::move(ours->mesh);
  own.note = "AWLOP " + std::to_string(options.awlop.iterations) + " iterations";
  rows.push_back(std::move(own));

  if (!a.no_peers) {
    for (const auto& peer : peers::all_peers()) {
      Row r;
      r.method = peer.name;
      auto result = peer.run(*input, a.target);
      if (!result.ok()) {
        r.error = result.status().message();
        std::fprintf(stderr, "vpremesh: %s failed: %s\n", peer.name.c_str(), r.error.c_str());
      } else {
        r.ms = result->ms;
        r.mesh = std::move(result->mesh);
        r.note = result->note;
      }
      rows.push_back(std::move(r));
    }
  }

  auto renderer = create_renderer(*kind);
  if (!renderer.ok()) return fail("", renderer.status());
  VisualSimilarityOptions vo;
  vo.views = a.views;
  vo.resolution = a.resolution;
  auto reference = VisualReference::create(*input, renderer->get(), vo);
  if (!reference.ok()) return fail("rendering the input", reference.status());
  HausdorffOptions ho;
  ho.samples_per_mesh = a.samples;
  for (Row& r : rows) {
    if (!r.error.empty()) continue;
    auto visual = reference->compare(r.mesh);
    if (!visual.ok()) return fail(r.method, visual.status());
    auto h = hausdorff_distance(*input, r.mesh, ho);
    if (!h.ok()) return fail(r.method, h.status());
    r.visual = *visual;
    r.hausdorff = *h;
    r.quality = mesh_quality(r.mesh);
  }

  const std::string table = markdown(rows);
  if (!a.out_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(a.out_dir, ec);
    if (ec) return fail("", internal_error("cannot create " + a.out_dir + ": " + ec.message()));
    const std::string dir = a.out_dir + "/";
    for (const Status& s :
         {write_text(dir + "table.md", table), write_text(dir + "table.csv", csv(rows)),
          write_sheet(dir + "contact_sheet.png", *input, ours->input_importance, rows, renderer->get(), a.tile)})
      if (!s.ok()) return fail("", s);
  }
  if (a.json) {
    nlohmann::json j = {{"input", a.input},
                        {"input_vertices", input->vertex_count()},
                        {"input_faces", input->face_count()},
                        {"target_vertices", a.target},
                        {"renderer", (*renderer)->description()},
                        {"views", a.views},
                        {"resolution", a.resolution},
                        {"hausdorff_unit", "input bounding-box diagonal"},
                        {"methods", nlohmann::json::array()}};
    for (const Row& r : rows) j["methods"].push_back(row_json(r));
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("%s: %zu vertices -> %u; SSIM over %d views at %d px (%s); Hausdorff in %% of the bbox diagonal\n\n%s",
                a.input.c_str(), input->vertex_count(), a.target, a.views, a.resolution,
                (*renderer)->description().c_str(), table.c_str());
  }
  return kExitOk;
}

}  // namespace

Command add_compare_command(CLI::App& app) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* cmd = app.add_subcommand("compare", "Compare our remeshing with peer methods at one vertex count");
  cmd->add_option("input", args->input, "Input mesh (.drc .glb .gltf .obj .ply .off .stl)")->required();
  cmd->add_option("-n,--target-vertices", args->target, "Vertex count for every method")->required();
  cmd->add_option("--out", args->out_dir, "Write table.md, table.csv and contact_sheet.png here");
  cmd->add_flag("--json", args->json, "Print JSON instead of the table");
  cmd->add_option("--views", args->views, "SSIM views: 6 or 14")->capture_default_str();
  cmd->add_option("--resolution", args->resolution, "SSIM image size in pixels")->capture_default_str();
  cmd->add_option("--tile", args->tile, "Contact sheet tile size in pixels")->capture_default_str();
  cmd->add_option("--samples", args->samples, "Hausdorff samples per mesh")->capture_default_str();
  cmd->add_option("--renderer", args->renderer, "auto, egl or osmesa")->capture_default_str();
  cmd->add_option("--awlop-iterations", args->awlop_iterations, "Our AWLOP iterations (default: the pipeline's)");
  cmd->add_flag("--no-peers", args->no_peers, "Measure our pipeline only");
  return [args]() { return run_compare(*args); };
}

}  // namespace vpr::cli
