// The real `vpremesh` binary: a good run and every kind of bad input, each
// with its exit code and one clear line.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_runner.h"
#include "eval/mesh_quality.h"
#include "io/mesh_io.h"
#include "test_meshes.h"

namespace fs = std::filesystem;

namespace vpr {
namespace {

using vpr::testing::CliRun;
using vpr::testing::run_cli;

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vpremesh_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& content) const {
    std::ofstream(path(name), std::ios::binary) << content;
    return path(name);
  }
  fs::path dir_;
};

TEST_F(CliTest, LocalRemeshesAModelAndReportsStagesAsJson) {
  const std::string out = path("spot.drc");
  CliRun r = run_cli("local ../shared/models/spot.obj -o " + out + " --target-vertices 800 --json --field-out " +
                     path("field.ply") + " --debug-dir " + path("debug"));
  ASSERT_EQ(r.code, 0) << r.all();
  const nlohmann::json j = nlohmann::json::parse(r.all());
  EXPECT_EQ(j["input"]["vertices"], 2930);
  const int v = j["output"]["vertices"];
  EXPECT_NEAR(v, 800, 16);
  std::vector<std::string> names;
  for (const auto& s : j["stages"]) names.push_back(s["name"]);
  for (const char* stage : {"read", "views", "render", "image_saliency", "unproject", "debug_output", "saliency_field",
                            "density", "cvt", "meshing", "write"})
    EXPECT_NE(std::find(names.begin(), names.end(), stage), names.end()) << stage;

  auto mesh = read_mesh(out);
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  EXPECT_EQ(int(mesh->vertex_count()), v);
  auto saliency = read_saliency(out);
  ASSERT_TRUE(saliency.ok());
  EXPECT_EQ(saliency->size(), mesh->vertex_count());
  EXPECT_EQ(mesh_quality(*mesh).non_manifold_edges, 0u);

  // The Draco result is itself a valid input (the service's wire format).
  CliRun again = run_cli("local " + out + " -o " + path("again.obj") + " --target-vertices 400 --json");
  ASSERT_EQ(again.code, 0) << again.all();
  EXPECT_EQ(nlohmann::json::parse(again.all())["input"]["vertices"], v);
  auto obj = read_mesh(path("again.obj"));
  ASSERT_TRUE(obj.ok()) << obj.status().to_string();
  EXPECT_NEAR(double(obj->vertex_count()), 400.0, 8.0);

  auto field = read_saliency(path("field.ply"));
  ASSERT_TRUE(field.ok());
  EXPECT_EQ(field->size(), 2930u);
  EXPECT_TRUE(fs::exists(path("debug/view_px_snapshot.png")));
  EXPECT_TRUE(fs::exists(path("debug/view_mz_skeleton.png")));
  EXPECT_TRUE(fs::exists(path("debug/view_py_points.ply")));
}

// A colored input: the output has colors (a colors stage ran), and
// --field-out still draws the field's ramp, not the input's colors.
TEST_F(CliTest, LocalCarriesColorsAndTheFieldKeepsItsRamp) {
  Mesh sphere = testing::icosphere(3);
  for (size_t v = 0; v < sphere.vertex_count(); ++v)
    sphere.colors.insert(sphere.colors.end(), {uint8_t(sphere.positions[3 * v + 2] > 0 ? 255 : 0), 40, 80});
  ASSERT_TRUE(write_mesh(path("colored.ply"), sphere, nullptr).ok());
  CliRun r = run_cli("local " + path("colored.ply") + " -o " + path("out.obj") +
                     " --target-vertices 300 --resolution 128 --json --field-out " + path("field.ply"));
  ASSERT_EQ(r.code, 0) << r.all();
  const nlohmann::json j = nlohmann::json::parse(r.all());
  bool colors_stage = false;
  for (const auto& s : j["stages"]) colors_stage = colors_stage || s["name"] == "colors";
  EXPECT_TRUE(colors_stage) << r.all();
  auto out = read_mesh(path("out.obj"));
  ASSERT_TRUE(out.ok()) << out.status().to_string();
  ASSERT_EQ(out->colors.size(), 3 * out->vertex_count());
  for (size_t v = 0; v < out->vertex_count(); ++v) EXPECT_EQ(out->colors[3 * v + 1], 40) << "vertex " << v;
  std::ifstream field(path("field.ply"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(field)), std::istreambuf_iterator<char>());
  EXPECT_NE(bytes.find("comment vpremesh: vertex colors show saliency"), std::string::npos);
}

