// The color transfer: vertex colors through the whole pipeline against an
// analytic gradient, a textured quad read from a GLB built here (PNG in
// memory) sampled at texel centres and between them, the wrap modes, and
// the same answer on any thread count and in any frame.
#include "pipeline/color_transfer.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/color.h"
#include "io/mesh_io.h"
#include "io/png_io.h"
#include "pipeline/pipeline.h"
#include "test_meshes.h"

namespace vpr {
namespace {

using json = nlohmann::json;

// The gradient of the sphere tests, linear RGB of a point at height z in
// [-1, 1]: red on top, blue at the bottom, a little green everywhere.
std::array<float, 3> gradient(double z) {
  return {float(0.5 * (1 + z)), 0.2f, float(0.5 * (1 - z))};
}

Mesh gradient_sphere(int levels) {
  Mesh m = testing::icosphere(levels);
  for (size_t v = 0; v < m.vertex_count(); ++v)
    for (float c : gradient(m.positions[3 * v + 2])) m.colors.push_back(srgb_from_linear(c));
  return m;
}

int worst_channel(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  EXPECT_EQ(a.size(), b.size());
  int worst = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) worst = std::max(worst, std::abs(int(a[i]) - int(b[i])));
  return worst;
}

// An output vertex on an input vertex takes that vertex's color exactly, in
// any frame of the output.
TEST(ColorTransfer, VerticesOnInputVerticesKeepTheirColors) {
  const Mesh sphere = gradient_sphere(3);
  std::vector<uint8_t> colors;
  ASSERT_TRUE(transfer_colors(sphere, sphere, &colors).ok());
  EXPECT_EQ(colors, sphere.colors);
  const Mesh moved = rebased(sphere, {0.5, -3, 7}, 2);
  ASSERT_TRUE(transfer_colors(sphere, moved, &colors).ok());
  EXPECT_EQ(colors, sphere.colors);
}

// Through run_pipeline: a 2562-vertex sphere colored by the gradient,
// remeshed to 500 vertices; each output vertex's color against the gradient
// at its height. The input's and the output's bytes are each within half a
// step, and a face interpolates the linear gradient exactly; what is left is
// geometric: an output vertex lies up to 0.1% of the radius off the input's
// flat faces, 0.0005 in linear light, which the sRGB toe (12.92 x 255 steps
// per unit) stretches to 1.6 steps near black. Allowed: 3 steps at worst
// (measured: 2), 0.5 on average (measured: 0.12).
TEST(ColorTransfer, RemeshedSphereFollowsTheGradient) {
  const Mesh sphere = gradient_sphere(4);
  PipelineOptions options;
  options.target_vertices = 500;
  options.views.resolution = 128;
  options.renderer = RendererKind::kOsmesa;
  options.device = DevicePolicy::kCpu;
  auto result = run_pipeline(sphere, options);
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  const Mesh& out = result->mesh;
  ASSERT_EQ(out.colors.size(), 3 * out.vertex_count());
  EXPECT_EQ(result->stages.back().name, "colors");
  int worst = 0;
  double sum = 0;
  for (size_t v = 0; v < out.vertex_count(); ++v) {
    const Vec3d p = load3d(out.positions.data(), v);
    const std::array<float, 3> expected = gradient(p.z / norm(p));
    for (size_t c = 0; c < 3; ++c) {
      const int error = std::abs(int(out.colors[3 * v + c]) - int(srgb_from_linear(expected[c])));
      worst = std::max(worst, error);
      sum += error;
    }
  }
  EXPECT_LE(worst, 3);
  EXPECT_LE(sum / double(out.colors.size()), 0.5);
  // A mesh without colors gets none, and no colors stage.
  auto plain = run_pipeline(testing::icosphere(4), options);
  ASSERT_TRUE(plain.ok());
  EXPECT_TRUE(plain->mesh.colors.empty());
  for (const StageTiming& s : plain->stages) EXPECT_NE(s.name, "colors");
}

// ---- A textured quad from a GLB ---------------------------------------------

constexpr int kTexW = 4, kTexH = 4;

// Texel (x, y) of the 4 x 4 texture: a red ramp across, a green ramp down,
// blue on the checker's dark squares.
std::array<uint8_t, 3> texel(int x, int y) {
  return {uint8_t(20 + 70 * x), uint8_t(10 + 80 * y), uint8_t((x + y) % 2 ? 200 : 0)};
}

std::string bytes_of(const void* p, size_t n) {
  return std::string(static_cast<const char*>(p), n);
}

// The unit quad in z = 0 with TEXCOORD_0 = (uv_scale x, uv_scale y), the
// texture with the given wrap mode, and COLOR_0 when `tint` (all corners
// (1, 0.5, 1) linear); as GLB bytes.
std::string textured_quad_glb(float uv_scale, int wrap, bool tint) {
  std::vector<uint8_t> rgb;
  for (int y = 0; y < kTexH; ++y)
    for (int x = 0; x < kTexW; ++x) {
      const auto t = texel(x, y);
      rgb.insert(rgb.end(), t.begin(), t.end());
    }
  auto png = encode_rgb_png(kTexW, kTexH, rgb.data());
  EXPECT_TRUE(png.ok());
  const float positions[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const uint16_t faces[6] = {0, 1, 2, 0, 2, 3};
  const float uv[4][2] = {{0, 0}, {uv_scale, 0}, {uv_scale, uv_scale}, {0, uv_scale}};
  const float color[4][3] = {{1, 0.5f, 1}, {1, 0.5f, 1}, {1, 0.5f, 1}, {1, 0.5f, 1}};
  std::string bin = bytes_of(positions, 48) + bytes_of(faces, 12) + bytes_of(uv, 32) + bytes_of(color, 48) +
                    std::string(png->begin(), png->end());
  json attributes = {{"POSITION", 0}, {"TEXCOORD_0", 2}};
  if (tint) attributes["COLOR_0"] = 3;
  json root = {{"asset", {{"version", "2.0"}}},
               {"scenes", {{{"nodes", {0}}}}},
               {"nodes", {{{"mesh", 0}}}},
               {"meshes", {{{"primitives", {{{"attributes", attributes}, {"indices", 1}, {"material", 0}}}}}}},
               {"materials", {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}}},
               {"textures", {{{"source", 0}, {"sampler", 0}}}},
               {"samplers", {{{"wrapS", wrap}, {"wrapT", wrap}}}},
               {"images", {{{"bufferView", 4}, {"mimeType", "image/png"}}}},
               {"accessors",
                {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
                 {{"bufferView", 1}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}},
                 {{"bufferView", 2}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}},
                 {{"bufferView", 3}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}}}},
               {"bufferViews",
                {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
                 {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 12}},
                 {{"buffer", 0}, {"byteOffset", 60}, {"byteLength", 32}},
                 {{"buffer", 0}, {"byteOffset", 92}, {"byteLength", 48}},
                 {{"buffer", 0}, {"byteOffset", 140}, {"byteLength", png->size()}}}},
               {"buffers", {{{"byteLength", bin.size()}}}}};
  std::string text = root.dump();
  while (text.size() % 4) text += ' ';
  while (bin.size() % 4) bin += '\0';
  auto u32 = [](uint32_t v) { return bytes_of(&v, 4); };
  return "glTF" + u32(2) + u32(uint32_t(28 + text.size() + bin.size())) + u32(uint32_t(text.size())) + "JSON" + text +
         u32(uint32_t(bin.size())) + std::string("BIN\0", 4) + bin;
}

