// glTF 2.0 input and output: files built here byte by byte (so the reader is
// not only tested against our writer), node transforms, Draco-compressed
// primitives, external buffers, the writer's round trip, and hostile files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/color.h"
#include "io/mesh_io.h"
#include "io/png_io.h"

namespace vpr {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// A unit cube: 8 corners, 12 triangles.
const float kCube[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
const uint16_t kCubeFaces[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                                    {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};

std::string bytes_of(const void* p, size_t n) { return std::string(static_cast<const char*>(p), n); }

// The cube's binary buffer: positions (96 bytes), then uint16 indices (72).
std::string cube_bin() { return bytes_of(kCube, sizeof kCube) + bytes_of(kCubeFaces, sizeof kCubeFaces); }

json cube_accessors_and_views(size_t bin_size) {
  return {{"accessors",
           {{{"bufferView", 0}, {"componentType", 5126}, {"count", 8}, {"type", "VEC3"}},
            {{"bufferView", 1}, {"componentType", 5123}, {"count", 36}, {"type", "SCALAR"}}}},
          {"bufferViews",
           {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 96}}, {{"buffer", 0}, {"byteOffset", 96}, {"byteLength", 72}}}},
          {"buffers", {{{"byteLength", bin_size}}}}};
}

std::string glb(const json& root, std::string bin) {
  std::string text = root.dump();
  while (text.size() % 4) text += ' ';
  while (bin.size() % 4) bin += '\0';
  auto u32 = [](uint32_t v) { return bytes_of(&v, 4); };
  std::string out = "glTF" + u32(2) + u32(uint32_t(12 + 8 + text.size() + (bin.empty() ? 0 : 8 + bin.size())));
  out += u32(uint32_t(text.size())) + "JSON" + text;
  if (!bin.empty()) out += u32(uint32_t(bin.size())) + std::string("BIN\0", 4) + bin;
  return out;
}

// meshes: [ { primitives: [ primitive ] } ]
json one_mesh(const json& primitive) { return json::array({json{{"primitives", json::array({primitive})}}}); }

StatusOr<Mesh> parse(const std::string& bytes, const MeshLimits& limits = {}) {
  return parse_mesh(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), MeshFormat::kGltf, limits);
}

void expect_error(const StatusOr<Mesh>& mesh, StatusCode code, const std::string& needle) {
  ASSERT_FALSE(mesh.ok()) << "expected an error containing '" << needle << "'";
  EXPECT_EQ(mesh.status().code(), code) << mesh.status().to_string();
  EXPECT_NE(mesh.status().message().find(needle), std::string::npos) << mesh.status().to_string();
  EXPECT_EQ(mesh.status().message().find('\n'), std::string::npos) << "one line: " << mesh.status().to_string();
}

