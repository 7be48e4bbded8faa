// Writes the fuzzers' seed corpora (scripts/fuzz.sh runs it; the seeds are
// generated, not kept in git): small pieces of every model in MODELS_DIR (a
// patch of about 150 faces grown from one face, so each seed is a few KiB),
// generated shapes (spheres, two separate parts, an open grid, a soup, a
// point set), each in every reader's format and variants of it (ASCII and
// binary, both endians, quads, Draco's two codecs, with saliency, with vertex
// colors, glTF with a PNG or JPEG base-color texture), and the same shapes
// in the pipeline fuzzer's encoding (pipeline_input.h).
//   fuzz_seeds OUT_DIR MODELS_DIR [EXTRA_MESH...]
// writes OUT_DIR/{obj,ply,off,stl,draco,gltf,pipeline}/<name>.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <queue>
#include <string>
#include <vector>

#include "fuzz/pipeline_input.h"
#include "io/mesh_io.h"
#include "io/parsers.h"
#include "io/png_io.h"
#include "test_images.h"
#include "test_meshes.h"

namespace {

using namespace vpr;
namespace fs = std::filesystem;

constexpr size_t kPatchFaces = 100;

// The faces reached first by a breadth-first walk over shared vertices from
// face 0, re-indexed: a connected piece of the surface, creases and all.
Mesh patch(const Mesh& m, size_t max_faces) {
  std::vector<std::vector<uint32_t>> faces_of(m.vertex_count());
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int k = 0; k < 3; ++k) faces_of[m.indices[3 * f + k]].push_back(uint32_t(f));
  std::vector<bool> taken(m.face_count(), false);
  std::vector<uint32_t> order;
  std::queue<uint32_t> todo;
  todo.push(0);
  taken[0] = true;
  while (!todo.empty() && order.size() < max_faces) {
    const uint32_t f = todo.front();
    todo.pop();
    order.push_back(f);
    for (int k = 0; k < 3; ++k)
      for (uint32_t g : faces_of[m.indices[3 * f + k]])
        if (!taken[g]) {
          taken[g] = true;
          todo.push(g);
        }
  }
  Mesh out;
  std::map<uint32_t, uint32_t> remap;
  for (uint32_t f : order)
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = m.indices[3 * f + k];
      auto [it, inserted] = remap.try_emplace(v, uint32_t(out.vertex_count()));
      if (inserted) out.positions.insert(out.positions.end(), &m.positions[3 * v], &m.positions[3 * v + 3]);
      out.indices.push_back(it->second);
    }
  return out;
}

Mesh translated(Mesh m, float dx) {
  for (size_t v = 0; v < m.vertex_count(); ++v) m.positions[3 * v] += dx;
  return m;
}

Mesh merged(const Mesh& a, const Mesh& b) {
  Mesh out = a;
  const uint32_t offset = uint32_t(a.vertex_count());
  out.positions.insert(out.positions.end(), b.positions.begin(), b.positions.end());
  for (uint32_t i : b.indices) out.indices.push_back(i + offset);
  return out;
}

Mesh grid(int n) {
  Mesh m;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) m.positions.insert(m.positions.end(), {float(x), float(y), 0.1f * float(x * y % 3)});
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const uint32_t a = uint32_t(y * (n + 1) + x), b = a + 1, c = a + uint32_t(n) + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
    }
  return m;
}

void write(const fs::path& path, const std::string& text) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return;
  std::fwrite(text.data(), 1, text.size(), f);
  std::fclose(f);
}

void write(const fs::path& path, const std::vector<uint8_t>& bytes) {
  write(path, std::string(bytes.begin(), bytes.end()));
}

