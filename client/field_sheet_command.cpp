// `vpremesh field-sheet`: a mesh rendered from a few views, coloured by one or
// more per-vertex fields side by side (rows: views; columns: fields), as one
// PNG. docs/perception.md uses it to put the attention field beside the
// measured fixation of ../shared/gaze/ (scripts/gaze-score.py fixation-field
// writes the fixation as such a field).
//
// The views are in the model's own frame, not its principal axes: a person
// looks at an upright object from the front and a little above (the frame the
// attention field's front-top bias assumes, +y up and +z front), so the
// pictures show the model as its viewers saw it.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "contact_sheet.h"
#include "exit_codes.h"
#include "io/mesh_io.h"
#include "render/snapshot.h"
#include "render/views.h"

namespace vpr::cli {
namespace {

struct FieldSheetArgs {
  std::string mesh, output, renderer = "auto";
  std::vector<std::string> fields;
  std::vector<std::string> views = {"-y", "+x-y+z"};
  int tile = 256;
};

int fail(const Status& s) {
  std::fprintf(stderr, "vpremesh: error: field-sheet: %s\n", s.to_string().c_str());
  return exit_code_for(s);
}

// Model frame (+y up, +z front) to the views' aligned frame, whose image up is
// its +z: aligned (x, y, z) = model (x, -z, y), a rotation (det +1). So view
// "-y" looks at the model's front with its top up, and "+x-y+z" from the
// front, right and above.
constexpr std::array<double, 9> kUprightFront = {1, 0, 0, 0, 0, -1, 0, 1, 0};

int run_field_sheet(const FieldSheetArgs& a) {
  auto mesh = read_mesh(a.mesh);
  if (!mesh.ok()) return fail(mesh.status());
  std::vector<std::vector<float>> fields;
  for (const std::string& path : a.fields) {
    auto f = read_saliency(path);
    if (!f.ok()) return fail(f.status());
    if (f->size() != mesh->vertex_count())
      return fail(invalid_argument(path + " has " + std::to_string(f->size()) + " field values, " + a.mesh + " has " +
                                   std::to_string(mesh->vertex_count()) + " vertices"));
    fields.push_back(std::move(*f));
  }
  ViewOptions vo;
  vo.count = 14;
  vo.resolution = a.tile;
  vo.pca_align = false;
  vo.user_rotation = kUprightFront;
  auto all = make_views(*mesh, vo);
  if (!all.ok()) return fail(all.status());
  std::vector<View> views;
  for (const std::string& name : a.views) {
    bool found = false;
    for (const View& v : *all)
      if (v.name == name) views.push_back(v), found = true;
    if (!found) return fail(invalid_argument("no view named " + name + " (+x, -x, ..., +x+y+z, ...)"));
  }
  auto kind = parse_renderer_kind(a.renderer);
  if (!kind.ok()) return fail(kind.status());
  auto renderer = create_renderer(*kind);
  if (!renderer.ok()) return fail(renderer.status());
  std::vector<Snapshot> snaps;
  if (Status s = (*renderer)->render(*mesh, views, &snaps); !s.ok()) return fail(s);
  std::vector<std::vector<RgbImage>> tiles(views.size());
  for (size_t v = 0; v < views.size(); ++v)
    for (const std::vector<float>& f : fields) {
      auto heat = heat_map(snaps[v], views[v], *mesh, f);
      if (!heat.ok()) return fail(heat.status());
      tiles[v].push_back(std::move(*heat));
    }
  if (Status s = write_contact_sheet(a.output, tiles); !s.ok()) return fail(s);
  return kExitOk;
}

}  // namespace

Command add_field_sheet_command(CLI::App& app) {
  auto args = std::make_shared<FieldSheetArgs>();
  CLI::App* cmd = app.add_subcommand(
      "field-sheet", "Render a mesh coloured by per-vertex fields side by side (rows: views; columns: fields), one PNG");
  cmd->add_option("mesh", args->mesh, "The mesh the fields belong to (.drc .obj .ply .off .stl)")->required();
  cmd->add_option("-f,--field", args->fields,
                  "A field: a PLY or Draco file with a 'saliency' value per vertex of the mesh, in the same order "
                  "(vpremesh local --field-out writes one); repeat for more columns")
      ->required();
  cmd->add_option("-o,--output", args->output, "The PNG to write")->required();
  cmd->add_option("--view", args->views,
                  "Views in the model's frame (+y up, +z front) as the 14-view names of an aligned frame whose +z is "
                  "the model's up and -y its front: -y is the front, +x-y+z front-right-above")
      ->capture_default_str();
  cmd->add_option("--tile", args->tile, "Tile size in pixels")->capture_default_str();
  cmd->add_option("--renderer", args->renderer, "auto, egl or osmesa")->capture_default_str();
  return [args]() { return run_field_sheet(*args); };
}

}  // namespace vpr::cli