class TempDir {
 public:
  TempDir() : path_(fs::temp_directory_path() / ("vpr_gltf_io_test_" + std::to_string(::getpid()))) {
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

void write(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

// Two nodes place the cube twice: one moved and scaled, one rotated 90
// degrees about z whose child (a matrix) moves it again.
TEST(Gltf, TwoNodesWithDifferentTransformsGiveOneSurface) {
  json root = cube_accessors_and_views(168);
  root["asset"] = {{"version", "2.0"}};
  root["scene"] = 0;
  root["scenes"] = {{{"nodes", {0, 1}}}};
  const double h = std::sqrt(0.5);
  root["nodes"] = {{{"mesh", 0}, {"translation", {10, 0, 0}}, {"scale", {2, 2, 2}}},
                   {{"rotation", {0, 0, h, h}}, {"children", {2}}},
                   {{"mesh", 0}, {"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 5, 1}}}};
  root["meshes"] = one_mesh({{"attributes", {{"POSITION", 0}}}, {"indices", 1}});
  auto mesh = parse(glb(root, cube_bin()));
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  ASSERT_EQ(mesh->vertex_count(), 16u);
  ASSERT_EQ(mesh->face_count(), 24u);
  // Scene order: node 0 first, then node 1's child.
  for (int v = 0; v < 8; ++v) {
    const double moved[3] = {10 + 2.0 * kCube[v][0], 2.0 * kCube[v][1], 2.0 * kCube[v][2]};
    // Child: z + 5; parent: (x, y) -> (-y, x).
    const double turned[3] = {-kCube[v][1], kCube[v][0], kCube[v][2] + 5};
    for (int a = 0; a < 3; ++a) {
      // Floats in the mesh frame: within 1e-7 of the 16-unit diagonal.
      EXPECT_NEAR(mesh->absolute(size_t(v), a), moved[a], 2e-6) << "vertex " << v;
      EXPECT_NEAR(mesh->absolute(size_t(v) + 8, a), turned[a], 2e-6) << "vertex " << v + 8;
    }
  }
  for (int f = 0; f < 12; ++f)
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(mesh->indices[size_t(3 * f + k)], kCubeFaces[f][k]);
      EXPECT_EQ(mesh->indices[size_t(36 + 3 * f + k)], kCubeFaces[f][k] + 8u);
    }
}

Mesh cube_mesh() {
  Mesh m;
  for (const auto& p : kCube) m.positions.insert(m.positions.end(), p, p + 3);
  for (const auto& f : kCubeFaces) m.indices.insert(m.indices.end(), f, f + 3);
  return m;
}

TEST(Gltf, DracoCompressedPrimitiveDecodes) {
  DracoOptions draco;
  draco.speed = 10;  // sequential: every face kept in order
  auto bitstream = encode_draco(cube_mesh(), nullptr, draco);
  ASSERT_TRUE(bitstream.ok());
  const std::string bin(bitstream->begin(), bitstream->end());
  json root = {{"asset", {{"version", "2.0"}}},
               {"scenes", {{{"nodes", {0}}}}},
               {"nodes", {{{"mesh", 0}, {"translation", {0, 0, 3}}}}},
               {"meshes",
                {{{"primitives",
                   {{{"attributes", {{"POSITION", 0}}},
                     {"indices", 1},
                     {"extensions",
                      {{"KHR_draco_mesh_compression", {{"bufferView", 0}, {"attributes", {{"POSITION", 0}}}}}}}}}}}}},
               {"accessors",
                {{{"componentType", 5126}, {"count", 8}, {"type", "VEC3"}},
                 {{"componentType", 5125}, {"count", 36}, {"type", "SCALAR"}}}},
               {"bufferViews", {{{"buffer", 0}, {"byteLength", bin.size()}}}},
               {"buffers", {{{"byteLength", bin.size()}}}},
               {"extensionsRequired", {"KHR_draco_mesh_compression"}}};
  auto mesh = parse(glb(root, bin));
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  ASSERT_EQ(mesh->vertex_count(), 8u);
  ASSERT_EQ(mesh->face_count(), 12u);
  // 14-bit quantization of a unit cube: within half a step.
  const double step = 1.0 / ((1 << 14) - 1);
  for (int v = 0; v < 8; ++v)
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(mesh->absolute(size_t(v), a), kCube[v][a] + (a == 2 ? 3 : 0), step) << "vertex " << v;
}

// .gltf text with an external .bin beside it, and a triangle strip.
TEST(Gltf, TextFileWithExternalBufferAndStrip) {
  TempDir dir;
  const float quad[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  write(dir.file("quad.bin"), bytes_of(quad, sizeof quad));
  json root = {{"asset", {{"version", "2.0"}}},
               {"scenes", {{{"nodes", {0}}}}},
               {"nodes", {{{"mesh", 0}}}},
               {"meshes", one_mesh({{"attributes", {{"POSITION", 0}}}, {"mode", 5}})},
               {"accessors", {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}}}},
               {"bufferViews", {{{"buffer", 0}, {"byteLength", 48}}}},
               {"buffers", {{{"byteLength", 48}, {"uri", "quad.bin"}}}}};
  write(dir.file("quad.gltf"), root.dump());
  auto mesh = read_mesh(dir.file("quad.gltf"));
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  ASSERT_EQ(mesh->face_count(), 2u);
  // Strip: (0 1 2), then (2 1 3) so both face +z.
  EXPECT_EQ(mesh->indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
  // The same bytes as an upload may not name files.
  const std::string text = root.dump();
  expect_error(parse(text), StatusCode::kInvalidArgument, "external file 'quad.bin', which an upload cannot carry");
  fs::remove(dir.file("quad.bin"));
  auto missing = read_mesh(dir.file("quad.gltf"));
  expect_error(missing, StatusCode::kInvalidArgument, "external buffer 'quad.bin' is missing");
}

Mesh far_sphere() {
  Mesh m;
  const int rings = 6, segments = 8;
  const double pi = 3.14159265358979323846;
  std::vector<double> p;
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s < segments; ++s) {
      // No vertex at the poles: every vertex has its own position.
      const double t = pi * (r + 0.5) / (rings + 1), f = 2 * pi * s / segments;
      p.insert(p.end(), {4e5 + std::sin(t) * std::cos(f), -3e6 + std::sin(t) * std::sin(f), 120 + std::cos(t)});
    }
  std::vector<uint32_t> idx;
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const uint32_t a = uint32_t(r * segments + s), b = uint32_t(r * segments + (s + 1) % segments);
      idx.insert(idx.end(), {a, a + segments, b + segments, a, b + segments, b});
    }
  return mesh_from_absolute(p, idx);
}

TEST(Gltf, WriterRoundTripKeepsFrameFloatsAndSaliency) {
  TempDir dir;
  const Mesh mesh = far_sphere();
  std::vector<float> saliency(mesh.vertex_count());
  for (size_t i = 0; i < saliency.size(); ++i) saliency[i] = float(i % 7) / 6.0f;
  for (const char* name : {"plain.glb", "plain.gltf"}) {
    DracoOptions plain;
    plain.gltf_draco = false;
    ASSERT_TRUE(write_mesh(dir.file(name), mesh, saliency.data(), plain).ok()) << name;
    auto back = read_mesh(dir.file(name));
    ASSERT_TRUE(back.ok()) << name << ": " << back.status().to_string();
    ASSERT_EQ(back->indices, mesh.indices) << name;
    // The node carries the frame in double: a vertex 3e6 from zero comes back
    // to within a float step of the unit-sized model, not of 3e6.
    for (size_t v = 0; v < mesh.vertex_count(); ++v)
      for (int a = 0; a < 3; ++a) ASSERT_NEAR(back->absolute(v, a), mesh.absolute(v, a), 1e-6) << name << " vertex " << v;
    auto values = read_saliency(dir.file(name));
    ASSERT_TRUE(values.ok());
    EXPECT_EQ(*values, saliency) << name;
  }
  // Draco-compressed: positions within half a 14-bit step of the extent
  // (in the frame: the node restores the origin), saliency within 10 bits.
  ASSERT_TRUE(write_mesh(dir.file("draco.glb"), mesh, saliency.data()).ok());
  const std::string bytes = [&] {
    std::ifstream in(dir.file("draco.glb"), std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  EXPECT_NE(bytes.find("KHR_draco_mesh_compression"), std::string::npos);
  auto back = read_mesh(dir.file("draco.glb"));
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  ASSERT_EQ(back->vertex_count(), mesh.vertex_count());
  ASSERT_EQ(back->face_count(), mesh.face_count());
  auto values = read_saliency(dir.file("draco.glb"));
  ASSERT_TRUE(values.ok());
  ASSERT_EQ(values->size(), mesh.vertex_count());
  // Edgebreaker reorders vertices: match each one to its nearest original.
  const double extent = 2.0, tolerance = 0.5 * extent / ((1 << 14) - 1) * 1.01;
  for (size_t v = 0; v < back->vertex_count(); ++v) {
    double best = HUGE_VAL;
    size_t nearest = 0;
    for (size_t u = 0; u < mesh.vertex_count(); ++u) {
      double d = 0;
      for (int a = 0; a < 3; ++a) d = std::max(d, std::fabs(back->absolute(v, a) - mesh.absolute(u, a)));
      if (d < best) best = d, nearest = u;
    }
    EXPECT_LE(best, tolerance) << "vertex " << v;
    EXPECT_NEAR((*values)[v], saliency[nearest], 0.5 / 1023 + 1e-6) << "vertex " << v;
  }
}

TEST(Gltf, HostileAndBrokenFilesNameTheProblem) {
  json base = cube_accessors_and_views(168);
  base["asset"] = {{"version", "2.0"}};
  base["scenes"] = {{{"nodes", {0}}}};
  base["nodes"] = {{{"mesh", 0}}};
  base["meshes"] = one_mesh({{"attributes", {{"POSITION", 0}}}, {"indices", 1}});
  ASSERT_TRUE(parse(glb(base, cube_bin())).ok());

  // No triangles: a point primitive only.
  json points = base;
  points["meshes"][0]["primitives"][0]["mode"] = 0;
  expect_error(parse(glb(points, cube_bin())), StatusCode::kInvalidArgument, "the scene has no triangles");
  // 1e9 indices declared in a 200-byte file: refused before anything is sized.
  json huge = base;
  huge["accessors"][1]["count"] = 1000000000;
  expect_error(parse(glb(huge, cube_bin())), StatusCode::kResourceExhausted, "the limit is");
  huge["accessors"][1]["count"] = 3000000;
  expect_error(parse(glb(huge, cube_bin())), StatusCode::kInvalidArgument,
               "accessor 1 declares 3000000 elements, more than its bufferView's 72 bytes hold");
  // One mesh instanced by many nodes counts once per node.
  json instanced = base;
  instanced["nodes"] = json::array();
  instanced["scenes"][0]["nodes"] = json::array();
  for (int i = 0; i < 200; ++i) {
    instanced["nodes"].push_back({{"mesh", 0}});
    instanced["scenes"][0]["nodes"].push_back(i);
  }
  expect_error(parse(glb(instanced, cube_bin()), MeshLimits{1000, 100000}), StatusCode::kResourceExhausted,
               "the limit is 1000");
  // A buffer longer than the BIN chunk, a view beyond its buffer, an index beyond the vertices.
  json longer = base;
  longer["buffers"][0]["byteLength"] = 100000;
  expect_error(parse(glb(longer, cube_bin())), StatusCode::kInvalidArgument, "buffer 0 declares 100000 bytes but holds 168");
  json beyond = base;
  beyond["bufferViews"][1]["byteOffset"] = 160;
  expect_error(parse(glb(beyond, cube_bin())), StatusCode::kInvalidArgument, "lies beyond its buffer's 168 bytes");
  std::string bad_index = cube_bin();
  bad_index[96] = 9;
  expect_error(parse(glb(base, bad_index)), StatusCode::kInvalidArgument, "index 9 is beyond the primitive's 8 vertices");
  // A stride beyond glTF's 252 bytes (it would let a count wrap the bounds check).
  json strided = base;
  strided["bufferViews"][0]["byteStride"] = int64_t(1) << 62;
  expect_error(parse(glb(strided, cube_bin())), StatusCode::kInvalidArgument, "byteStride 4611686018427387904 is outside");
  // Millions of tiny JSON values: refused before the document is built.
  std::string many = R"({"asset":{"version":"2.0"},"extras":[)";
  for (int i = 0; i < 4'000'001; ++i) many += "0,";
  many += "0]}";
  expect_error(parse(many), StatusCode::kResourceExhausted, "values, the limit is 4000000");
  // More nodes than the walk keeps matrices for.
  std::string nodes = R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[)";
  for (int i = 0; i < 1'000'000; ++i) nodes += "{},";
  nodes += "{}]}";
  expect_error(parse(nodes), StatusCode::kResourceExhausted, "the file has 1000001 nodes, the limit is 1000000");
  // A cycle in the node graph.
  json cycle = base;
  cycle["nodes"] = {{{"mesh", 0}, {"children", {1}}}, {{"children", {0}}}};
  expect_error(parse(glb(cycle, cube_bin())), StatusCode::kInvalidArgument, "reached twice");
  // Not JSON, not glTF 2, a truncated GLB header and a lying chunk length.
  expect_error(parse("{not json"), StatusCode::kInvalidArgument, "the JSON is malformed");
  expect_error(parse(R"({"asset":{"version":"1.0"}})"), StatusCode::kInvalidArgument, "version '1.0' is not supported");
  expect_error(parse(std::string("glTF\x02\0\0\0", 8)), StatusCode::kInvalidArgument, "GLB header is truncated");
  std::string lying = glb(base, cube_bin());
  lying[12] = '\xff';
  lying[13] = '\xff';
  expect_error(parse(lying), StatusCode::kInvalidArgument, "beyond the file's end");
  // A Draco primitive declaring 1e9 points in its few bytes: the Draco pre-scan refuses it.
  std::string draco = std::string("DRACO\x02\x02\x01\x00\x00\x00", 11) + std::string("\x0a\x80\x94\xeb\xdc\x03", 6);
  draco.resize(40, '\0');
  json compressed = base;
  compressed["meshes"][0]["primitives"][0]["extensions"] = {
      {"KHR_draco_mesh_compression", {{"bufferView", 0}, {"attributes", {{"POSITION", 0}}}}}};
  compressed["bufferViews"] = {{{"buffer", 0}, {"byteLength", 40}}};
  compressed["buffers"][0]["byteLength"] = 40;
  compressed["accessors"][0].erase("bufferView");
  compressed["accessors"][1].erase("bufferView");
  expect_error(parse(glb(compressed, draco)), StatusCode::kResourceExhausted,
               "Draco-compressed primitive: Draco: the header declares 1000000000 vertices, the limit is");
}

// ---- Colors and textures ---------------------------------------------------

// A unit quad in the xy plane (4 vertices, 2 triangles) with texture
// coordinates (x, y) and COLOR_0, after it any images' bytes; the accessors:
// 0 positions, 1 indices, 2 TEXCOORD_0, 3 COLOR_0 (VEC3 unsigned short).
const float kQuad[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
const uint16_t kQuadFaces[6] = {0, 1, 2, 0, 2, 3};
const float kQuadUv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
const uint16_t kQuadColors[4][4] = {{65535, 0, 0, 0}, {0, 65535, 0, 0}, {0, 0, 65535, 0}, {32768, 32768, 32768, 0}};

std::string quad_bin(const std::string& images = "") {
  return bytes_of(kQuad, 48) + bytes_of(kQuadFaces, 12) + bytes_of(kQuadUv, 32) + bytes_of(kQuadColors, 32) + images;
}

json textured_quad(const std::string& png, const json& primitive_attributes) {
  json root = {{"asset", {{"version", "2.0"}}},
               {"scenes", {{{"nodes", {0}}}}},
               {"nodes", {{{"mesh", 0}}}},
               {"meshes", one_mesh({{"attributes", primitive_attributes}, {"indices", 1}, {"material", 0}})},
               {"materials", {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}}},
               {"textures", {{{"source", 0}, {"sampler", 0}}}},
               {"samplers", {{{"wrapS", 33071}, {"wrapT", 33648}}}},
               {"images", {{{"bufferView", 4}, {"mimeType", "image/png"}}}},
               {"accessors",
                {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
                 {{"bufferView", 1}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}},
                 {{"bufferView", 2}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}},
                 {{"bufferView", 3}, {"componentType", 5123}, {"normalized", true}, {"count", 4}, {"type", "VEC3"}}}},
               {"bufferViews",
                {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
                 {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 12}},
                 {{"buffer", 0}, {"byteOffset", 60}, {"byteLength", 32}},
                 {{"buffer", 0}, {"byteOffset", 92}, {"byteLength", 32}, {"byteStride", 8}},
                 {{"buffer", 0}, {"byteOffset", 124}, {"byteLength", png.size()}}}},
               {"buffers", {{{"byteLength", 124 + png.size()}}}}};
  return root;
}

// A 4 x 2 PNG: texel (x, y) = (60 x, 100 y, 7).
std::string small_png() {
  std::vector<uint8_t> rgb;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) rgb.insert(rgb.end(), {uint8_t(60 * x), uint8_t(100 * y), 7});
  auto png = encode_rgb_png(4, 2, rgb.data());
  EXPECT_TRUE(png.ok());
  return std::string(png->begin(), png->end());
}

TEST(GltfColors, Color0FormsAreLinearAndTheFactorMultiplies) {
  // COLOR_0 as stored (unsigned short, stride 8), then as VEC4 floats and
  // unsigned bytes, each under a baseColorFactor of (1, 0.5, 1).
  const std::string png = small_png();
  json root = textured_quad(png, {{"POSITION", 0}, {"COLOR_0", 3}});
  root["materials"] = {{{"pbrMetallicRoughness", {{"baseColorFactor", {1, 0.5, 1, 1}}}}}};
  auto mesh = parse(glb(root, quad_bin(png)));
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  EXPECT_TRUE(mesh->textures.empty());
  const uint8_t half = srgb_from_linear(0.5f), gray = srgb_from_linear(32768.0f / 65535),
                quarter = srgb_from_linear(0.25f);
  EXPECT_EQ(half, 188);
  EXPECT_EQ(mesh->colors, (std::vector<uint8_t>{255, 0, 0, 0, half, 0, 0, 0, 255, gray,
                                                srgb_from_linear(0.5f * 32768.0f / 65535), gray}));
  const float rgba[4][4] = {{1, 0, 0, 1}, {0, 1, 0, 1}, {0.25f, 0.5f, 1, 1}, {2, -1, 0.5f, 0}};
  const uint8_t bytes[4][4] = {{255, 0, 0, 9}, {0, 255, 0, 9}, {64, 128, 255, 9}, {255, 0, 128, 9}};
  for (int form = 0; form < 2; ++form) {
    std::string bin = quad_bin(png) + (form == 0 ? bytes_of(rgba, 64) : bytes_of(bytes, 16));
    json r = root;
    r["buffers"][0]["byteLength"] = bin.size();
    r["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 124 + png.size()}, {"byteLength", form == 0 ? 64 : 16}});
    r["accessors"][3] = {{"bufferView", 5}, {"componentType", form == 0 ? 5126 : 5121}, {"count", 4}, {"type", "VEC4"}};
    if (form == 1) r["accessors"][3]["normalized"] = true;
    auto m = parse(glb(r, bin));
    ASSERT_TRUE(m.ok()) << m.status().to_string();
    ASSERT_EQ(m->colors.size(), 12u);
    const uint8_t third = form == 0 ? quarter : srgb_from_linear(64 / 255.0f);
    EXPECT_EQ(m->colors[0], 255);
    EXPECT_EQ(m->colors[4], half);  // green 1 x factor 0.5
    EXPECT_EQ(m->colors[6], third);
    EXPECT_EQ(m->colors[9], 255) << "2 is clamped to 1";
    EXPECT_EQ(m->colors[10], 0) << "-1 is clamped to 0";
  }
}

TEST(GltfColors, BaseColorTextureWithSamplerAndTransform) {
  const std::string png = small_png();
  json root = textured_quad(png, {{"POSITION", 0}, {"TEXCOORD_0", 2}});
  auto mesh = parse(glb(root, quad_bin(png)));
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  EXPECT_TRUE(mesh->colors.empty()) << "a texture alone gives no vertex colors";
  const MeshTextures& t = mesh->textures;
  ASSERT_EQ(t.textures.size(), 1u);
  EXPECT_EQ(t.textures[0].wrap_u, TextureWrap::kClampToEdge);
  EXPECT_EQ(t.textures[0].wrap_v, TextureWrap::kMirroredRepeat);
  const RgbImage& image = *t.textures[0].image;
  ASSERT_EQ(image.width, 4);
  ASSERT_EQ(image.height, 2);
  EXPECT_EQ(image.at(3, 1), (std::array<uint8_t, 3>{180, 100, 7}));
  EXPECT_EQ(t.uvs, (std::vector<float>{0, 0, 1, 0, 1, 1, 0, 1}));
  EXPECT_EQ(t.vertex_texture, (std::vector<uint32_t>{0, 0, 0, 0}));

  // KHR_texture_transform: scale (2, 3), a quarter turn, offset (0.5, 0.25):
  // u' = cos r 2u + sin r 3v + 0.5, v' = -sin r 2u + cos r 3v + 0.25.
  json turned = root;
  turned["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] = {
      {"KHR_texture_transform", {{"offset", {0.5, 0.25}}, {"rotation", 1.5707963267948966}, {"scale", {2, 3}}}}};
  mesh = parse(glb(turned, quad_bin(png)));
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  const std::vector<float> expected = {0.5f, 0.25f, 0.5f, -1.75f, 3.5f, -1.75f, 3.5f, 0.25f};
  ASSERT_EQ(mesh->textures.uvs.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) EXPECT_NEAR(mesh->textures.uvs[i], expected[i], 1e-6) << i;
}

// A textured primitive and an untextured, tinted one: one surface whose
// untextured vertices have kNone, and whose first vertices are white.
TEST(GltfColors, MixedPrimitivesKeepTheirOwnAppearance) {
  const std::string png = small_png();
  json root = textured_quad(png, {{"POSITION", 0}, {"TEXCOORD_0", 2}});
  json plain = {{"attributes", {{"POSITION", 0}}}, {"indices", 1}, {"material", 1}};
  root["meshes"][0]["primitives"].push_back(plain);
  root["materials"].push_back({{"pbrMetallicRoughness", {{"baseColorFactor", {0, 0, 1, 1}}}}});
  auto mesh = parse(glb(root, quad_bin(png)));
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  ASSERT_EQ(mesh->vertex_count(), 8u);
  EXPECT_EQ(mesh->colors, (std::vector<uint8_t>{255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255,
                                                0,   0,   255, 0,   0,   255, 0,   0,   255, 0,   0,   255}));
  const uint32_t none = MeshTextures::kNone;
  EXPECT_EQ(mesh->textures.vertex_texture, (std::vector<uint32_t>{0, 0, 0, 0, none, none, none, none}));
  EXPECT_EQ(mesh->textures.uvs.size(), 16u);
}

// .gltf text with the image as a data: URI, or as a file beside it (which
// an upload may not name).
TEST(GltfColors, ImagesFromDataUrisAndFilesBesideTheModel) {
  const std::string png = small_png();
  json root = textured_quad(png, {{"POSITION", 0}, {"TEXCOORD_0", 2}});
  const std::string bin = quad_bin();
  std::string base64;
  {
    static const char digits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    auto encode = [&](const std::string& b) {
      std::string out;
      for (size_t i = 0; i < b.size(); i += 3) {
        uint32_t n = uint32_t(uint8_t(b[i])) << 16;
        if (i + 1 < b.size()) n |= uint32_t(uint8_t(b[i + 1])) << 8;
        if (i + 2 < b.size()) n |= uint8_t(b[i + 2]);
        out += digits[(n >> 18) & 63];
        out += digits[(n >> 12) & 63];
        out += i + 1 < b.size() ? digits[(n >> 6) & 63] : '=';
        out += i + 2 < b.size() ? digits[n & 63] : '=';
      }
      return out;
    };
    root["buffers"] = {{{"byteLength", bin.size()}, {"uri", "data:application/octet-stream;base64," + encode(bin)}}};
    root["bufferViews"].erase(4);
    root["images"] = {{{"uri", "data:image/png;base64," + encode(png)}}};
  }
  auto mesh = parse(root.dump());
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  ASSERT_EQ(mesh->textures.textures.size(), 1u);
  EXPECT_EQ(mesh->textures.textures[0].image->at(1, 0), (std::array<uint8_t, 3>{60, 0, 7}));

  TempDir dir;
  root["images"] = {{{"uri", "checker.png"}}};
  write(dir.file("checker.png"), png);
  write(dir.file("quad.gltf"), root.dump());
  mesh = read_mesh(dir.file("quad.gltf"));
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  EXPECT_EQ(mesh->textures.textures[0].image->at(2, 1), (std::array<uint8_t, 3>{120, 100, 7}));
  expect_error(parse(root.dump()), StatusCode::kInvalidArgument,
               "image 0 is the external file 'checker.png', which an upload cannot carry");
  fs::remove(dir.file("checker.png"));
  expect_error(read_mesh(dir.file("quad.gltf")), StatusCode::kInvalidArgument,
               "external image 'checker.png' is missing or unreadable");
}

// A texture that cannot be read fails the file with one line naming the
// image and the problem; sizes are refused from the image's header.
TEST(GltfColors, UnreadableOrHugeTexturesAreOneLineErrors) {
  const std::string png = small_png();
  const json attributes = {{"POSITION", 0}, {"TEXCOORD_0", 2}};
  std::string corrupt = png;
  corrupt.resize(png.size() - 20);
  expect_error(parse(glb(textured_quad(corrupt, attributes), quad_bin(corrupt))), StatusCode::kInvalidArgument,
               "glTF: image 0: PNG: cannot decode the image (libpng: ");
  std::string huge = png;
  const char billion[4] = {0x3b, char(0x9a), char(0xca), 0x00};  // 10^9, big-endian
  huge.replace(16, 4, billion, 4);
  huge.replace(20, 4, billion, 4);
  expect_error(parse(glb(textured_quad(huge, attributes), quad_bin(huge))), StatusCode::kResourceExhausted,
               "glTF: image 0: PNG: the image is 1000000000 x 1000000000 pixels, the limit is 16384 per side");
  const std::string webp = std::string("RIFF\x10\0\0\0WEBPVP8 ", 16);
  expect_error(parse(glb(textured_quad(webp, attributes), quad_bin(webp))), StatusCode::kInvalidArgument,
               "glTF: image 0: the image is neither PNG nor JPEG");
  // Two 4 x 2 images against a budget of 12 pixels: the second one fails.
  json two = textured_quad(png, attributes);
  two["meshes"][0]["primitives"].push_back({{"attributes", attributes}, {"indices", 1}, {"material", 1}});
  two["materials"].push_back({{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 1}}}}}});
  two["textures"].push_back({{"source", 1}});
  two["images"].push_back({{"bufferView", 4}});
  MeshLimits budget;
  budget.max_texture_pixels = 12;
  expect_error(parse(glb(two, quad_bin(png)), budget), StatusCode::kResourceExhausted,
               "glTF: image 1: PNG: the image is 4 x 2 pixels, the limit is 16384 per side and 4 pixels (the file's "
               "other textures took 8 of 12)");
  // No coordinates for the texture, or an image only an extension names.
  expect_error(parse(glb(textured_quad(png, {{"POSITION", 0}}), quad_bin(png))), StatusCode::kInvalidArgument,
               "a primitive whose material has a base-color texture has no TEXCOORD_0 for it");
  json basisu = textured_quad(png, attributes);
  basisu["textures"][0] = {{"extensions", {{"KHR_texture_basisu", {{"source", 0}}}}}};
  expect_error(parse(glb(basisu, quad_bin(png))), StatusCode::kInvalidArgument, "texture 0 has no PNG or JPEG image");
  json sampler = textured_quad(png, attributes);
  sampler["samplers"][0]["wrapS"] = 1234;
  expect_error(parse(glb(sampler, quad_bin(png))), StatusCode::kInvalidArgument,
               "sampler 0: wrapS 1234 is not a wrap mode");
}