std::string number(float v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string ascii_ply(const Mesh& m) {
  std::string s = "ply\nformat ascii 1.0\ncomment fuzz seed\nelement vertex " + std::to_string(m.vertex_count()) +
                  "\nproperty float x\nproperty float y\nproperty float z\nproperty float saliency\n"
                  "element face " +
                  std::to_string(m.face_count()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (size_t v = 0; v < m.vertex_count(); ++v)
    s += number(m.positions[3 * v]) + " " + number(m.positions[3 * v + 1]) + " " + number(m.positions[3 * v + 2]) +
         " " + number(float(v % 10) / 10) + "\n";
  for (size_t f = 0; f < m.face_count(); ++f)
    s += "3 " + std::to_string(m.indices[3 * f]) + " " + std::to_string(m.indices[3 * f + 1]) + " " +
         std::to_string(m.indices[3 * f + 2]) + "\n";
  return s;
}

// Big-endian doubles, ushort-counted uint lists, and an extra element.
std::vector<uint8_t> big_endian_ply(const Mesh& m) {
  std::string h = "ply\nformat binary_big_endian 1.0\nelement vertex " + std::to_string(m.vertex_count()) +
                  "\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\n"
                  "element face " +
                  std::to_string(m.face_count()) +
                  "\nproperty list ushort uint vertex_indices\nelement edge 1\nproperty int vertex1\n"
                  "property int vertex2\nend_header\n";
  std::vector<uint8_t> out(h.begin(), h.end());
  auto put = [&](const void* p, size_t n) {
    const uint8_t* b = static_cast<const uint8_t*>(p);
    for (size_t i = 0; i < n; ++i) out.push_back(b[n - 1 - i]);
  };
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    for (int a = 0; a < 3; ++a) {
      const double d = m.positions[3 * v + a];
      put(&d, 8);
    }
    out.push_back(uint8_t(v));
  }
  for (size_t f = 0; f < m.face_count(); ++f) {
    const uint16_t three = 3;
    put(&three, 2);
    for (int k = 0; k < 3; ++k) put(&m.indices[3 * f + k], 4);
  }
  const int32_t edge[2] = {0, 1};
  put(&edge[0], 4);
  put(&edge[1], 4);
  return out;
}

// Quads where two consecutive triangles share an edge, negative indices and
// v/vt/vn corners elsewhere.
std::string fancy_obj(const Mesh& m) {
  std::string s = "# fuzz seed\nmtllib none.mtl\no piece\n";
  for (size_t v = 0; v < m.vertex_count(); ++v)
    s += "v " + number(m.positions[3 * v]) + " " + number(m.positions[3 * v + 1]) + " " +
         number(m.positions[3 * v + 2]) + (v % 2 ? " 1.0\n" : " 0.5 0.5 0.5\n");
  s += "vt 0 0\nvn 0 0 1\ng part\nusemtl none\ns 1\n";
  const long nv = long(m.vertex_count());
  for (size_t f = 0; f < m.face_count(); ++f) {
    const uint32_t* t = &m.indices[3 * f];
    switch (f % 3) {
      case 0:
        s += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) + " " + std::to_string(t[2] + 1) + "\n";
        break;
      case 1:
        s += "f " + std::to_string(long(t[0]) - nv) + "/1 " + std::to_string(long(t[1]) - nv) + "/1 " +
             std::to_string(long(t[2]) - nv) + "/1\n";
        break;
      default:
        s += "f " + std::to_string(t[0] + 1) + "/1/1 " + std::to_string(t[1] + 1) + "//1 " + std::to_string(t[2] + 1) +
             "/1/1 " + std::to_string(t[0] + 1) + "/1/1\n";  // a degenerate quad
    }
  }
  return s;
}

std::string off(const Mesh& m, bool colored) {
  std::string s = colored ? "COFF\n# fuzz seed\n" : "OFF\n";
  s += std::to_string(m.vertex_count()) + " " + std::to_string(m.face_count()) + " 0\n";
  for (size_t v = 0; v < m.vertex_count(); ++v)
    s += number(m.positions[3 * v]) + " " + number(m.positions[3 * v + 1]) + " " + number(m.positions[3 * v + 2]) +
         (colored ? " 255 0 0 255\n" : "\n");
  for (size_t f = 0; f < m.face_count(); ++f)
    s += "3 " + std::to_string(m.indices[3 * f]) + " " + std::to_string(m.indices[3 * f + 1]) + " " +
         std::to_string(m.indices[3 * f + 2]) + (colored ? " 0 255 0\n" : "\n");
  return s;
}