// glTF in -> remesh -> out -> reread, on three inputs generated here from
// spot (2,930 vertices): plain accessors; two nodes placing it twice with
// different transforms (one surface of 5,860 vertices); Draco-compressed.
TEST_F(CliTest, LocalGltfRoundTrips) {
  auto spot = read_mesh("../shared/models/spot.obj");
  ASSERT_TRUE(spot.ok()) << spot.status().to_string();
  DracoOptions plain;
  plain.gltf_draco = false;
  ASSERT_TRUE(write_mesh(path("plain.glb"), *spot, nullptr, plain).ok());
  ASSERT_TRUE(write_mesh(path("draco.glb"), *spot, nullptr).ok());
  // The writer's .gltf has one node carrying the frame; a second node puts a
  // copy 3 units along x, turned half a turn about y.
  ASSERT_TRUE(write_mesh(path("one.gltf"), *spot, nullptr, plain).ok());
  std::ifstream one(path("one.gltf"));
  nlohmann::json two = nlohmann::json::parse(one);
  nlohmann::json copy = {{"children", {0}}, {"translation", {3.0, 0.0, 0.0}}, {"rotation", {0.0, 1.0, 0.0, 0.0}}};
  two["nodes"].push_back(copy);
  two["scenes"][0]["nodes"] = {0, 1};
  // Node 0 cannot be both a root and node 1's child: give the copy its own.
  two["nodes"].push_back(two["nodes"][0]);
  two["nodes"][1]["children"] = {2};
  write("two.gltf", two.dump());

  struct Case {
    const char* input;
    int vertices;
    const char* output;
    bool draco_out;
  } cases[] = {{"plain.glb", 2930, "plain_out.glb", true},
               {"two.gltf", 5860, "two_out.glb", false},
               {"draco.glb", 2930, "draco_out.gltf", true}};
  for (const Case& c : cases) {
    const std::string out = path(c.output);
    CliRun r = run_cli("local " + path(c.input) + " -o " + out + " --target-vertices 800 --json" +
                       (c.draco_out ? "" : " --no-draco"));
    ASSERT_EQ(r.code, 0) << c.input << ": " << r.all();
    const nlohmann::json j = nlohmann::json::parse(r.all());
    EXPECT_EQ(j["input"]["vertices"], c.vertices) << c.input;
    const int v = j["output"]["vertices"];
    EXPECT_NEAR(v, 800, 16) << c.input;
    auto mesh = read_mesh(out);
    ASSERT_TRUE(mesh.ok()) << out << ": " << mesh.status().to_string();
    EXPECT_EQ(int(mesh->vertex_count()), v) << out;
    auto saliency = read_saliency(out);
    ASSERT_TRUE(saliency.ok());
    EXPECT_EQ(saliency->size(), mesh->vertex_count()) << out;
    std::ifstream f(out, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_EQ(bytes.find("KHR_draco_mesh_compression") != std::string::npos, c.draco_out) << out;
    EXPECT_NE(bytes.find("_SALIENCY"), std::string::npos) << out;
    // The output spans what the input spans (both copies for two.gltf).
    auto input = read_mesh(path(c.input));
    ASSERT_TRUE(input.ok());
    EXPECT_NEAR(mesh->scale, input->scale, 0.02 * input->scale) << out;
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(mesh->origin[size_t(a)], input->origin[size_t(a)], 0.02 * input->scale) << out;
  }
}

// Issue 19: a model moved up to 1e7 away, or resized by 1e-6 .. 1e6, remeshes
// to the same output moved or resized (within 1e-5 of the diagonal, same
// counts); unused vertices change nothing and are reported.
TEST_F(CliTest, LocalOutputFollowsTheInputsTranslationAndScaleAndIgnoresStrayVertices) {
  struct Case {
    const char* name;
    double scale, shift;
    int strays;
  };
  const Case cases[] = {{"plain", 1, 0, 0},   {"moved", 1, 1e6, 0}, {"far", 1, -1e7, 0},
                        {"tiny", 1e-6, 0, 0}, {"huge", 1e6, 0, 0},  {"strays", 1, 0, 100}};
  std::vector<Mesh> out;
  for (const Case& c : cases) {
    const std::string in =
        write(std::string(c.name) + ".obj", vpr::testing::bumpy_sphere_obj(c.scale, c.shift, c.strays));
    CliRun r =
        run_cli("local " + in + " -o " + path(std::string(c.name) + "_out.obj") + " --target-vertices 300 --json");
    ASSERT_EQ(r.code, 0) << c.name << ": " << r.all();
    EXPECT_EQ(nlohmann::json::parse(r.out)["ignored_vertices"], c.strays) << c.name;
    auto mesh = read_mesh(path(std::string(c.name) + "_out.obj"));
    ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
    out.push_back(std::move(mesh).value());
  }
  const Mesh& plain = out[0];
  double diagonal2 = 0;
  for (int a = 0; a < 3; ++a) {
    double lo = 1e300, hi = -1e300;
    for (size_t v = 0; v < plain.vertex_count(); ++v) {
      lo = std::min(lo, plain.absolute(v, a));
      hi = std::max(hi, plain.absolute(v, a));
    }
    diagonal2 += (hi - lo) * (hi - lo);
  }
  const double diagonal = std::sqrt(diagonal2);
  for (size_t i = 1; i < out.size(); ++i) {
    const Case& c = cases[i];
    ASSERT_EQ(out[i].vertex_count(), plain.vertex_count()) << c.name;
    ASSERT_EQ(out[i].face_count(), plain.face_count()) << c.name;
    EXPECT_EQ(out[i].indices, plain.indices) << c.name;
    double worst = 0;
    for (size_t v = 0; v < plain.vertex_count(); ++v)
      for (int a = 0; a < 3; ++a)
        worst = std::max(worst, std::fabs((out[i].absolute(v, a) - c.shift) / c.scale - plain.absolute(v, a)));
    std::printf("  %-7s max deviation %.3g of the diagonal\n", c.name, worst / diagonal);
    EXPECT_LT(worst, 1e-5 * diagonal) << c.name;
  }
}

TEST_F(CliTest, TablePrintsEveryStage) {
  CliRun r = run_cli("local ../shared/models/suzanne.obj -o " + path("s.ply") + " --target-vertices 300");
  ASSERT_EQ(r.code, 0) << r.all();
  for (const char* stage : {"render", "image_saliency", "saliency_field", "cvt", "meshing", "total"})
    EXPECT_NE(r.all().find(stage), std::string::npos) << r.all();
}

// --lod: one file per level, OUT.lodN.EXT, each with its field and its count,
// reported in level order with the front half's stages once (issue 20).
TEST_F(CliTest, LocalLodChainWritesOneFilePerLevel) {
  CliRun r = run_cli("local ../shared/models/spot.obj -o " + path("spot.ply") + " --lod 900,0.1 --json");
  ASSERT_EQ(r.code, 0) << r.all();
  const nlohmann::json j = nlohmann::json::parse(r.all());
  ASSERT_TRUE(j.is_array());
  ASSERT_EQ(j.size(), 2u);
  const int asked[2] = {900, 293};  // 0.1 of 2,930
  for (int level = 0; level < 2; ++level) {
    const nlohmann::json& l = j[size_t(level)];
    EXPECT_EQ(l["level"], level);
    EXPECT_EQ(l["target_vertices"], asked[level]);
    const std::string file = path("spot.lod" + std::to_string(level) + ".ply");
    EXPECT_EQ(l["output_file"], file);
    auto mesh = read_mesh(file);
    ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
    EXPECT_NEAR(double(mesh->vertex_count()), asked[level], 0.02 * asked[level]);
    EXPECT_EQ(int(mesh->vertex_count()), l["output"]["vertices"]);
    auto saliency = read_saliency(file);
    ASSERT_TRUE(saliency.ok());
    EXPECT_EQ(saliency->size(), mesh->vertex_count());
    int renders = 0;
    for (const auto& s : l["stages"]) renders += s["name"] == "render";
    EXPECT_EQ(renders, level == 0 ? 1 : 0) << "the snapshots are rendered once, for level 0";
  }
  EXPECT_FALSE(fs::exists(path("spot.ply")));
}

TEST_F(CliTest, BadInputsGetOneClearLineAndTheirExitCode) {
  struct Case {
    std::string args;
    int code;
    std::string needle;
  };
  const std::string obj_nan = write("nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
  const std::string obj_oob = write("oob.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  const std::string cloud = write("cloud.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  const std::string empty = write("empty.off", "");
  const std::string corrupt = write("corrupt.drc", std::string("DRACO\x02\x02\x01\x01\x00\x00garbage", 18));
  const std::string ply_head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                               "property float z\n";
  const std::string ply_tail = "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string map3 = write("map3.ply", ply_head + "property float saliency\n" + ply_tail +
                                                 "0 0 0 0.5\n1 0 0 0.2\n0 1 0 0.9\n3 0 1 2\n");
  const std::string no_map = write("nomap.ply", ply_head + ply_tail + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  const std::string good = "../shared/models/spot.obj";
  const std::string spot_to_ply = "local " + good + " -o " + path("o.ply");
  const Case cases[] = {
      {"local " + path("missing.obj") + " -o " + path("o.ply") + " -n 500", 7, "missing.obj"},
      {"local " + obj_nan + " -o " + path("o.ply") + " -n 500", 3, "non-finite"},
      {"local " + obj_oob + " -o " + path("o.ply") + " -n 500", 3, "out of range"},
      {"local " + cloud + " -o " + path("o.ply") + " -n 500", 3, "point cloud"},
      {"local " + empty + " -o " + path("o.ply") + " -n 500", 3, "empty.off"},
      {"local " + corrupt + " -o " + path("o.ply") + " -n 500", 3, "corrupt.drc"},
      {spot_to_ply + " -n 5", 3, "[100, 2000000]"},
      {"local " + good + " -o " + path("o.xyz") + " -n 500", 3, ".xyz"},
      {spot_to_ply + " -n 500 --views 7", 2, "views"},
      {spot_to_ply + " -n 500 --renderer vulkan", 3, "vulkan"},
      {spot_to_ply, 3, "a target is required"},
      {spot_to_ply + " -n 500 --lod 300", 3, "not both"},
      {spot_to_ply + " --lod 500,0", 3, "--lod item 1 '0'"},
      {spot_to_ply + " --lod 500,abc", 3, "'abc' is not a number"},
      {spot_to_ply + " --lod 500,1.5", 3, "whole number"},
      {spot_to_ply + " --lod 1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1", 3, "at most 16"},
      {spot_to_ply + " --min-ssim 1.2", 3, "outside (0, 1)"},
      {spot_to_ply + " -n 500 --attention-map " + map3, 3, "attention map has 3 values for a mesh of 2930 vertices"},
      {spot_to_ply + " -n 500 --attention-map " + no_map, 3, "has no 'saliency' values"},
      {spot_to_ply + " -n 500 --attention-map " + path("nomap-missing.ply"), 7, "nomap-missing.ply"},
  };
  for (const Case& c : cases) {
    CliRun r = run_cli(c.args);
    EXPECT_EQ(r.code, c.code) << c.args << "\n" << r.all();
    EXPECT_NE(r.all().find(c.needle), std::string::npos) << c.args << "\n" << r.all();
  }
  // The file is named once ("x.drc: Draco: ...", not "x.drc: x.drc: Draco: ...").
  CliRun r = run_cli("local " + corrupt + " -o " + path("o.ply") + " -n 500");
  const size_t first = r.err.find("corrupt.drc");
  ASSERT_NE(first, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("corrupt.drc", first + 1), std::string::npos) << r.err;
}

TEST_F(CliTest, EvalOfAMeshAgainstItselfIsZero) {
  CliRun r = run_cli("eval ../shared/models/spot.obj ../shared/models/spot.obj --json --samples 20000");
  ASSERT_EQ(r.code, 0) << r.all();
  const nlohmann::json j = nlohmann::json::parse(r.all());
  EXPECT_LT(double(j["hausdorff"]["max"]), 1e-9);
  EXPECT_EQ(j["candidate"]["vertices"], 2930);
  EXPECT_EQ(j["candidate"]["non_manifold_edges"], 0);
}

// field-sheet: rows are views, columns fields, tiles with a 2-pixel gutter
// around and between them; a field of another mesh is refused.
TEST_F(CliTest, FieldSheetDrawsOneTilePerViewAndFieldAndRefusesAFieldOfAnotherMesh) {
  const std::string field = path("field.ply");
  CliRun r = run_cli("local ../shared/models/spot.obj -o " + path("spot.ply") + " -n 500 --field-out " + field);
  ASSERT_EQ(r.code, 0) << r.all();
  const std::string png = path("sheet.png");
  r = run_cli("field-sheet ../shared/models/spot.obj -f " + field + " -f " + field + " -f " + field + " -o " + png +
              " --tile 64");
  ASSERT_EQ(r.code, 0) << r.all();
  std::ifstream in(png, std::ios::binary);
  unsigned char head[24] = {};
  in.read(reinterpret_cast<char*>(head), sizeof head);
  ASSERT_TRUE(in) << png;
  EXPECT_EQ(std::string(reinterpret_cast<char*>(head + 12), 4), "IHDR");
  auto be32 = [&](int at) { return (head[at] << 24) | (head[at + 1] << 16) | (head[at + 2] << 8) | head[at + 3]; };
  EXPECT_EQ(be32(16), 3 * 64 + 4 * 2);  // three fields across
  EXPECT_EQ(be32(20), 2 * 64 + 3 * 2);  // two views down

  r = run_cli("field-sheet ../shared/models/suzanne.obj -f " + field + " -o " + path("bad.png"));
  EXPECT_EQ(r.code, 3) << r.all();
  EXPECT_NE(r.err.find("2930 field values"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("bad.png")));
}

}  // namespace
}  // namespace vpr