TEST(GltfColors, WriterRoundTripKeepsColorsPlainAndCompressed) {
  TempDir dir;
  Mesh mesh = far_sphere();
  for (size_t v = 0; v < mesh.vertex_count(); ++v)
    mesh.colors.insert(mesh.colors.end(), {uint8_t(v * 5), uint8_t(255 - v * 3), uint8_t(v % 4)});
  std::vector<float> saliency(mesh.vertex_count(), 0.25f);
  DracoOptions plain;
  plain.gltf_draco = false;
  DracoOptions sequential;
  sequential.speed = 10;
  for (const DracoOptions& options : {plain, sequential}) {
    for (const char* name : {"c.glb", "c.gltf"}) {
      ASSERT_TRUE(write_mesh(dir.file(name), mesh, saliency.data(), options).ok()) << name;
      auto back = read_mesh(dir.file(name));
      ASSERT_TRUE(back.ok()) << name << ": " << back.status().to_string();
      ASSERT_EQ(back->vertex_count(), mesh.vertex_count());
      // The vertex order is kept (plain accessors, sequential Draco): colors come back byte for byte.
      EXPECT_EQ(back->colors, mesh.colors) << name << (options.gltf_draco ? " compressed" : " plain");
    }
  }
  // COLOR_0 is linear unsigned short, VEC3, vertex-aligned with a stride of 8.
  ASSERT_TRUE(write_mesh(dir.file("p.gltf"), mesh, nullptr, plain).ok());
  std::ifstream in(dir.file("p.gltf"));
  const json root = json::parse(in);
  const json& accessor = root["accessors"][int(root["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"])];
  EXPECT_EQ(accessor["componentType"], 5123);
  EXPECT_EQ(accessor["type"], "VEC3");
  EXPECT_EQ(accessor["normalized"], true);
  EXPECT_EQ(root["bufferViews"][int(accessor["bufferView"])]["byteStride"], 8);
}

}  // namespace
}  // namespace vpr