Mesh read_quad(float uv_scale, int wrap, bool tint) {
  const std::string glb = textured_quad_glb(uv_scale, wrap, tint);
  auto mesh = parse_mesh(reinterpret_cast<const uint8_t*>(glb.data()), glb.size(), MeshFormat::kGltf);
  EXPECT_TRUE(mesh.ok()) << mesh.status().to_string();
  return mesh.ok() ? *mesh : Mesh();
}

// "Remeshed" vertices at the given (x, y), 0.01 above the quad: the closest
// point is straight below.
Mesh points_above(const std::vector<std::array<double, 2>>& xy, const Mesh& frame) {
  std::vector<double> absolute;
  for (const auto& p : xy) absolute.insert(absolute.end(), {p[0], p[1], 0.01});
  Mesh m;
  m.origin = frame.origin;
  m.scale = frame.scale;
  for (size_t i = 0; i < absolute.size(); ++i)
    m.positions.push_back(float((absolute[i] - frame.origin[i % 3]) / frame.scale));
  return m;
}

// Texel centres give the texel itself; halfway between two centres, their
// mean in linear light. The quad's frame is its own (origin at its centre).
TEST(ColorTransfer, TexturedQuadSamplesBilinearlyAtKnownPoints) {
  const Mesh quad = read_quad(1, 33071, false);
  ASSERT_FALSE(quad.textures.empty());
  std::vector<std::array<double, 2>> xy;
  for (int y = 0; y < kTexH; ++y)
    for (int x = 0; x < kTexW; ++x) xy.push_back({(x + 0.5) / kTexW, (y + 0.5) / kTexH});
  xy.push_back({2.0 / kTexW, 1.5 / kTexH});  // between texels (1, 1) and (2, 1)
  xy.push_back({2.0 / kTexW, 2.0 / kTexH});  // among texels (1, 1), (2, 1), (1, 2), (2, 2)
  xy.push_back({0.01, 0.99});                // clamped to texel (0, 3)
  std::vector<uint8_t> colors;
  ASSERT_TRUE(transfer_colors(quad, points_above(xy, quad), &colors).ok());
  ASSERT_EQ(colors.size(), 3 * xy.size());
  for (int y = 0; y < kTexH; ++y)
    for (int x = 0; x < kTexW; ++x)
      for (size_t c = 0; c < 3; ++c)
        EXPECT_EQ(colors[3 * size_t(y * kTexW + x) + c], texel(x, y)[c]) << "texel " << x << ", " << y;
  const size_t between = 3 * size_t(kTexW * kTexH);
  for (size_t c = 0; c < 3; ++c) {
    const double two = 0.5 * (srgb_to_linear(texel(1, 1)[c]) + srgb_to_linear(texel(2, 1)[c]));
    EXPECT_EQ(colors[between + c], srgb_from_linear(float(two))) << c;
    double four = 0;
    for (int dy = 1; dy <= 2; ++dy)
      for (int dx = 1; dx <= 2; ++dx) four += 0.25 * srgb_to_linear(texel(dx, dy)[c]);
    EXPECT_EQ(colors[between + 3 + c], srgb_from_linear(float(four))) << c;
    EXPECT_EQ(colors[between + 6 + c], texel(0, 3)[c]) << c;
  }
  // The red channel of the two-texel mean, by hand: linear(90) and linear(160)
  // are 0.1022 and 0.3515, their mean 0.2269 is sRGB 131 (not 125, the mean of the bytes).
  EXPECT_EQ(colors[between], 131);
}

