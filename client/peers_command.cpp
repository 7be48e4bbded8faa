// `vpremesh peers INPUT --target-vertices N --out DIR [--only NAME]`: the
// peer methods of `vpremesh compare` (worker/peers), each to the same vertex
// count, their meshes written to DIR/<slug>.ply, so that a benchmark script
// can judge them with `vpremesh eval` exactly as it judges our output
// (scripts/quality.sh). Prints one JSON object per method: slug, name, file,
// ok, error, time_ms, vertices, faces, note.
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.h"
#include "exit_codes.h"
#include "io/mesh_io.h"
#include "peers/peers.h"

namespace vpr::cli {
namespace {

struct PeersArgs {
  std::string input, out_dir, only;
  uint32_t target = 0;
};

// "OpenMesh QEM" -> "openmesh-qem": the file name and the --only key.
std::string slug(const std::string& name) {
  std::string s;
  for (char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c)))
      s += char(std::tolower(static_cast<unsigned char>(c)));
    else if (!s.empty() && s.back() != '-')
      s += '-';
  }
  return s;
}

int fail(const Status& s) {
  std::fprintf(stderr, "vpremesh: error: %s\n", s.to_string().c_str());
  return exit_code_for(s);
}

int run_peers(const PeersArgs& a) {
  bool known = a.only.empty();
  for (const auto& peer : peers::all_peers()) known = known || slug(peer.name) == a.only;
  if (!known) {
    std::string names;
    for (const auto& peer : peers::all_peers()) names += " " + slug(peer.name);
    std::fprintf(stderr, "vpremesh: error: --only %s: no such peer (one of:%s)\n", a.only.c_str(), names.c_str());
    return kExitUsage;
  }
  auto input = read_mesh(a.input);
  if (!input.ok()) return fail(Status(input.status().code(), a.input + ": " + input.status().message()));
  std::error_code ec;
  std::filesystem::create_directories(a.out_dir, ec);
  if (ec) return fail(internal_error("cannot create " + a.out_dir + ": " + ec.message()));

  nlohmann::json methods = nlohmann::json::array();
  for (const auto& peer : peers::all_peers()) {
    const std::string key = slug(peer.name);
    if (!a.only.empty() && key != a.only) continue;
    nlohmann::json m = {{"slug", key}, {"method", peer.name}};
    auto result = peer.run(*input, a.target);
    Status written = result.ok() ? write_mesh(a.out_dir + "/" + key + ".ply", result->mesh, nullptr) : result.status();
    if (!written.ok()) {
      m["ok"] = false;
      m["error"] = written.message();
      std::fprintf(stderr, "vpremesh: %s failed: %s\n", peer.name.c_str(), written.message().c_str());
    } else {
      m["ok"] = true;
      m["file"] = a.out_dir + "/" + key + ".ply";
      m["time_ms"] = result->ms;
      m["vertices"] = result->mesh.vertex_count();
      m["faces"] = result->mesh.face_count();
      m["note"] = result->note;
    }
    methods.push_back(std::move(m));
  }
  const nlohmann::json j = {{"input", a.input}, {"target_vertices", a.target}, {"methods", methods}};
  std::printf("%s\n", j.dump(2).c_str());
  return kExitOk;
}

}  // namespace

Command add_peers_command(CLI::App& app) {
  auto args = std::make_shared<PeersArgs>();
  CLI::App* cmd = app.add_subcommand("peers", "Run the peer methods of `compare` and write their meshes");
  cmd->add_option("input", args->input, "Input mesh (.drc .glb .gltf .obj .ply .off .stl)")->required();
  cmd->add_option("-n,--target-vertices", args->target, "Vertex count for every method")
      ->required()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--out", args->out_dir, "Write <slug>.ply of each method here")->required();
  cmd->add_option("--only", args->only, "Run one peer: openmesh-qem, meshoptimizer or cgal-isotropic");
  return [args]() { return run_peers(*args); };
}

}  // namespace vpr::cli