std::string ascii_stl(const Mesh& m) {
  std::string s = "solid seed\n";
  for (size_t f = 0; f < m.face_count(); ++f) {
    s += "  facet normal 0 0 1\n    outer loop\n";
    for (int k = 0; k < 3; ++k) {
      const float* p = &m.positions[3 * m.indices[3 * f + k]];
      s += "      vertex " + number(p[0]) + " " + number(p[1]) + " " + number(p[2]) + "\n";
    }
    s += "    endloop\n  endfacet\n";
  }
  return s + "endsolid seed\n";
}

std::vector<uint8_t> binary_stl(const Mesh& m) {
  std::vector<uint8_t> out(80, ' ');
  std::memcpy(out.data(), "solid binary header", 19);  // as some writers do
  const uint32_t n = uint32_t(m.face_count());
  for (int i = 0; i < 4; ++i) out.push_back(uint8_t(n >> (8 * i)));
  for (size_t f = 0; f < m.face_count(); ++f) {
    out.insert(out.end(), 12, 0);
    for (int k = 0; k < 3; ++k) {
      const uint8_t* b = reinterpret_cast<const uint8_t*>(&m.positions[3 * m.indices[3 * f + k]]);
      out.insert(out.end(), b, b + 12);
    }
    out.insert(out.end(), 2, 0);
  }
  return out;
}

void write_draco(const fs::path& base, const Mesh& m) {
  std::vector<float> saliency(m.vertex_count());
  for (size_t v = 0; v < saliency.size(); ++v) saliency[v] = float(v % 7) / 7;
  const struct {
    const char* suffix;
    int bits, speed;
    bool saliency;
  } variants[] = {
      {"-edgebreaker.drc", 14, 0, true}, {"-sequential.drc", 11, 10, false}, {"-lossless.drc", 0, 5, false}};
  for (const auto& v : variants) {
    DracoOptions o;
    o.position_bits = v.bits;
    o.speed = v.speed;
    auto bytes = encode_draco(m, v.saliency ? saliency.data() : nullptr, o);
    if (bytes.ok()) write(base.string() + v.suffix, *bytes);
  }
}

// Plain and Draco-compressed GLB, and .gltf text with a data: URI, with
// saliency as _SALIENCY.
void write_gltf(const fs::path& base, const Mesh& m) {
  std::vector<float> saliency(m.vertex_count());
  for (size_t v = 0; v < saliency.size(); ++v) saliency[v] = float(v % 5) / 5;
  DracoOptions plain;
  plain.gltf_draco = false;
  if (auto b = encode_gltf(m, saliency.data(), plain, true); b.ok()) write(base.string() + ".glb", *b);
  if (auto b = encode_gltf(m, nullptr, DracoOptions{}, true); b.ok()) write(base.string() + "-draco.glb", *b);
  if (auto b = encode_gltf(m, nullptr, plain, false); b.ok()) write(base.string() + ".gltf", *b);
}

// The shape with a color per vertex, from its position.
Mesh colored(Mesh m) {
  m.colors.resize(m.positions.size());
  for (size_t i = 0; i < m.positions.size(); ++i) m.colors[i] = uint8_t(int(m.positions[i] * 97.0f) & 255);
  return m;
}