// Coordinates 0..2 over the quad: REPEAT draws the texture twice, MIRRORED
// the second time flipped, CLAMP stretches its edge texels over the rest.
// Two points: u = 0.5 / W (texel 0's centre) and u = 1 + 0.5 / W, where
// REPEAT is at texel 0's centre again and the others at the last texel.
TEST(ColorTransfer, WrapModesOfTheSampler) {
  const double y = 0.25 / kTexH;  // v = 0.5 / H: the first row's centre
  for (int wrap : {10497, 33648, 33071}) {
    const Mesh quad = read_quad(2, wrap, false);
    std::vector<uint8_t> colors;
    ASSERT_TRUE(transfer_colors(quad, points_above({{0.25 / kTexW, y}, {0.5 + 0.25 / kTexW, y}}, quad), &colors).ok());
    const std::array<uint8_t, 3> second = wrap == 10497 ? texel(0, 0) : texel(kTexW - 1, 0);
    for (size_t c = 0; c < 3; ++c) {
      EXPECT_EQ(colors[c], texel(0, 0)[c]) << wrap;
      EXPECT_EQ(colors[3 + c], second[c]) << wrap;
    }
  }
}

// Texture x COLOR_0: (1, 0.5, 1) halves the green of every texel in linear light.
TEST(ColorTransfer, VertexColorsMultiplyTheTexture) {
  const Mesh quad = read_quad(1, 33071, true);
  ASSERT_EQ(quad.colors.size(), 12u);
  std::vector<uint8_t> colors;
  ASSERT_TRUE(transfer_colors(quad, points_above({{1.5 / kTexW, 2.5 / kTexH}}, quad), &colors).ok());
  const auto t = texel(1, 2);
  EXPECT_EQ(colors[0], t[0]);
  // COLOR_0's 0.5 became the byte 188 on reading; that byte is 0.5029 linear.
  EXPECT_EQ(colors[1], srgb_from_linear(srgb_to_linear(t[1]) * srgb_to_linear(188)));
  EXPECT_EQ(colors[2], t[2]);
}