// An 8 x 8 texture as PNG, or as JPEG (baseline or progressive).
std::vector<uint8_t> texture_rgb() {
  std::vector<uint8_t> rgb(8 * 8 * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = uint8_t(i * 37);
  return rgb;
}

std::string jpeg_texture(bool progressive) {
  const std::vector<uint8_t> jpeg = testing::encode_rgb_jpeg(8, 8, texture_rgb(), progressive, true);
  return std::string(jpeg.begin(), jpeg.end());
}

// A plain GLB whose primitive has TEXCOORD_0 (x, y of each vertex), COLOR_0
// (4 unsigned bytes) and a material with a factor, a transformed base-color
// texture and a sampler; the image in a bufferView.
std::string textured_glb(const Mesh& m, const std::string& image, const char* mime) {
  using json = nlohmann::json;
  const size_t nv = m.vertex_count();
  std::string bin(reinterpret_cast<const char*>(m.positions.data()), 12 * nv);
  bin.append(reinterpret_cast<const char*>(m.indices.data()), 4 * m.indices.size());
  for (size_t v = 0; v < nv; ++v) {
    const float uv[2] = {m.positions[3 * v], m.positions[3 * v + 1]};
    bin.append(reinterpret_cast<const char*>(uv), 8);
  }
  for (size_t v = 0; v < nv; ++v) bin += {char(v), char(3 * v), char(255), char(128)};
  const size_t at_image = bin.size();
  bin += image;
  const size_t offsets[5] = {0, 12 * nv, 12 * nv + 4 * m.indices.size(), 20 * nv + 4 * m.indices.size(), at_image};
  const size_t lengths[5] = {12 * nv, 4 * m.indices.size(), 8 * nv, 4 * nv, image.size()};
  json views = json::array();
  for (int i = 0; i < 5; ++i) views.push_back({{"buffer", 0}, {"byteOffset", offsets[i]}, {"byteLength", lengths[i]}});
  json root = {
      {"asset", {{"version", "2.0"}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 2}, {"COLOR_0", 3}}}, {"indices", 1}, {"material", 0}}}}}}},
      {"materials",
       {{{"pbrMetallicRoughness",
          {{"baseColorFactor", {1, 0.5, 0.25, 1}},
           {"baseColorTexture",
            {{"index", 0},
             {"extensions",
              {{"KHR_texture_transform", {{"offset", {0.5, 0}}, {"rotation", 0.3}, {"scale", {2, 2}}}}}}}}}}}}},
      {"textures", {{{"source", 0}, {"sampler", 0}}}},
      {"samplers", {{{"wrapS", 33648}, {"wrapT", 33071}}}},
      {"images", {{{"bufferView", 4}, {"mimeType", mime}}}},
      {"accessors",
       {{{"bufferView", 0}, {"componentType", 5126}, {"count", nv}, {"type", "VEC3"}},
        {{"bufferView", 1}, {"componentType", 5125}, {"count", m.indices.size()}, {"type", "SCALAR"}},
        {{"bufferView", 2}, {"componentType", 5126}, {"count", nv}, {"type", "VEC2"}},
        {{"bufferView", 3}, {"componentType", 5121}, {"normalized", true}, {"count", nv}, {"type", "VEC4"}}}},
      {"bufferViews", views},
      {"buffers", {{{"byteLength", bin.size()}}}}};
  std::string text = root.dump();
  while (text.size() % 4) text += ' ';
  while (bin.size() % 4) bin += '\0';
  auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  return "glTF" + u32(2) + u32(uint32_t(28 + text.size() + bin.size())) + u32(uint32_t(text.size())) + "JSON" + text +
         u32(uint32_t(bin.size())) + std::string("BIN\0", 4) + bin;
}

// Every format with vertex colors, and glTF with textures.
void write_colored(const fs::path& out, const std::string& name, const Mesh& plain) {
  const Mesh m = colored(plain);
  write(out / "obj" / (name + "-colors.obj"), io_detail::encode_obj(m, nullptr));
  write(out / "ply" / (name + "-colors.ply"), io_detail::encode_ply(m, nullptr));
  DracoOptions sequential;
  sequential.speed = 10;
  if (auto b = encode_draco(m, nullptr, sequential); b.ok()) write(out / "draco" / (name + "-colors.drc"), *b);
  DracoOptions plain_gltf;
  plain_gltf.gltf_draco = false;
  if (auto b = encode_gltf(m, nullptr, plain_gltf, true); b.ok()) write(out / "gltf" / (name + "-colors.glb"), *b);
  if (auto b = encode_gltf(m, nullptr, DracoOptions{}, true); b.ok())
    write(out / "gltf" / (name + "-colors-draco.glb"), *b);
  const std::vector<uint8_t> rgb = texture_rgb();
  if (auto png = encode_rgb_png(8, 8, rgb.data()); png.ok())
    write(out / "gltf" / (name + "-png.glb"), textured_glb(plain, std::string(png->begin(), png->end()), "image/png"));
  write(out / "gltf" / (name + "-jpeg.glb"), textured_glb(plain, jpeg_texture(false), "image/jpeg"));
  write(out / "gltf" / (name + "-progressive.glb"), textured_glb(plain, jpeg_texture(true), "image/jpeg"));
}

void write_pipeline(const fs::path& dir, const std::string& name, const Mesh& m) {
  fuzz::PipelineInput in;
  in.mesh = m.vertex_count() > fuzz::kMaxVertices ? patch(m, 2 * fuzz::kMaxVertices / 3) : m;
  const uint32_t n = uint32_t(in.mesh.vertex_count());
  in.target = std::max<uint32_t>(std::min<uint32_t>(2 * n, 150), 4);  // the pipeline's minimum is 100
  write(dir / (name + "-pipeline"), fuzz::encode(in));
  in.density = DensityMode::kPaper;
  write(dir / (name + "-pipeline-paper"), fuzz::encode(in));
  in.mode = fuzz::Mode::kPoints;
  in.seed = 8;  // slabs of 32 points
  write(dir / (name + "-points"), fuzz::encode(in));
  in.mode = fuzz::Mode::kSoup;
  in.seed = 0;
  write(dir / (name + "-soup"), fuzz::encode(in));
}

void write_all(const fs::path& out, const std::string& name, const Mesh& m) {
  write(out / "obj" / (name + ".obj"), io_detail::encode_obj(m, nullptr));
  write(out / "obj" / (name + "-fancy.obj"), fancy_obj(m));
  write(out / "ply" / (name + "-le.ply"), io_detail::encode_ply(m, nullptr));
  write(out / "ply" / (name + "-ascii.ply"), ascii_ply(m));
  write(out / "ply" / (name + "-be.ply"), big_endian_ply(m));
  write(out / "off" / (name + ".off"), off(m, false));
  write(out / "off" / (name + "-color.off"), off(m, true));
  write(out / "stl" / (name + "-ascii.stl"), ascii_stl(m));
  write(out / "stl" / (name + "-binary.stl"), binary_stl(m));
  write_draco(out / "draco" / name, m);
  write_gltf(out / "gltf" / name, m);
  write_colored(out, name, m);
  write_pipeline(out / "pipeline", name, m);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: fuzz_seeds OUT_DIR MODELS_DIR [EXTRA_MESH...]\n");
    return 2;
  }
  const fs::path out = argv[1];
  for (const char* d : {"obj", "ply", "off", "stl", "draco", "gltf", "pipeline"}) fs::create_directories(out / d);

  std::vector<std::pair<std::string, Mesh>> shapes;
  const Mesh sphere = testing::icosphere(2);
  shapes.push_back({"icosphere", sphere});
  shapes.push_back({"two-spheres", merged(sphere, translated(testing::icosphere(1, 0.5f), 3.0f))});
  shapes.push_back({"soup", testing::flipped_soup(testing::icosphere(1))});
  shapes.push_back({"grid", grid(8)});
  Mesh tetra;
  tetra.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  tetra.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  shapes.push_back({"tetrahedron", tetra});

  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(argv[2], ec))
    if (entry.is_regular_file()) files.push_back(entry.path());
  for (int i = 3; i < argc; ++i) files.push_back(argv[i]);
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    if (!format_from_path(file.string()).ok()) continue;
    auto mesh = read_mesh(file.string());
    if (!mesh.ok()) {
      std::fprintf(stderr, "fuzz_seeds: skipping %s\n", mesh.status().to_string().c_str());
      continue;
    }
    shapes.push_back({file.stem().string(), patch(*mesh, kPatchFaces)});
  }
  for (const auto& [name, mesh] : shapes) write_all(out, name, mesh);
  // A point set: the pipeline refuses it, mesh_points reconstructs it.
  fuzz::PipelineInput points;
  points.mode = fuzz::Mode::kPoints;
  points.mesh.positions = testing::icosphere(2).positions;
  write(out / "pipeline" / "icosphere-point-set", fuzz::encode(points));
  std::printf("fuzz_seeds: %zu shapes in %s\n", shapes.size(), out.c_str());
  return 0;
}