TEST(ColorTransfer, SampleTextureWrapsAnyCoordinate) {
  BaseColorTexture t;
  auto image = std::make_shared<RgbImage>(2, 1);
  image->at(0, 0) = {0, 0, 0};
  image->at(1, 0) = {255, 255, 255};
  t.image = image;
  // u = 0.25 and 0.75 are the texel centres; REPEAT: 1.25, -0.75 and 1e12 + 0.25 are the same place.
  for (double u : {0.25, 1.25, -0.75, 1e12 + 0.25}) EXPECT_FLOAT_EQ(sample_texture(t, u, 0.5)[0], 0.0f) << u;
  EXPECT_FLOAT_EQ(sample_texture(t, 0.75, 0.5)[0], 1.0f);
  // At u = 0: halfway between the last texel (wrapped) and the first.
  EXPECT_FLOAT_EQ(sample_texture(t, 0.0, 0.5)[0], 0.5f);
  t.wrap_u = TextureWrap::kClampToEdge;
  EXPECT_FLOAT_EQ(sample_texture(t, 0.0, 0.5)[0], 0.0f);
  EXPECT_FLOAT_EQ(sample_texture(t, -5.0, 0.5)[0], 0.0f);
  EXPECT_FLOAT_EQ(sample_texture(t, 5.0, 0.5)[0], 1.0f);
  t.wrap_u = TextureWrap::kMirroredRepeat;
  EXPECT_FLOAT_EQ(sample_texture(t, 1.25, 0.5)[0], 1.0f);  // mirrored: 0.75
  EXPECT_FLOAT_EQ(sample_texture(t, -0.25, 0.5)[0], 0.0f);
  // Non-finite coordinates read as 0 instead of reaching an index.
  for (double bad : {NAN, INFINITY, -INFINITY}) {
    const std::array<float, 3> c = sample_texture(t, bad, bad);
    EXPECT_TRUE(std::isfinite(c[0]));
  }
}

TEST(ColorTransfer, SameColorsOnOneAndTwoThreads) {
  const Mesh sphere = gradient_sphere(4);
  Mesh output = testing::icosphere(5, 1.02f);  // 10242 vertices just outside
  std::vector<uint8_t> one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    ASSERT_TRUE(transfer_colors(sphere, output, &one).ok());
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    ASSERT_TRUE(transfer_colors(sphere, output, &two).ok());
  }
  EXPECT_EQ(one, two);
  EXPECT_EQ(one.size(), 3 * output.vertex_count());
}

}  // namespace
}  // namespace vpr
