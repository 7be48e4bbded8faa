// Mesh and PNG input/output: every format on synthetic files written here,
// broken and hostile bytes, and the shared models with their README counts.
#include "io/mesh_io.h"

#include <gtest/gtest.h>
#include <png.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "draco/compression/encode.h"
#include "draco/mesh/mesh.h"
#include "draco/point_cloud/point_cloud.h"
#include "io/png_io.h"

namespace vpr {
namespace {

namespace fs = std::filesystem;

// What our PLY and OBJ writers say when their colors are the saliency ramp.
constexpr const char* kRampComment = "vertex colors show saliency";

// ---- Helpers ---------------------------------------------------------------

class TempDir {
 public:
  TempDir() {
    static int counter = 0;
    path_ = fs::temp_directory_path() /
            ("vpr_mesh_io_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

StatusOr<Mesh> parse(const std::string& bytes, MeshFormat format, const MeshLimits& limits = {}) {
  return parse_mesh(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), format, limits);
}

// The unit-ish cube used throughout; coordinates include 0.1 and 1e-3, which
// are not exact in binary, so every text path must round the same way.
const float kCubeXs[2] = {-1.5f, 0.1f};
const float kCubeYs[2] = {0.0f, 2.25f};
const float kCubeZs[2] = {-3.0f, 1e-3f};

std::vector<std::array<double, 3>> cube_corners_text() {
  // The same values as decimal text reads them (doubles), before float rounding.
  const double xs[2] = {-1.5, 0.1}, ys[2] = {0.0, 2.25}, zs[2] = {-3.0, 1e-3};
  const int corner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  std::vector<std::array<double, 3>> out;
  for (auto& c : corner) out.push_back({xs[c[0]], ys[c[1]], zs[c[2]]});
  return out;
}

std::vector<float> cube_positions() {
  const int corner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  std::vector<float> p;
  for (auto& c : corner) {
    p.push_back(kCubeXs[c[0]]);
    p.push_back(kCubeYs[c[1]]);
    p.push_back(kCubeZs[c[2]]);
  }
  return p;
}

// Six outward quads, 0-based.
const int kCubeQuads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 4, 7, 3}, {1, 2, 6, 5}};

// Fan triangulation of the quads: (a b c), (a c d).
std::vector<uint32_t> cube_triangles() {
  std::vector<uint32_t> t;
  for (auto& q : kCubeQuads) {
    for (int k : {q[0], q[1], q[2], q[0], q[2], q[3]}) t.push_back(uint32_t(k));
  }
  return t;
}

Mesh cube_mesh() {
  Mesh m;
  m.positions = cube_positions();
  m.indices = cube_triangles();
  return m;
}

// UV sphere of radius 1: 2 poles + (rings - 1) * segments vertices.
Mesh uv_sphere(int rings, int segments) {
  Mesh m;
  const double pi = 3.14159265358979323846;
  m.positions = {0, 0, 1};
  for (int r = 1; r < rings; ++r) {
    const double theta = pi * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double phi = 2 * pi * s / segments;
      m.positions.push_back(float(std::sin(theta) * std::cos(phi)));
      m.positions.push_back(float(std::sin(theta) * std::sin(phi)));
      m.positions.push_back(float(std::cos(theta)));
    }
  }
  m.positions.insert(m.positions.end(), {0, 0, -1});
  const uint32_t south = uint32_t(m.vertex_count() - 1);
  auto ring = [&](int r, int s) { return uint32_t(1 + (r - 1) * segments + (s % segments)); };
  for (int s = 0; s < segments; ++s) m.indices.insert(m.indices.end(), {0, ring(1, s), ring(1, s + 1)});
  for (int r = 1; r + 1 < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      m.indices.insert(m.indices.end(), {ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)});
      m.indices.insert(m.indices.end(), {ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)});
    }
  }
  for (int s = 0; s < segments; ++s)
    m.indices.insert(m.indices.end(), {south, ring(rings - 1, s + 1), ring(rings - 1, s)});
  return m;
}

// Positions are scale-free floats in the mesh's frame (mesh.h): values read
// come back to within a float's precision of the bounding-box diagonal.
void expect_positions(const Mesh& mesh, const std::vector<float>& expected, const std::string& what) {
  ASSERT_EQ(mesh.positions.size(), expected.size()) << what;
  for (size_t i = 0; i < expected.size(); ++i)
    EXPECT_NEAR(mesh.absolute(i / 3, int(i % 3)), expected[i], 1e-7 * mesh.scale) << what << ", coordinate " << i;
}

void expect_cube(const StatusOr<Mesh>& mesh, const std::string& what) {
  ASSERT_TRUE(mesh.ok()) << what << ": " << mesh.status().to_string();
  EXPECT_EQ(mesh->vertex_count(), 8u) << what;
  EXPECT_EQ(mesh->face_count(), 12u) << what;
  expect_positions(*mesh, cube_positions(), what);
  EXPECT_EQ(mesh->indices, cube_triangles()) << what;
}

void expect_error(const StatusOr<Mesh>& mesh, StatusCode code, const std::string& needle) {
  ASSERT_FALSE(mesh.ok()) << "expected an error containing '" << needle << "'";
  EXPECT_EQ(mesh.status().code(), code) << mesh.status().to_string();
  EXPECT_NE(mesh.status().message().find(needle), std::string::npos)
      << "message '" << mesh.status().message() << "' lacks '" << needle << "'";
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// ---- format_from_path --------------------------------------------------------

TEST(FormatFromPath, KnownExtensionsAnyCase) {
  EXPECT_EQ(*format_from_path("a/b/mesh.DRC"), MeshFormat::kDraco);
  EXPECT_EQ(*format_from_path("mesh.obj"), MeshFormat::kObj);
  EXPECT_EQ(*format_from_path("mesh.Ply"), MeshFormat::kPly);
  EXPECT_EQ(*format_from_path("x.y.off"), MeshFormat::kOff);
  EXPECT_EQ(*format_from_path("mesh.STL"), MeshFormat::kStl);
  EXPECT_EQ(*format_from_path("scene.GLB"), MeshFormat::kGltf);
  EXPECT_EQ(*format_from_path("scene.gltf"), MeshFormat::kGltf);
}

TEST(FormatFromPath, UnknownExtensionNamesTheSupportedOnes) {
  auto f = format_from_path("mesh.xyz");
  ASSERT_FALSE(f.ok());
  EXPECT_EQ(f.status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(f.status().message(), "unsupported format '.xyz' (supported: .drc .glb .gltf .obj .ply .off .stl)");
  auto none = format_from_path("mesh");
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find("no file extension"), std::string::npos);
}

// ---- OBJ -----------------------------------------------------------------------

TEST(Obj, TokenFormsCommentsCrlfAndNegativeIndices) {
  std::string text = "# cube\r\nmtllib cube.mtl\r\no cube\r\n";
  const auto corners = cube_corners_text();
  for (size_t i = 0; i < corners.size(); ++i) {
    // Alternate plain, w, and r g b extras, all ignored.
    std::string extra = i % 3 == 1 ? " 1.0" : (i % 3 == 2 ? " 0.5 0.25 1" : "");
    text += "v " + fmt("%.17g", corners[i][0]) + " " + fmt("%.17g", corners[i][1]) + "\t" +
            fmt("%.17g", corners[i][2]) + extra + "\r\n";
  }
  text += "vt 0 0\r\nvt 1 0\r\nvn 0 0 1\r\ng faces\r\nusemtl red\r\ns off\r\n";
  // Quad 0 plain, 1 v/vt, 2 v//vn, 3 v/vt/vn, 4 negative, 5 mixed.
  auto q = kCubeQuads;
  text += "f " + std::to_string(q[0][0] + 1) + " " + std::to_string(q[0][1] + 1) + " " + std::to_string(q[0][2] + 1) +
          " " + std::to_string(q[0][3] + 1) + "\r\n";
  text += "f";
  for (int k = 0; k < 4; ++k) text += " " + std::to_string(q[1][k] + 1) + "/1";
  text += "\r\nf";
  for (int k = 0; k < 4; ++k) text += " " + std::to_string(q[2][k] + 1) + "//1";
  text += "\r\nf";
  for (int k = 0; k < 4; ++k) text += " " + std::to_string(q[3][k] + 1) + "/2/1";
  text += "\r\nf";
  for (int k = 0; k < 4; ++k) text += " " + std::to_string(q[4][k] - 8);  // -8 is vertex 0
  text += "\r\nf";
  for (int k = 0; k < 4; ++k)
    text += k % 2 ? " " + std::to_string(q[5][k] - 8) + "/1/1" : " " + std::to_string(q[5][k] + 1);
  text += "\r\n# end\r\n";
  expect_cube(parse(text, MeshFormat::kObj), "obj with every token form");
}

TEST(Obj, PolygonsBecomeFans) {
  // A hexagon (4 triangles), a pentagon (3) and a triangle (1).
  std::string text;
  for (int i = 0; i < 6; ++i)
    text += "v " + fmt("%.9g", std::cos(i * 1.0471975511965976)) + " " + fmt("%.9g", std::sin(i * 1.0471975511965976)) +
            " 0\n";
  text += "f 1 2 3 4 5 6\nf 1 2 3 4 5\nf 6 5 4\n";
  auto mesh = parse(text, MeshFormat::kObj);
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  EXPECT_EQ(mesh->face_count(), 8u);
  const std::vector<uint32_t> expected = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5, 0, 1, 2, 0, 2, 3, 0, 3, 4, 5, 4, 3};
  EXPECT_EQ(mesh->indices, expected);
}

TEST(Obj, SoupWithDuplicatedFlippedAndDegenerateFacesIsKept) {
  const std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 3\nf 3 2 1\nf 1 1 2\n";
  auto mesh = parse(text, MeshFormat::kObj);
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  EXPECT_EQ(mesh->face_count(), 4u);
  EXPECT_EQ(mesh->indices, (std::vector<uint32_t>{0, 1, 2, 0, 1, 2, 2, 1, 0, 0, 0, 1}));
}

TEST(Obj, IndexOutOfRangeNamesLineAndVertexCount) {
  std::string text = "# header\n";
  for (int i = 0; i < 8; ++i) text += "v " + std::to_string(i) + " " + std::to_string(i * i) + " 1\n";
  for (int i = 0; i < 7; ++i) text += "# filler\n";
  text += "f 1 2 9\n";  // line 17
  expect_error(parse(text, MeshFormat::kObj), StatusCode::kInvalidArgument,
               "OBJ line 17: face index 9 is out of range (the file has 8 vertices so far)");
  expect_error(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", MeshFormat::kObj), StatusCode::kInvalidArgument,
               "OBJ line 4: face index -4 is out of range (the file has 3 vertices so far)");
  expect_error(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", MeshFormat::kObj), StatusCode::kInvalidArgument,
               "OBJ line 4: face index 0 is invalid");
  // A face may only use vertices defined before it.
  expect_error(parse("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n", MeshFormat::kObj), StatusCode::kInvalidArgument,
               "line 3: face index 3 is out of range (the file has 2 vertices so far)");
}

TEST(Obj, MalformedLinesNameTheProblem) {
  expect_error(parse("v 0 0\n", MeshFormat::kObj), StatusCode::kInvalidArgument,
               "OBJ line 1: vertex has 2 coordinates, 3 are needed");
  expect_error(parse("v 0 0 zero\n", MeshFormat::kObj), StatusCode::kInvalidArgument,
               "OBJ line 1: vertex coordinate 'zero' is not a number");
  expect_error(parse("v 0 0 0\nv 1 0 0\nf 1 2\n", MeshFormat::kObj), StatusCode::kInvalidArgument,
               "OBJ line 3: face has 2 vertices, at least 3 are needed");
  expect_error(parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 x/1\n", MeshFormat::kObj), StatusCode::kInvalidArgument,
               "OBJ line 4: face vertex 'x/1' does not start with an integer index");
}

TEST(Obj, NanAndInfVerticesAreReportedByValidation) {
  expect_error(parse("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", MeshFormat::kObj), StatusCode::kInvalidArgument,
               "OBJ: vertex 1 has a non-finite coordinate");
  expect_error(parse("v 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n", MeshFormat::kObj), StatusCode::kInvalidArgument,
               "vertex 2 has a non-finite coordinate");
  // Underflow is not an error: 1e-50 reads as 0.
  auto tiny = parse("v 1e-50 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", MeshFormat::kObj);
  ASSERT_TRUE(tiny.ok()) << tiny.status().to_string();
  EXPECT_NEAR(tiny->absolute(0, 0), 0.0, 1e-7);
}

TEST(Obj, LimitsFailEarlyWithResourceExhausted) {
  MeshLimits limits;
  limits.max_vertices = 5;
  std::string text;
  for (int i = 0; i < 8; ++i) text += "v " + std::to_string(i) + " 0 " + std::to_string(i % 2) + "\n";
  expect_error(parse(text, MeshFormat::kObj, limits), StatusCode::kResourceExhausted,
               "OBJ line 6: the file has more than 5 vertices (the limit is 5)");
  limits = MeshLimits{};
  limits.max_faces = 3;
  expect_error(parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4 5 1 2\n", MeshFormat::kObj, limits),
               StatusCode::kResourceExhausted, "more than 3 triangles");
}

// ---- PLY -----------------------------------------------------------------------

enum class Enc { kAscii, kLittle, kBig };

// Appends one value of a PLY type, as text or bytes.
void put(std::string* out, const std::string& type, double v, Enc enc) {
  if (enc == Enc::kAscii) {
    if (type == "float" || type == "float32") {
      *out += fmt("%.9g", v);
    } else if (type == "double" || type == "float64") {
      *out += fmt("%.17g", v);
    } else {
      *out += std::to_string(int64_t(v));
    }
    *out += ' ';
    return;
  }
  unsigned char b[8];
  size_t n = 0;
  auto store = [&](auto value) {
    n = sizeof value;
    std::memcpy(b, &value, n);
  };
  if (type == "char" || type == "int8")
    store(int8_t(v));
  else if (type == "uchar" || type == "uint8")
    store(uint8_t(v));
  else if (type == "short" || type == "int16")
    store(int16_t(v));
  else if (type == "ushort" || type == "uint16")
    store(uint16_t(v));
  else if (type == "int" || type == "int32")
    store(int32_t(v));
  else if (type == "uint" || type == "uint32")
    store(uint32_t(v));
  else if (type == "float" || type == "float32")
    store(float(v));
  else
    store(double(v));
  if (enc == Enc::kBig) std::reverse(b, b + n);
  out->append(reinterpret_cast<char*>(b), n);
}

// The cube as PLY, with properties around the ones that matter: a double x, a
// uchar between x and y, a list on the vertices, an "edge" element between
// vertex and face, and face properties before and after the index list.
std::string cube_ply(Enc enc, const std::string& count_type, const std::string& index_type,
                     const std::string& list_name = "vertex_indices") {
  const auto corners = cube_corners_text();
  std::string h = "ply\n";
  h += enc == Enc::kAscii
           ? "format ascii 1.0\n"
           : (enc == Enc::kLittle ? "format binary_little_endian 1.0\n" : "format binary_big_endian 1.0\n");
  h += "comment synthetic cube\nobj_info generated by mesh_io_test\n";
  h += "element vertex 8\nproperty double x\nproperty uchar quality\nproperty float y\n";
  h += "property list uchar short neighbours\nproperty float z\nproperty int32 id\n";
  h += "element edge 2\nproperty int vertex1\nproperty int vertex2\n";
  h += "element face 6\nproperty uchar flags\nproperty list " + count_type + " " + index_type + " " + list_name +
       "\nproperty list uchar float texcoord\n";
  h += "element empty 3\n";
  h += "end_header\n";
  std::string body;
  for (int i = 0; i < 8; ++i) {
    put(&body, "double", corners[i][0], enc);
    put(&body, "uchar", 200 + i, enc);
    put(&body, "float", corners[i][1], enc);
    put(&body, "uchar", i % 3, enc);
    for (int k = 0; k < i % 3; ++k) put(&body, "short", -k, enc);
    put(&body, "float", corners[i][2], enc);
    put(&body, "int32", i * 1000, enc);
    if (enc == Enc::kAscii) body += "\n";
  }
  for (int e = 0; e < 2; ++e) {
    put(&body, "int", e, enc);
    put(&body, "int", e + 1, enc);
    if (enc == Enc::kAscii) body += "\n";
  }
  for (auto& q : kCubeQuads) {
    put(&body, "uchar", 7, enc);
    put(&body, count_type, 4, enc);
    for (int k = 0; k < 4; ++k) put(&body, index_type, q[k], enc);
    put(&body, "uchar", 2, enc);
    put(&body, "float", 0.5, enc);
    put(&body, "float", 0.25, enc);
    if (enc == Enc::kAscii) body += "\n";
  }
  return h + body;
}

TEST(Ply, AsciiLittleAndBigEndianWithExtraPropertiesGiveIdenticalMeshes) {
  const std::vector<std::pair<std::string, std::string>> list_types = {{"uchar", "int"},    {"uint8", "uint32"},
                                                                       {"ushort", "short"}, {"int", "uint"},
                                                                       {"char", "uchar"},   {"uint", "ushort"}};
  int parsed = 0;
  for (Enc enc : {Enc::kAscii, Enc::kLittle, Enc::kBig}) {
    for (const auto& [count_type, index_type] : list_types) {
      const std::string what = "PLY enc " + std::to_string(int(enc)) + " list " + count_type + " " + index_type;
      expect_cube(parse(cube_ply(enc, count_type, index_type), MeshFormat::kPly), what);
      ++parsed;
    }
  }
  expect_cube(parse(cube_ply(Enc::kLittle, "uchar", "int", "vertex_index"), MeshFormat::kPly), "vertex_index");
  EXPECT_EQ(parsed, 18);
}

TEST(Ply, CrlfHeaderIsAccepted) {
  std::string ply = cube_ply(Enc::kAscii, "uchar", "int");
  std::string crlf;
  for (char c : ply) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  expect_cube(parse(crlf, MeshFormat::kPly), "ascii PLY with CRLF");
}

std::string triangle_ply_header(const std::string& format, int vertices, int faces) {
  return "ply\nformat " + format + " 1.0\nelement vertex " + std::to_string(vertices) +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " + std::to_string(faces) +
         "\nproperty list uchar int vertex_indices\nend_header\n";
}

TEST(Ply, TruncatedBinarySaysHowFarItGot) {
  std::string ply = triangle_ply_header("binary_little_endian", 40, 1);
  for (int i = 0; i < 12; ++i) {
    for (int a = 0; a < 3; ++a) put(&ply, "float", i + a, Enc::kLittle);
  }
  put(&ply, "float", 1.0, Enc::kLittle);  // a partial 13th vertex
  expect_error(parse(ply, MeshFormat::kPly), StatusCode::kInvalidArgument, "PLY: file ends after 12 of 40 vertices");

  std::string faces = triangle_ply_header("binary_big_endian", 3, 5);
  for (int i = 0; i < 9; ++i) put(&faces, "float", i, Enc::kBig);
  put(&faces, "uchar", 3, Enc::kBig);
  for (int k = 0; k < 3; ++k) put(&faces, "int", k, Enc::kBig);
  put(&faces, "uchar", 3, Enc::kBig);
  put(&faces, "int", 0, Enc::kBig);
  expect_error(parse(faces, MeshFormat::kPly), StatusCode::kInvalidArgument, "PLY: file ends after 1 of 5 faces");

  std::string ascii = triangle_ply_header("ascii", 3, 1) + "0 0 0\n1 0 0\n";
  expect_error(parse(ascii, MeshFormat::kPly), StatusCode::kInvalidArgument, "PLY: file ends after 2 of 3 vertices");
}

TEST(Ply, HostileCountsFailWithoutReadingFurther) {
  // Declared counts beyond the limits: RESOURCE_EXHAUSTED before the body.
  expect_error(parse(triangle_ply_header("binary_little_endian", 2000000000, 1), MeshFormat::kPly),
               StatusCode::kResourceExhausted, "PLY: the header declares 2000000000 vertices, the limit is 20000000");
  std::string huge =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 9999999999999\nproperty list uchar int vertex_indices\nend_header\n";
  expect_error(parse(huge, MeshFormat::kPly), StatusCode::kResourceExhausted, "faces, the limit is 40000000");
  MeshLimits limits;
  limits.max_vertices = 50;
  expect_error(parse(cube_ply(Enc::kLittle, "uchar", "int"), MeshFormat::kPly, MeshLimits{10, 11}),
               StatusCode::kResourceExhausted, "PLY: the faces triangulate to more than 11 triangles");
  expect_error(parse(triangle_ply_header("ascii", 100, 1), MeshFormat::kPly, limits), StatusCode::kResourceExhausted,
               "the limit is 50");
  // Within the limits but far beyond the data: an error after the bytes that exist.
  std::string big = triangle_ply_header("binary_little_endian", 19000000, 1);
  for (int a = 0; a < 3; ++a) put(&big, "float", a, Enc::kLittle);
  expect_error(parse(big, MeshFormat::kPly), StatusCode::kInvalidArgument, "file ends after 1 of 19000000 vertices");
  // A list that claims more entries than the file holds.
  std::string list = triangle_ply_header("binary_little_endian", 3, 1);
  for (int i = 0; i < 9; ++i) put(&list, "float", i % 4, Enc::kLittle);
  put(&list, "uchar", 255, Enc::kLittle);
  put(&list, "int", 0, Enc::kLittle);
  expect_error(parse(list, MeshFormat::kPly), StatusCode::kInvalidArgument, "file ends after 0 of 1 faces");
}

TEST(Ply, BadHeadersAndIndicesNameTheProblem) {
  expect_error(parse("plyx\n", MeshFormat::kPly), StatusCode::kInvalidArgument, "does not start with the line 'ply'");
  expect_error(parse("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", MeshFormat::kPly),
               StatusCode::kInvalidArgument, "no end_header");
  expect_error(parse("ply\nformat binary_middle_endian 1.0\nend_header\n", MeshFormat::kPly),
               StatusCode::kInvalidArgument, "PLY header line 2: unknown format 'binary_middle_endian'");
  expect_error(parse("ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n", MeshFormat::kPly),
               StatusCode::kInvalidArgument, "PLY header line 4: unknown property type 'float128'");
  expect_error(parse("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
                     MeshFormat::kPly),
               StatusCode::kInvalidArgument, "no 'z' property");
  std::string no_list =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty int a\nend_header\n0 0 0\n1 0 0\n0 1 0\n1\n";
  expect_error(parse(no_list, MeshFormat::kPly), StatusCode::kInvalidArgument, "no vertex_indices");
  std::string out_of_range = triangle_ply_header("ascii", 3, 1) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n";
  expect_error(parse(out_of_range, MeshFormat::kPly), StatusCode::kInvalidArgument,
               "PLY: face 0 references vertex 3 but the file has 3 vertices");
  std::string negative = triangle_ply_header("ascii", 3, 1) + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n";
  expect_error(parse(negative, MeshFormat::kPly), StatusCode::kInvalidArgument, "references vertex -1");
  std::string word = triangle_ply_header("ascii", 3, 1) + "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n";
  expect_error(parse(word, MeshFormat::kPly), StatusCode::kInvalidArgument,
               "PLY line 11: 'zero' is not a number (vertex 1, property 'y')");
  std::string two = triangle_ply_header("ascii", 3, 1) + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n";
  expect_error(parse(two, MeshFormat::kPly), StatusCode::kInvalidArgument, "face 0 has 2 vertices");
}

TEST(Ply, PointCloudAndNanAreRejected) {
  std::string cloud =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "end_header\n0 0 0\n1 0 0\n0 1 0\n";
  expect_error(parse(cloud, MeshFormat::kPly), StatusCode::kInvalidArgument,
               "PLY: no faces: the input is a point cloud with 3 points");
  std::string nan = triangle_ply_header("binary_little_endian", 3, 1);
  for (int i = 0; i < 9; ++i) put(&nan, "float", i == 4 ? std::nan("") : double(i % 4), Enc::kLittle);
  put(&nan, "uchar", 3, Enc::kLittle);
  for (int k = 0; k < 3; ++k) put(&nan, "int", k, Enc::kLittle);
  expect_error(parse(nan, MeshFormat::kPly), StatusCode::kInvalidArgument, "vertex 1 has a non-finite coordinate");
}

// ---- OFF -----------------------------------------------------------------------

std::string cube_off_body(bool colors) {
  std::string s;
  for (const auto& c : cube_corners_text()) {
    s += fmt("%.17g", c[0]) + " " + fmt("%.17g", c[1]) + " " + fmt("%.17g", c[2]);
    s += colors ? " 0.5 0.5 1 1  # corner\n" : "\n";
  }
  for (auto& q : kCubeQuads) {
    s += "4 " + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " + std::to_string(q[2]) + " " +
         std::to_string(q[3]);
    s += colors ? " 255 0 0\n" : "\n";
  }
  return s;
}

TEST(Off, HeaderAndCountsVariantsGiveTheCube) {
  expect_cube(parse("OFF\n# a comment\n8 6 12\n" + cube_off_body(false), MeshFormat::kOff), "OFF, counts line");
  expect_cube(parse("OFF 8 6 0\n" + cube_off_body(false), MeshFormat::kOff), "counts on the OFF line");
  expect_cube(parse("# no keyword\n\n8 6\n" + cube_off_body(false), MeshFormat::kOff), "no OFF keyword, 2 counts");
  expect_cube(parse("COFF\n8 6 0\n" + cube_off_body(true), MeshFormat::kOff), "COFF with colors");
  expect_cube(parse("nOFF\n3\n8 6 0\n" + cube_off_body(false), MeshFormat::kOff), "nOFF with dimension 3");
  std::string crlf;
  for (char c : "OFF\n8 6 0\n" + cube_off_body(false)) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  expect_cube(parse(crlf, MeshFormat::kOff), "OFF with CRLF");
}

TEST(Off, ErrorsNameTheLine) {
  expect_error(parse("OFF\n8 6 0\n0 0 0\n", MeshFormat::kOff), StatusCode::kInvalidArgument,
               "OFF: file ends after 1 of 8 vertices");
  expect_error(parse("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", MeshFormat::kOff), StatusCode::kInvalidArgument,
               "OFF line 6: face index 7 is out of range (the file has 3 vertices)");
  expect_error(parse("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", MeshFormat::kOff), StatusCode::kInvalidArgument,
               "OFF: file ends after 1 of 2 faces");
  expect_error(parse("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", MeshFormat::kOff), StatusCode::kInvalidArgument,
               "face announces 4 vertices but lists 3");
  expect_error(parse("OFF\nmany faces\n", MeshFormat::kOff), StatusCode::kInvalidArgument,
               "OFF line 2: expected the counts");
  expect_error(parse("4OFF\n", MeshFormat::kOff), StatusCode::kInvalidArgument, "4D vertices are not supported");
  expect_error(parse("OFF BINARY\n", MeshFormat::kOff), StatusCode::kInvalidArgument, "binary OFF is not supported");
  expect_error(parse("OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", MeshFormat::kOff), StatusCode::kInvalidArgument,
               "point cloud");
  MeshLimits limits;
  limits.max_faces = 5;
  expect_error(parse("OFF\n8 6 0\n" + cube_off_body(false), MeshFormat::kOff, limits), StatusCode::kResourceExhausted,
               "OFF: the header declares 6 faces, the limit is 5");
  expect_error(parse("OFF\n3000000000 1 0\n", MeshFormat::kOff), StatusCode::kResourceExhausted, "3000000000 vertices");
}

// ---- STL -----------------------------------------------------------------------

std::string cube_stl_ascii() {
  const std::vector<float> p = cube_positions();
  const std::vector<uint32_t> t = cube_triangles();
  std::string s = "solid cube made by the test\n";
  for (size_t f = 0; f < t.size() / 3; ++f) {
    s += "  facet normal 0 0 0\n    outer loop\n";
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = t[3 * f + k];
      s += "      vertex " + fmt("%.9g", p[3 * v]) + " " + fmt("%.9g", p[3 * v + 1]) + " " + fmt("%.9g", p[3 * v + 2]) +
           "\n";
    }
    s += "    endloop\n  endfacet\n";
  }
  return s + "endsolid cube\n";
}

std::string cube_stl_binary() {
  const std::vector<float> p = cube_positions();
  const std::vector<uint32_t> t = cube_triangles();
  // A header that starts with "solid", as many binary writers do.
  std::string s = "solid binary header that must not fool the reader";
  s.resize(80, ' ');
  const uint32_t n = uint32_t(t.size() / 3);
  s.append(reinterpret_cast<const char*>(&n), 4);  // the test machine is little-endian
  for (uint32_t f = 0; f < n; ++f) {
    const float normal[3] = {0, 0, 1};
    s.append(reinterpret_cast<const char*>(normal), 12);
    for (int k = 0; k < 3; ++k) s.append(reinterpret_cast<const char*>(&p[3 * t[3 * f + k]]), 12);
    s += std::string(2, '\0');
  }
  return s;
}

TEST(Stl, BinaryAndAsciiGiveTheSameMergedMesh) {
  const std::string binary = cube_stl_binary();
  ASSERT_EQ(binary.size(), 84u + 50u * 12u);
  auto b = parse(binary, MeshFormat::kStl);
  auto a = parse(cube_stl_ascii(), MeshFormat::kStl);
  ASSERT_TRUE(b.ok()) << b.status().to_string();
  ASSERT_TRUE(a.ok()) << a.status().to_string();
  // 36 corners merge into the 8 distinct positions, in first-occurrence order.
  EXPECT_EQ(b->vertex_count(), 8u);
  EXPECT_EQ(b->face_count(), 12u);
  expect_positions(*a, absolute_positions(*b), "ASCII against binary");
  EXPECT_EQ(a->indices, b->indices);
  // First occurrences follow the triangle list: 0, 3, 2, 1, 4, 5, ...
  const std::vector<float> cube = cube_positions();
  const std::vector<uint32_t> tri = cube_triangles();
  std::vector<int> order;
  for (uint32_t v : tri) {
    if (std::find(order.begin(), order.end(), int(v)) == order.end()) order.push_back(int(v));
  }
  for (size_t i = 0; i < 8; ++i) {
    for (int a3 = 0; a3 < 3; ++a3) EXPECT_NEAR(b->absolute(i, a3), cube[3 * order[i] + a3], 1e-6);
  }
  for (size_t c = 0; c < tri.size(); ++c) EXPECT_EQ(order[b->indices[c]], int(tri[c]));
}

TEST(Stl, SoupFacetsAreKeptAndPolygonLoopsFan) {
  std::string s = "solid soup\n";
  auto facet = [&](std::vector<std::array<float, 3>> vs) {
    s += "facet normal 0 0 1\nouter loop\n";
    for (auto& v : vs) s += "vertex " + fmt("%.9g", v[0]) + " " + fmt("%.9g", v[1]) + " " + fmt("%.9g", v[2]) + "\n";
    s += "endloop\nendfacet\n";
  };
  facet({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
  facet({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});             // duplicate
  facet({{0, -0.0f, 0}, {0, 1, 0}, {1, 0, 0}});         // flipped, with -0
  facet({{0, 0, 0}, {0, 0, 0}, {1, 0, 0}});             // degenerate
  facet({{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}});  // quad loop
  s += "endsolid soup\n";
  auto mesh = parse(s, MeshFormat::kStl);
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  EXPECT_EQ(mesh->face_count(), 6u);
  EXPECT_EQ(mesh->vertex_count(), 7u);
  EXPECT_EQ(mesh->indices, (std::vector<uint32_t>{0, 1, 2, 0, 1, 2, 0, 2, 1, 0, 0, 1, 3, 4, 5, 3, 5, 6}));
}

TEST(Stl, BrokenFilesNameTheProblem) {
  std::string wrong_size = cube_stl_binary();
  wrong_size.resize(wrong_size.size() - 7);
  wrong_size[0] = 'X';  // not "solid" either
  expect_error(parse(wrong_size, MeshFormat::kStl), StatusCode::kInvalidArgument,
               "the header declares 12 facets, which take 684 bytes, but the file has 677");
  expect_error(
      parse("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n", MeshFormat::kStl),
      StatusCode::kInvalidArgument, "STL line 6: facet has 2 vertices");
  expect_error(parse("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n", MeshFormat::kStl),
               StatusCode::kInvalidArgument, "file ends inside a facet");
  expect_error(parse("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\n",
                     MeshFormat::kStl),
               StatusCode::kInvalidArgument, "STL: the file ends after 1 triangles without 'endsolid' (truncated?)");
  expect_error(parse("solid x\nouter loop\nvertex 0 0 0\nvertex 1 0 O\n", MeshFormat::kStl),
               StatusCode::kInvalidArgument, "STL line 4: vertex coordinate 'O' is not a number");
  expect_error(parse("solid empty\nendsolid empty\n", MeshFormat::kStl), StatusCode::kInvalidArgument,
               "empty mesh: no vertices");
  std::string inf = cube_stl_ascii();
  inf.replace(inf.find("vertex ") + 7, 4, "inf ");
  expect_error(parse(inf, MeshFormat::kStl), StatusCode::kInvalidArgument, "non-finite coordinate");
  expect_error(parse(cube_stl_binary(), MeshFormat::kStl, MeshLimits{100, 10}), StatusCode::kResourceExhausted,
               "STL: 12 facets, the limit is 10 faces");
}

// ---- Writers and round trips -----------------------------------------------------

TEST(RoundTrip, ObjAndPlyAreExact) {
  TempDir dir;
  const Mesh cube = cube_mesh();
  for (const char* name : {"cube.obj", "cube.ply"}) {
    const std::string path = dir.file(name);
    ASSERT_TRUE(write_mesh(path, cube, nullptr).ok()) << name;
    expect_cube(read_mesh(path), name);
  }
  // Binary PLY: header + 8 * 12 + 12 * 13 bytes.
  const std::string ply = read_bytes(dir.file("cube.ply"));
  const size_t header = ply.find("end_header\n") + 11;
  EXPECT_EQ(ply.size() - header, 8u * 12u + 12u * 13u);
}

TEST(RoundTrip, SaliencyInPlyAndObj) {
  TempDir dir;
  const Mesh cube = cube_mesh();
  const std::vector<float> saliency = {0.0f, 0.125f, 0.25f, 0.5f, 0.75f, 1.0f, 0.3f, 0.99f};
  ASSERT_TRUE(write_mesh(dir.file("s.ply"), cube, saliency.data()).ok());
  auto back = read_saliency(dir.file("s.ply"));
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(*back, saliency);
  expect_cube(read_mesh(dir.file("s.ply")), "PLY with saliency and colors");
  // Vertex 1 record: x y z saliency r g b right after the header.
  const std::string ply = read_bytes(dir.file("s.ply"));
  const size_t body = ply.find("end_header\n") + 11;
  uint8_t rgb[3];
  saliency_color(saliency[1], rgb);
  EXPECT_EQ(uint8_t(ply[body + 19 + 16]), rgb[0]);
  EXPECT_EQ(uint8_t(ply[body + 19 + 17]), rgb[1]);
  EXPECT_EQ(uint8_t(ply[body + 19 + 18]), rgb[2]);

  ASSERT_TRUE(write_mesh(dir.file("s.obj"), cube, saliency.data()).ok());
  expect_cube(read_mesh(dir.file("s.obj")), "OBJ with vertex colors");
  const std::string obj = read_bytes(dir.file("s.obj"));
  // saliency 1.0 is red: "1 0 0" at the end of vertex 5's line.
  const std::string v5 = "v 0.1 0 0.001 1 0 0\n";
  EXPECT_NE(obj.find(v5), std::string::npos) << obj;
  auto none = read_saliency(dir.file("s.obj"));
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

TEST(RoundTrip, WriterErrors) {
  TempDir dir;
  const Mesh cube = cube_mesh();
  Status s = write_mesh(dir.file("cube.xyz"), cube, nullptr);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("(supported: .drc .glb .gltf .obj .ply .off .stl)"), std::string::npos) << s.message();
  s = write_mesh(dir.file("cube.stl"), cube, nullptr);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("output formats: .drc .glb .gltf .obj .ply"), std::string::npos) << s.message();
  s = write_mesh(dir.file("missing_dir/cube.ply"), cube, nullptr);
  EXPECT_EQ(s.code(), StatusCode::kNotFound) << s.to_string();
  Mesh bad = cube;
  bad.indices[5] = 8;
  s = write_mesh(dir.file("bad.ply"), bad, nullptr);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("face 1 references vertex 8"), std::string::npos) << s.message();
  const std::vector<float> nan_saliency(8, std::nanf(""));
  s = write_mesh(dir.file("bad.drc"), cube, nan_saliency.data());
  EXPECT_NE(s.message().find("saliency of vertex 0 is not finite"), std::string::npos) << s.message();
  DracoOptions options;
  options.position_bits = 31;
  s = write_mesh(dir.file("bad.drc"), cube, nullptr, options);
  EXPECT_NE(s.message().find("position_bits is 31"), std::string::npos) << s.message();
}

TEST(RoundTrip, MissingFileIsNotFound) {
  auto mesh = read_mesh("../shared/models/no_such_mesh.obj");
  ASSERT_FALSE(mesh.ok());
  EXPECT_EQ(mesh.status().code(), StatusCode::kNotFound);
  EXPECT_NE(mesh.status().message().find("no_such_mesh.obj"), std::string::npos);
}

TEST(RoundTrip, EmptyInputForEveryFormat) {
  for (MeshFormat f : {MeshFormat::kDraco, MeshFormat::kObj, MeshFormat::kPly, MeshFormat::kOff, MeshFormat::kStl})
    expect_error(parse("", f), StatusCode::kInvalidArgument, "the input is empty (0 bytes)");
  expect_error(parse("# only a comment\n\n", MeshFormat::kObj), StatusCode::kInvalidArgument,
               "empty mesh: no vertices");
  TempDir dir;
  write_bytes(dir.file("empty.off"), "");
  auto mesh = read_mesh(dir.file("empty.off"));
  ASSERT_FALSE(mesh.ok());
  EXPECT_NE(mesh.status().message().find("empty.off: OFF: the input is empty"), std::string::npos)
      << mesh.status().message();
}

// ---- Draco -----------------------------------------------------------------------

// Half a quantization step of Draco's quantizer: values map to
// round((v - min) / range * (2^bits - 1)), so a value moves by at most
// range / (2^bits - 1) / 2 (plus float rounding, the 1e-6 relative slack).
double quantization_bound(double range, int bits) {
  return 0.5 * range / double((1 << bits) - 1) * (1 + 1e-6) + 1e-7;
}

TEST(Draco, CubeRoundTrip) {
  TempDir dir;
  const Mesh cube = cube_mesh();
  ASSERT_TRUE(write_mesh(dir.file("cube.drc"), cube, nullptr).ok());
  auto back = read_mesh(dir.file("cube.drc"));
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->vertex_count(), 8u);
  EXPECT_EQ(back->face_count(), 12u);
  const double bound = quantization_bound(3.001, 14);  // the z range is the largest
  for (size_t i = 0; i < back->vertex_count(); ++i) {
    double best = 1e9;
    for (size_t j = 0; j < 8; ++j) {
      double d = 0;
      for (int a = 0; a < 3; ++a)
        d = std::max(d, std::fabs(back->absolute(i, a) - cube.absolute(j, a)));
      best = std::min(best, d);
    }
    EXPECT_LE(best, bound) << "vertex " << i;
  }
  EXPECT_NEAR(total_area(*back) * back->scale * back->scale, total_area(cube), 1e-3 * total_area(cube));
}

TEST(Draco, SaliencyRoundTripWithinQuantization) {
  TempDir dir;
  const Mesh sphere = uv_sphere(16, 24);
  ASSERT_EQ(sphere.vertex_count(), 2u + 15u * 24u);
  std::vector<float> saliency(sphere.vertex_count());
  for (size_t i = 0; i < saliency.size(); ++i) saliency[i] = 0.5f + 0.5f * sphere.positions[3 * i + 2];
  DracoOptions options;  // 14 position bits, 10 saliency bits
  ASSERT_TRUE(write_mesh(dir.file("sphere.drc"), sphere, saliency.data(), options).ok());
  auto back = read_mesh(dir.file("sphere.drc"));
  auto back_saliency = read_saliency(dir.file("sphere.drc"));
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  ASSERT_TRUE(back_saliency.ok()) << back_saliency.status().to_string();
  ASSERT_EQ(back->vertex_count(), sphere.vertex_count());
  ASSERT_EQ(back->face_count(), sphere.face_count());
  ASSERT_EQ(back_saliency->size(), back->vertex_count());

  // Positions span [-1, 1]: bound 6.1e-5; saliency spans [0, 1]: bound 4.9e-4.
  const double position_bound = quantization_bound(2.0, options.position_bits);
  const double saliency_bound = quantization_bound(1.0, options.saliency_bits);
  EXPECT_NEAR(position_bound, 6.1e-5, 1e-6);
  EXPECT_NEAR(saliency_bound, 4.89e-4, 1e-6);
  // Draco reorders vertices: match each decoded one to its nearest original.
  std::vector<uint32_t> original(back->vertex_count());
  double worst_position = 0, worst_saliency = 0;
  for (size_t i = 0; i < back->vertex_count(); ++i) {
    double best = 1e9;
    for (size_t j = 0; j < sphere.vertex_count(); ++j) {
      double d = 0;
      for (int a = 0; a < 3; ++a)
        d = std::max(d, std::fabs(back->absolute(i, a) - sphere.absolute(j, a)));
      if (d < best) {
        best = d;
        original[i] = uint32_t(j);
      }
    }
    worst_position = std::max(worst_position, best);
    worst_saliency = std::max(worst_saliency, double(std::fabs((*back_saliency)[i] - saliency[original[i]])));
  }
  EXPECT_LE(worst_position, position_bound);
  EXPECT_LE(worst_saliency, saliency_bound);
  EXPECT_GT(worst_saliency, 0.0);  // it really was quantized
  // Every decoded triangle is an original one (same orientation, any rotation).
  auto canonical = [](uint32_t a, uint32_t b, uint32_t c) {
    if (b < a && b < c) return std::array<uint32_t, 3>{b, c, a};
    if (c < a && c < b) return std::array<uint32_t, 3>{c, a, b};
    return std::array<uint32_t, 3>{a, b, c};
  };
  std::multiset<std::array<uint32_t, 3>> faces, decoded;
  for (size_t f = 0; f < sphere.face_count(); ++f)
    faces.insert(canonical(sphere.indices[3 * f], sphere.indices[3 * f + 1], sphere.indices[3 * f + 2]));
  for (size_t f = 0; f < back->face_count(); ++f)
    decoded.insert(canonical(original[back->indices[3 * f]], original[back->indices[3 * f + 1]],
                             original[back->indices[3 * f + 2]]));
  EXPECT_TRUE(faces == decoded);
}

TEST(Draco, EncodingIsDeterministicAndSpeedTenIsSequential) {
  const Mesh sphere = uv_sphere(8, 12);
  std::vector<float> s(sphere.vertex_count(), 0.25f);
  auto a = encode_draco(sphere, s.data(), DracoOptions{});
  auto b = encode_draco(sphere, s.data(), DracoOptions{});
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(*a, *b);
  DracoOptions fast;
  fast.speed = 10;
  auto c = encode_draco(sphere, nullptr, fast);
  ASSERT_TRUE(c.ok());
  EXPECT_EQ((*c)[8], 0) << "speed 10 uses the sequential method";
  EXPECT_EQ((*a)[8], 1) << "the default speed uses edgebreaker";
  auto decoded = parse_mesh(c->data(), c->size(), MeshFormat::kDraco);
  ASSERT_TRUE(decoded.ok()) << decoded.status().to_string();
  EXPECT_EQ(decoded->face_count(), sphere.face_count());
}

TEST(Draco, SequentialKeepsSoupsEdgebreakerDropsDegenerateFaces) {
  Mesh soup;
  soup.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
  soup.indices = {0, 1, 2, 0, 1, 2, 2, 1, 0, 0, 0, 1, 1, 3, 2};  // duplicate, flipped, degenerate
  DracoOptions sequential;
  sequential.speed = 10;
  auto a = encode_draco(soup, nullptr, sequential);
  ASSERT_TRUE(a.ok());
  auto kept = parse_mesh(a->data(), a->size(), MeshFormat::kDraco);
  ASSERT_TRUE(kept.ok()) << kept.status().to_string();
  EXPECT_EQ(kept->indices, soup.indices);
  expect_positions(*kept, soup.positions, "sequential");  // 0 and 1 are exact at any bit count
  auto b = encode_draco(soup, nullptr, DracoOptions{});
  ASSERT_TRUE(b.ok());
  auto edgebreaker = parse_mesh(b->data(), b->size(), MeshFormat::kDraco);
  ASSERT_TRUE(edgebreaker.ok()) << edgebreaker.status().to_string();
  EXPECT_EQ(edgebreaker->face_count(), 4u);     // the degenerate face is gone
  EXPECT_EQ(edgebreaker->vertex_count(), 10u);  // non-manifold vertices split
}

std::string draco_point_cloud() {
  draco::PointCloud pc;
  pc.set_num_points(4);
  draco::GeometryAttribute ga;
  ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 12, 0);
  const int id = pc.AddAttribute(ga, true, 4);
  const float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int i = 0; i < 4; ++i) pc.attribute(id)->SetAttributeValue(draco::AttributeValueIndex(i), p[i]);
  draco::Encoder encoder;
  draco::EncoderBuffer buffer;
  EXPECT_TRUE(encoder.EncodePointCloudToBuffer(pc, &buffer).ok());
  return std::string(buffer.data(), buffer.size());
}

// One attribute of a Draco triangle: 3 values of `size` bytes each.
struct DracoValues {
  draco::GeometryAttribute::Type kind;
  draco::DataType type;
  int components;
  bool normalized;
  const void* values;
  size_t size;
};

// A triangle of the given attributes, sequential and unquantized, so the
// values arrive as they are.
std::string draco_triangle_of(std::initializer_list<DracoValues> attributes) {
  draco::Mesh mesh;
  mesh.set_num_points(3);
  for (const DracoValues& a : attributes) {
    draco::GeometryAttribute ga;
    ga.Init(a.kind, nullptr, int8_t(a.components), a.type, a.normalized, int64_t(a.size), 0);
    const int id = mesh.AddAttribute(ga, true, 3);
    for (int i = 0; i < 3; ++i)
      mesh.attribute(id)->SetAttributeValue(draco::AttributeValueIndex(i),
                                            static_cast<const char*>(a.values) + i * a.size);
  }
  mesh.SetNumFaces(1);
  mesh.SetFace(draco::FaceIndex(0), {draco::PointIndex(0), draco::PointIndex(1), draco::PointIndex(2)});
  draco::Encoder encoder;
  encoder.SetSpeedOptions(10, 10);
  draco::EncoderBuffer buffer;
  EXPECT_TRUE(encoder.EncodeMeshToBuffer(mesh, &buffer).ok());
  return std::string(buffer.data(), buffer.size());
}

// A triangle whose positions Draco stores with the given type.
template <class T>
std::string draco_triangle(draco::DataType type, const T (&p)[3][3]) {
  return draco_triangle_of({{draco::GeometryAttribute::POSITION, type, 3, false, p, 3 * sizeof(T)}});
}

// Found by draco_fuzzer: Draco converts a stored value to float with a plain
// cast, so booleans (any byte loaded as a bool) and doubles beyond the float
// range were undefined behaviour. Both are refused; integer types still read.
TEST(Draco, BooleanOrOutOfRangePositionsAreInvalidArgument) {
  const std::string fuzzed(
      "\x44\x52\x41\x43\x4f\x02\x02\x01\x01\x00\x00\x00\x04\x04\x00\x03\x00\x00\x01\x2f\x01\x01\x10\x01\xff"
      "\x00\x00\x01\x00\x0b\x03\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x3f\x00\x00\x00\x23"
      "\x3f\x00\x00\x00\x00\x00\x00\x00\x00",
      59);
  expect_error(parse(fuzzed, MeshFormat::kDraco), StatusCode::kInvalidArgument,
               "Draco: the position attribute has data type 11, a numeric type is needed");
  const bool bits[3][3] = {{false, false, false}, {true, false, false}, {false, true, false}};
  expect_error(parse(draco_triangle(draco::DT_BOOL, bits), MeshFormat::kDraco), StatusCode::kInvalidArgument,
               "a numeric type is needed");
  const double huge[3][3] = {{0, 0, 0}, {1e300, 0, 0}, {0, 1, 0}};
  expect_error(parse(draco_triangle(draco::DT_FLOAT64, huge), MeshFormat::kDraco), StatusCode::kInvalidArgument,
               "non-finite coordinate");
  const int16_t steps[3][3] = {{0, 0, 0}, {-7, 0, 0}, {0, 300, 0}};
  auto mesh = parse(draco_triangle(draco::DT_INT16, steps), MeshFormat::kDraco);
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  expect_positions(*mesh, {0, 0, 0, -7, 0, 0, 0, 300, 0}, "int16 positions");
}

TEST(Draco, PointCloudAndCorruptBytesAreInvalidArgument) {
  expect_error(parse(draco_point_cloud(), MeshFormat::kDraco), StatusCode::kInvalidArgument,
               "no faces: the input is a point cloud");
  expect_error(parse("not a draco file at all", MeshFormat::kDraco), StatusCode::kInvalidArgument,
               "does not start with 'DRACO'");
  const Mesh sphere = uv_sphere(8, 12);
  auto encoded = encode_draco(sphere, nullptr, DracoOptions{});
  ASSERT_TRUE(encoded.ok());
  const std::string good(encoded->begin(), encoded->end());
  expect_error(parse(good.substr(0, good.size() / 2), MeshFormat::kDraco), StatusCode::kInvalidArgument,
               "Draco: cannot decode the mesh");
  expect_error(parse(good.substr(0, 9), MeshFormat::kDraco), StatusCode::kInvalidArgument, "ends inside the header");
  std::string version = good;
  version[5] = 9;
  expect_error(parse(version, MeshFormat::kDraco), StatusCode::kInvalidArgument,
               "bitstream version 9.2 is not supported");
  expect_error(parse(good, MeshFormat::kDraco, MeshLimits{1000, 10}), StatusCode::kResourceExhausted,
               "Draco: the header declares 168 faces, the limit is 10");
  // A million faces declared in 30 bytes.
  std::string dense = std::string("DRACO\x02\x02\x01\x00\x00\x00", 11) + std::string("\xc0\x84\x3d\x03", 4);
  dense.resize(30, '\0');
  expect_error(parse(dense, MeshFormat::kDraco), StatusCode::kInvalidArgument,
               "declares 1000000 faces in 30 bytes, more than 1000 per byte");
  // Metadata that claims a 4 GB entry, and metadata nested 1000 levels deep.
  std::string header = good.substr(0, 9) + std::string("\x00\x80", 2);
  header[8] = 0;  // sequential
  std::string big_entry = header + std::string("\x00\x01\x01n\xff\xff\xff\xff\x0f", 9);
  expect_error(parse(big_entry, MeshFormat::kDraco), StatusCode::kInvalidArgument, "ends inside the metadata");
  std::string deep = header + std::string("\x00", 1);
  for (int i = 0; i < 1000; ++i) deep += std::string("\x00\x01\x01m", 4);
  expect_error(parse(deep, MeshFormat::kDraco), StatusCode::kInvalidArgument, "nested deeper than 16 levels");
}

// ---- Hostile bytes ---------------------------------------------------------------

// A parse of hostile bytes may succeed or fail, but a failure must carry a
// data code and a message; the real check is that the process survives.
int fuzz_one(const std::string& bytes, MeshFormat format) {
  auto mesh = parse(bytes, format, MeshLimits{100000, 200000});
  if (mesh.ok()) {
    EXPECT_EQ(validate_mesh(*mesh).code(), StatusCode::kOk);
    return 0;
  }
  const StatusCode code = mesh.status().code();
  EXPECT_TRUE(code == StatusCode::kInvalidArgument || code == StatusCode::kResourceExhausted)
      << mesh.status().to_string();
  EXPECT_FALSE(mesh.status().message().empty());
  return 1;
}

// ---- Colors ----------------------------------------------------------------

// The cube with a color per corner: every channel value different.
Mesh colored_cube() {
  Mesh m = cube_mesh();
  for (size_t v = 0; v < 8; ++v)
    m.colors.insert(m.colors.end(), {uint8_t(30 * v), uint8_t(255 - 31 * v), uint8_t(7 + v)});
  return m;
}

// Colors of `back` against `mesh`'s, each vertex matched by position (Draco's
// edgebreaker reorders them); returns the largest channel difference.
int color_error(const Mesh& mesh, const Mesh& back) {
  EXPECT_EQ(back.colors.size(), 3 * back.vertex_count());
  int worst = 0;
  for (size_t i = 0; i < back.vertex_count() && back.colors.size() == 3 * back.vertex_count(); ++i) {
    size_t nearest = 0;
    double best = 1e300;
    for (size_t j = 0; j < mesh.vertex_count(); ++j) {
      double d = 0;
      for (int a = 0; a < 3; ++a) d += std::pow(back.absolute(i, a) - mesh.absolute(j, a), 2);
      if (d < best) best = d, nearest = j;
    }
    for (size_t c = 0; c < 3; ++c)
      worst = std::max(worst, std::abs(int(back.colors[3 * i + c]) - int(mesh.colors[3 * nearest + c])));
  }
  return worst;
}

TEST(Colors, EveryWriterAndReaderKeepsThemExactly) {
  TempDir dir;
  const Mesh cube = colored_cube();
  const std::vector<float> saliency = {0.0f, 0.125f, 0.25f, 0.5f, 0.75f, 1.0f, 0.3f, 0.99f};
  DracoOptions sequential;
  sequential.speed = 10;
  for (const char* name : {"c.ply", "c.obj", "c.drc", "c.glb", "c.gltf"}) {
    for (const float* s : {static_cast<const float*>(nullptr), saliency.data()}) {
      const std::string path = dir.file(name);
      ASSERT_TRUE(write_mesh(path, cube, s).ok()) << name;
      auto back = read_mesh(path);
      ASSERT_TRUE(back.ok()) << name << ": " << back.status().to_string();
      EXPECT_EQ(color_error(cube, *back), 0) << name << (s ? " with saliency" : "");
      if (s && std::string(name) != "c.obj") {
        auto values = read_saliency(path);
        ASSERT_TRUE(values.ok());
        EXPECT_EQ(values->size(), 8u) << name;
      }
    }
  }
  // Sequential Draco keeps the vertex order: the bytes come back in place.
  ASSERT_TRUE(write_mesh(dir.file("s.drc"), cube, nullptr, sequential).ok());
  auto in_order = read_mesh(dir.file("s.drc"));
  ASSERT_TRUE(in_order.ok());
  EXPECT_EQ(in_order->colors, cube.colors);
  // PLY: x y z saliency red green blue, the real colors beside the saliency.
  ASSERT_TRUE(write_mesh(dir.file("s.ply"), cube, saliency.data()).ok());
  const std::string ply = read_bytes(dir.file("s.ply"));
  const size_t body = ply.find("end_header\n") + 11;
  EXPECT_EQ(ply.find(kRampComment), std::string::npos);
  for (size_t c = 0; c < 3; ++c) EXPECT_EQ(uint8_t(ply[body + 19 + 16 + c]), cube.colors[3 + c]);
}

// Without colors, saliency is drawn as the ramp, marked so that a reader
// does not take the ramp for the model's colors.
TEST(Colors, TheSaliencyRampIsNotReadBackAsColors) {
  TempDir dir;
  const Mesh cube = cube_mesh();
  const std::vector<float> saliency(8, 0.5f);
  for (const char* name : {"r.ply", "r.obj"}) {
    ASSERT_TRUE(write_mesh(dir.file(name), cube, saliency.data()).ok());
    EXPECT_NE(read_bytes(dir.file(name)).find(kRampComment), std::string::npos) << name;
    auto back = read_mesh(dir.file(name));
    ASSERT_TRUE(back.ok()) << back.status().to_string();
    EXPECT_TRUE(back->colors.empty()) << name;
  }
}

std::string colored_triangle_ply(const std::string& type, const std::string& values) {
  std::string s = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  for (const char* name : {"red", "diffuse_green", "blue"}) s += "property " + type + " " + name + "\n";
  s += "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  return s + values + "3 0 1 2\n";
}

TEST(Colors, PlyTypesScaleToBytes) {
  struct Case {
    const char* type;
    const char* values;
    std::vector<uint8_t> expected;
  } cases[] = {
      {"uchar", "0 0 0 255 0 9\n1 0 0 0 128 0\n0 1 0 1 2 3\n", {255, 0, 9, 0, 128, 0, 1, 2, 3}},
      {"float", "0 0 0 1 0 0.5\n1 0 0 2 -1 0.25\n0 1 0 0.2 0.4 0.6\n", {255, 0, 128, 255, 0, 64, 51, 102, 153}},
      {"ushort", "0 0 0 65535 0 257\n1 0 0 0 32896 0\n0 1 0 1 2 3\n", {255, 0, 1, 0, 128, 0, 0, 0, 0}},
      {"int", "0 0 0 300 -5 9\n1 0 0 0 128 0\n0 1 0 1 2 3\n", {255, 0, 9, 0, 128, 0, 1, 2, 3}},
  };
  for (const Case& c : cases) {
    auto mesh = parse(colored_triangle_ply(c.type, c.values), MeshFormat::kPly);
    ASSERT_TRUE(mesh.ok()) << c.type << ": " << mesh.status().to_string();
    EXPECT_EQ(mesh->colors, c.expected) << c.type;
  }
  // Two of three channels are no colors.
  auto partial = parse(
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nelement face 1\nproperty list uchar int vertex_indices\n"
      "end_header\n0 0 0 1 2\n1 0 0 1 2\n0 1 0 1 2\n3 0 1 2\n",
      MeshFormat::kPly);
  ASSERT_TRUE(partial.ok()) << partial.status().to_string();
  EXPECT_TRUE(partial->colors.empty());
}

TEST(Colors, ObjVerticesWithoutColorsAreWhite) {
  auto mesh = parse("v 0 0 0\nv 1 0 0 1 0.5 0\nv 0 1 0 1.5 -2 0.2\nv 1 1 0 1\nf 1 2 3\nf 2 4 3\n", MeshFormat::kObj);
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  EXPECT_EQ(mesh->colors, (std::vector<uint8_t>{255, 255, 255, 255, 128, 0, 255, 0, 51, 255, 255, 255}));
  auto plain = parse("v 0 0 0\nv 1 0 0 1\nv 0 1 0\nf 1 2 3\n", MeshFormat::kObj);
  ASSERT_TRUE(plain.ok());
  EXPECT_TRUE(plain->colors.empty());
}

TEST(Colors, CoffIntegersAndFractionsAfterNormals) {
  const std::string faces = "3 0 1 2\n";
  auto bytes = parse("COFF\n3 1 0\n0 0 0 255 0 10 255\n1 0 0 0.5 1 0\n0 1 0 7\n" + faces, MeshFormat::kOff);
  ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
  // The third vertex's color is a colormap index: white.
  EXPECT_EQ(bytes->colors, (std::vector<uint8_t>{255, 0, 10, 128, 255, 0, 255, 255, 255}));
  auto normals =
      parse("CNOFF\n3 1 0\n0 0 0 0 0 1 1 2 3\n1 0 0 0 0 1 4 5 6 1\n0 1 0 0 0 1 7 8 9\n" + faces, MeshFormat::kOff);
  ASSERT_TRUE(normals.ok()) << normals.status().to_string();
  EXPECT_EQ(normals->colors, (std::vector<uint8_t>{1, 2, 3, 4, 5, 6, 7, 8, 9}));
  auto plain = parse("OFF\n3 1 0\n0 0 0 1 2 3\n1 0 0\n0 1 0\n" + faces, MeshFormat::kOff);
  ASSERT_TRUE(plain.ok());
  EXPECT_TRUE(plain->colors.empty());
}

// Another writer's Draco colors: 4 float components, or uint16 not normalized.
TEST(Colors, DracoColorAttributesOfOtherTypes) {
  const float p[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  auto encode = [&](draco::DataType type, int components, bool normalized, const void* values, size_t size) {
    return parse(draco_triangle_of({{draco::GeometryAttribute::POSITION, draco::DT_FLOAT32, 3, false, p, 12},
                                    {draco::GeometryAttribute::COLOR, type, components, normalized, values, size}}),
                 MeshFormat::kDraco);
  };
  const float rgba[3][4] = {{1, 0, 0.5f, 0.2f}, {0, 1, 0, 1}, {0.25f, 0.75f, 2, 1}};
  auto floats = encode(draco::DT_FLOAT32, 4, false, rgba, 16);
  ASSERT_TRUE(floats.ok()) << floats.status().to_string();
  EXPECT_EQ(floats->colors, (std::vector<uint8_t>{255, 0, 128, 0, 255, 0, 64, 191, 255}));
  const uint16_t wide[3][3] = {{65535, 0, 257}, {0, 65535, 0}, {0, 0, 0}};
  auto shorts = encode(draco::DT_UINT16, 3, false, wide, 6);
  ASSERT_TRUE(shorts.ok()) << shorts.status().to_string();
  EXPECT_EQ(shorts->colors, (std::vector<uint8_t>{255, 0, 1, 0, 255, 0, 0, 0, 0}));
}

TEST(Hostile, RandomBytesForEveryFormatNeverCrash) {
  std::mt19937 rng(1234);
  const std::vector<std::pair<MeshFormat, std::string>> prefixes = {
      {MeshFormat::kDraco, ""},
      {MeshFormat::kDraco, "DRACO\x02\x02\x01\x01"},
      {MeshFormat::kDraco, "DRACO\x02\x02\x01"},
      {MeshFormat::kObj, ""},
      {MeshFormat::kObj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf "},
      {MeshFormat::kPly, ""},
      {MeshFormat::kPly, triangle_ply_header("binary_little_endian", 5, 4)},
      {MeshFormat::kPly, triangle_ply_header("binary_big_endian", 5, 4)},
      {MeshFormat::kPly, triangle_ply_header("ascii", 3, 1)},
      {MeshFormat::kPly, "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty list uint double x\n"},
      {MeshFormat::kOff, ""},
      {MeshFormat::kOff, "OFF\n3 1 0\n"},
      {MeshFormat::kStl, ""},
      {MeshFormat::kStl, "solid x\nfacet normal 0 0 1\nouter loop\nvertex "},
  };
  const char alphabet[] = "0123456789 -.\nfv/e#plyOFFsolidvertexendloop\r\t";
  int failures = 0, runs = 0;
  for (const auto& [format, prefix] : prefixes) {
    for (int i = 0; i < 150; ++i) {
      std::string bytes = prefix;
      const size_t n = rng() % 600;
      const bool text = i % 2 == 1;
      for (size_t k = 0; k < n; ++k) bytes += text ? alphabet[rng() % (sizeof alphabet - 1)] : char(rng() & 0xff);
      failures += fuzz_one(bytes, format);
      ++runs;
    }
  }
  // Binary STL of the right size is always well-formed apart from NaNs.
  for (int i = 0; i < 20; ++i) {
    std::string bytes(84 + 50 * 3, '\0');
    for (char& c : bytes) c = char(rng() & 0xff);
    const uint32_t n = 3;
    std::memcpy(&bytes[80], &n, 4);
    failures += fuzz_one(bytes, MeshFormat::kStl);
    ++runs;
  }
  EXPECT_EQ(runs, 14 * 150 + 20);
  EXPECT_GT(failures, runs * 9 / 10);  // nearly all random inputs are rejected
}

TEST(Hostile, TruncationsAndBitFlipsOfValidFilesNeverCrash) {
  const Mesh sphere = uv_sphere(6, 8);
  std::vector<float> s(sphere.vertex_count());
  for (size_t i = 0; i < s.size(); ++i) s[i] = float(i % 7) / 6.0f;
  auto drc = encode_draco(sphere, s.data(), DracoOptions{});
  DracoOptions sequential;
  sequential.speed = 10;
  auto drc_seq = encode_draco(sphere, s.data(), sequential);
  ASSERT_TRUE(drc.ok() && drc_seq.ok());
  const std::vector<std::pair<MeshFormat, std::string>> files = {
      {MeshFormat::kDraco, std::string(drc->begin(), drc->end())},
      {MeshFormat::kDraco, std::string(drc_seq->begin(), drc_seq->end())},
      {MeshFormat::kPly, cube_ply(Enc::kLittle, "uchar", "int")},
      {MeshFormat::kPly, cube_ply(Enc::kBig, "ushort", "uint")},
      {MeshFormat::kPly, cube_ply(Enc::kAscii, "uchar", "int")},
      {MeshFormat::kOff, "COFF\n8 6 0\n" + cube_off_body(true)},
      {MeshFormat::kStl, cube_stl_binary()},
      {MeshFormat::kStl, cube_stl_ascii()},
  };
  std::mt19937 rng(99);
  int runs = 0;
  std::vector<int> truncated_ok;
  for (const auto& [format, good] : files) {
    ASSERT_EQ(fuzz_one(good, format), 0) << "the unmodified file must parse";
    truncated_ok.push_back(0);
    for (size_t cut = 0; cut < good.size(); ++cut) {
      if (!fuzz_one(good.substr(0, cut), format)) ++truncated_ok.back();
      ++runs;
    }
    for (int i = 0; i < 400; ++i) {
      std::string bytes = good;
      const int flips = 1 + int(rng() % 4);
      for (int k = 0; k < flips; ++k) bytes[rng() % bytes.size()] ^= char(1 << (rng() % 8));
      fuzz_one(bytes, format);
      ++runs;
    }
  }
  EXPECT_GT(runs, 3000);
  // No truncation of a binary file parses. Text can only be cut inside its
  // last token and still read (ASCII PLY "0.25" -> "0.2"; OFF face colors;
  // STL inside the name after "endsolid").
  EXPECT_EQ(truncated_ok, (std::vector<int>{0, 0, 0, 0, 5, 9, 0, 6}));
}

// ---- Shared models ---------------------------------------------------------------

struct ModelCount {
  const char* file;
  size_t vertices;
  size_t triangles;  // after fan triangulation
};

// ---- Far from the origin (issue 19) -------------------------------------------

// The cube moved by `shift` as OBJ text with every digit of a double.
std::string shifted_cube_obj(const double shift[3]) {
  std::string text;
  const std::vector<float> p = cube_positions();
  char line[128];
  for (size_t v = 0; v < 8; ++v) {
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p[3 * v] + shift[0], p[3 * v + 1] + shift[1],
                  p[3 * v + 2] + shift[2]);
    text += line;
  }
  for (auto& q : kCubeQuads) {
    std::snprintf(line, sizeof line, "f %d %d %d %d\n", q[0] + 1, q[1] + 1, q[2] + 1, q[3] + 1);
    text += line;
  }
  return text;
}

// Largest |absolute(back) - (cube + shift)| over the vertices, in units of the cube's diagonal.
double deviation_from_shifted_cube(const Mesh& back, const double shift[3]) {
  const std::vector<float> p = cube_positions();
  const double diagonal = std::sqrt(1.6 * 1.6 + 2.25 * 2.25 + 3.001 * 3.001);
  double worst = 0;
  for (size_t v = 0; v < 8; ++v)
    for (int a = 0; a < 3; ++a) worst = std::max(worst, std::fabs(back.absolute(v, a) - (p[3 * v + a] + shift[a])));
  return worst / diagonal;
}

TEST(FarFromOrigin, ReadInDoubleAndWrittenWithTheOriginAddedBack) {
  TempDir dir;
  for (double t : {1e5, 1e7, -3e7}) {
    const double shift[3] = {t, -t, 0.5 * t};
    auto mesh = parse(shifted_cube_obj(shift), MeshFormat::kObj);
    ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
    // The origin is the bounding-box centre; the floats are relative to it.
    EXPECT_NEAR(mesh->origin[0], t - 0.7, 1e-9 * std::fabs(t));
    EXPECT_LT(deviation_from_shifted_cube(*mesh, shift), 1e-7) << t;
    // A float absolute coordinate at 1e7 is 1 apart: 0.3 of this cube.
    for (const char* name : {"far.obj", "far.ply"}) {
      ASSERT_TRUE(write_mesh(dir.file(name), *mesh, nullptr).ok()) << name;
      auto back = read_mesh(dir.file(name));
      ASSERT_TRUE(back.ok()) << back.status().to_string();
      EXPECT_EQ(back->indices, mesh->indices) << name;
      EXPECT_LT(deviation_from_shifted_cube(*back, shift), 1e-7) << name << " at " << t;
    }
    // Draco: 64-bit positions on the 14-bit grid of the relative frame, or exact.
    for (int bits : {0, 14}) {
      DracoOptions options;
      options.position_bits = bits;
      auto bytes = encode_draco(*mesh, nullptr, options);
      ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
      auto back = parse_mesh(bytes->data(), bytes->size(), MeshFormat::kDraco);
      ASSERT_TRUE(back.ok()) << back.status().to_string();
      ASSERT_EQ(back->vertex_count(), 8u);
      double worst = 0;  // vertices may be reordered by edgebreaker: nearest original
      const std::vector<float> p = cube_positions();
      for (size_t i = 0; i < 8; ++i) {
        double best = 1e300;
        for (size_t j = 0; j < 8; ++j) {
          double d = 0;
          for (int a = 0; a < 3; ++a) d = std::max(d, std::fabs(back->absolute(i, a) - (p[3 * j + a] + shift[a])));
          best = std::min(best, d);
        }
        worst = std::max(worst, best);
      }
      EXPECT_LE(worst, bits == 0 ? 1e-9 * std::fabs(t) : quantization_bound(3.001, 14) + 1e-9 * std::fabs(t))
          << "Draco, " << bits << " bits, at " << t;
    }
  }
}

TEST(FarFromOrigin, ACoordinateAtTheFloatRangesEdgeIsWrittenAsTheEdge) {
  // A vertex read at -FLT_MAX comes back from its frame past the edge by
  // the frame's rounding, which no reader takes: writers store the edge
  // (a fuzzer's STL, tests/fuzz/regressions/stl); a coordinate further out
  // stays out of range, as before.
  Mesh mesh;
  mesh.positions = {-1, 0, 0, 0, 1, 0, 0, 0, 1};
  mesh.indices = {0, 1, 2};
  mesh.scale = double(FLT_MAX) * (1 + 0x1p-26);
  ASSERT_LT(mesh.absolute(0, 0), -double(FLT_MAX));
  EXPECT_EQ(writable_absolute(mesh, 0, 0), -double(FLT_MAX));
  EXPECT_EQ(absolute_positions(mesh)[0], -FLT_MAX);
  TempDir dir;
  for (const char* name : {"edge.ply", "edge.obj"}) {
    ASSERT_TRUE(write_mesh(dir.file(name), mesh, nullptr).ok()) << name;
    auto back = read_mesh(dir.file(name));
    ASSERT_TRUE(back.ok()) << name << ": " << back.status().to_string();
    EXPECT_NEAR(back->absolute(0, 0), -double(FLT_MAX), 1e-6 * mesh.scale) << name;  // its own frame's rounding
    EXPECT_NEAR(back->absolute(1, 1), mesh.absolute(1, 1), 1e-6 * mesh.scale) << name;
  }
  Mesh beyond = mesh;
  beyond.positions[0] = -1.5f;
  EXPECT_EQ(writable_absolute(beyond, 0, 0), -HUGE_VAL);
}

TEST(FarFromOrigin, LosslessDracoGivesBackTheSameFloatsAndFrame) {
  for (double t : {0.0, 1e6}) {
    auto mesh = parse(shifted_cube_obj(std::array<double, 3>{t, t, t}.data()), MeshFormat::kObj);
    ASSERT_TRUE(mesh.ok());
    for (int speed : {0, 10}) {
      auto bytes = encode_draco(*mesh, nullptr, DracoOptions{0, 10, speed});
      ASSERT_TRUE(bytes.ok()) << bytes.status().to_string();
      auto back = parse_mesh(bytes->data(), bytes->size(), MeshFormat::kDraco);
      ASSERT_TRUE(back.ok()) << back.status().to_string();
      EXPECT_EQ(back->origin, mesh->origin);
      EXPECT_EQ(back->scale, mesh->scale);
      if (speed == 10) EXPECT_EQ(back->positions, mesh->positions) << t;  // sequential keeps the order
    }
  }
}

TEST(FarFromOrigin, NearModelsGetFloatFiles) {
  TempDir dir;
  auto mesh = parse(shifted_cube_obj(std::array<double, 3>{5, 5, 5}.data()), MeshFormat::kObj);
  ASSERT_TRUE(mesh.ok());  // 5 is within 8 diagonals of zero
  ASSERT_TRUE(write_mesh(dir.file("near.ply"), *mesh, nullptr).ok());
  EXPECT_NE(read_bytes(dir.file("near.ply")).find("property float x"), std::string::npos);
  auto far = parse(shifted_cube_obj(std::array<double, 3>{1e6, 0, 0}.data()), MeshFormat::kObj);
  ASSERT_TRUE(far.ok());
  ASSERT_TRUE(write_mesh(dir.file("far.ply"), *far, nullptr).ok());
  EXPECT_NE(read_bytes(dir.file("far.ply")).find("property double x"), std::string::npos);
}

TEST(SharedModels, LoadWithReadmeCounts) {
  // README counts; beast and suzanne list polygons: beast has 124 triangles,
  // 32228 quads, 10 pentagons and 2 hexagons (32364 polygons -> 64618
  // triangles), suzanne 32 triangles and 468 quads (500 -> 968). kitten.obj
  // holds 28944 faces (its own header says so); the README says 28,940.
  const ModelCount models[] = {
      {"igea.ply", 134345, 268686}, {"nefertiti.obj", 49971, 99938}, {"horse.ply", 48485, 96966},
      {"bunny.obj", 35947, 69451},  {"kitten.obj", 14472, 28944},    {"rocker-arm.obj", 10044, 20088},
      {"fandisk.obj", 6475, 12946}, {"beast.obj", 32311, 64618},     {"spot.obj", 2930, 5856},
      {"teapot.obj", 3644, 6320},   {"suzanne.obj", 507, 968},
  };
  for (const ModelCount& m : models) {
    const std::string path = std::string("../shared/models/") + m.file;
    const auto start = std::chrono::steady_clock::now();
    auto mesh = read_mesh(path);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
    EXPECT_EQ(mesh->vertex_count(), m.vertices) << m.file;
    EXPECT_EQ(mesh->face_count(), m.triangles) << m.file;
    std::printf("  %-16s %7zu vertices %7zu triangles  %.3f s\n", m.file, mesh->vertex_count(), mesh->face_count(),
                seconds);
  }
  auto beast = read_mesh("../shared/models/beast.obj");
  ASSERT_TRUE(beast.ok());
  EXPECT_GE(beast->face_count(), 32364u);
}

TEST(SharedModels, HorseSurvivesObjAndPlyWritersExactly) {
  TempDir dir;
  auto horse = read_mesh("../shared/models/horse.ply");
  ASSERT_TRUE(horse.ok()) << horse.status().to_string();
  for (const char* name : {"horse.obj", "horse.ply"}) {
    ASSERT_TRUE(write_mesh(dir.file(name), *horse, nullptr).ok());
    auto back = read_mesh(dir.file(name));
    ASSERT_TRUE(back.ok()) << back.status().to_string();
    // Positions are scale-free floats in the file's frame (mesh.h): the text
    // reads back to within a float's precision of the diagonal.
    double worst = 0;
    for (size_t v = 0; v < horse->vertex_count(); ++v)
      for (int a = 0; a < 3; ++a) worst = std::max(worst, std::fabs(back->absolute(v, a) - horse->absolute(v, a)));
    EXPECT_LT(worst, 2e-7 * horse->scale) << name;
    EXPECT_TRUE(back->indices == horse->indices) << name;
  }
}

// ---- PNG and debug output ----------------------------------------------------------

std::vector<uint8_t> read_png(const std::string& path, uint32_t format, int* width, int* height) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) return {};
  image.format = format;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) return {};
  *width = int(image.width);
  *height = int(image.height);
  return pixels;
}

TEST(Png, GrayMaskAndRgbDecodeToTheSamePixels) {
  TempDir dir;
  GrayImage gray(37, 23);
  for (int y = 0; y < gray.height; ++y) {
    for (int x = 0; x < gray.width; ++x) gray.at(x, y) = uint8_t((x * 7 + y * 13) & 0xff);
  }
  ASSERT_TRUE(write_png(dir.file("gray.png"), gray).ok());
  int w = 0, h = 0;
  EXPECT_EQ(read_png(dir.file("gray.png"), PNG_FORMAT_GRAY, &w, &h), gray.pixels);
  EXPECT_EQ(w, 37);
  EXPECT_EQ(h, 23);

  Mask mask(5, 4);
  for (size_t i = 0; i < mask.pixels.size(); ++i) mask.pixels[i] = uint8_t(i % 3);  // 0, 1, 2
  ASSERT_TRUE(write_mask_png(dir.file("mask.png"), mask).ok());
  const std::vector<uint8_t> m = read_png(dir.file("mask.png"), PNG_FORMAT_GRAY, &w, &h);
  ASSERT_EQ(m.size(), 20u);
  for (size_t i = 0; i < m.size(); ++i) EXPECT_EQ(m[i], i % 3 ? 255 : 0) << i;

  std::vector<uint8_t> rgb(11 * 3 * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = uint8_t(i * 29);
  ASSERT_TRUE(write_rgb_png(dir.file("rgb.png"), 11, 3, rgb.data()).ok());
  EXPECT_EQ(read_png(dir.file("rgb.png"), PNG_FORMAT_RGB, &w, &h), rgb);
  EXPECT_EQ(w, 11);
  EXPECT_EQ(h, 3);
}

TEST(Png, BadSizesAndPathsAreErrors) {
  TempDir dir;
  GrayImage empty;
  EXPECT_EQ(write_png(dir.file("e.png"), empty).code(), StatusCode::kInvalidArgument);
  GrayImage ragged(4, 4);
  ragged.pixels.pop_back();
  Status s = write_png(dir.file("r.png"), ragged);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("15 bytes of pixels for a 4 x 4 image that needs 16"), std::string::npos) << s.message();
  EXPECT_EQ(write_png(dir.file("no/such/dir.png"), GrayImage(2, 2)).code(), StatusCode::kNotFound);
  EXPECT_EQ(write_rgb_png(dir.file("n.png"), 2, 2, nullptr).code(), StatusCode::kInvalidArgument);
}

TEST(Debug, SaliencyColorRamp) {
  auto color = [](float v) {
    uint8_t c[3];
    saliency_color(v, c);
    return std::array<int, 3>{c[0], c[1], c[2]};
  };
  EXPECT_EQ(color(0.0f), (std::array<int, 3>{0, 0, 255}));
  EXPECT_EQ(color(0.25f), (std::array<int, 3>{0, 255, 255}));
  EXPECT_EQ(color(0.5f), (std::array<int, 3>{0, 255, 0}));
  EXPECT_EQ(color(0.75f), (std::array<int, 3>{255, 255, 0}));
  EXPECT_EQ(color(1.0f), (std::array<int, 3>{255, 0, 0}));
  EXPECT_EQ(color(0.125f), (std::array<int, 3>{0, 128, 255}));
  EXPECT_EQ(color(-3.0f), color(0.0f));
  EXPECT_EQ(color(7.0f), color(1.0f));
  EXPECT_EQ(color(std::nanf("")), color(0.0f));
}

TEST(Debug, PointPlyHasTheExactLayout) {
  TempDir dir;
  const float points[3][3] = {{1, 2, 3}, {-0.5f, 0.25f, 8}, {0, 0, 1e-3f}};
  const uint8_t colors[3][3] = {{255, 0, 0}, {0, 255, 0}, {1, 2, 3}};
  ASSERT_TRUE(write_point_ply(dir.file("p.ply"), &points[0][0], 3, &colors[0][0]).ok());
  const std::string bytes = read_bytes(dir.file("p.ply"));
  const size_t body = bytes.find("end_header\n") + 11;
  ASSERT_EQ(bytes.size() - body, 3u * 15u);
  EXPECT_NE(bytes.find("element vertex 3\n"), std::string::npos);
  float y1;
  std::memcpy(&y1, &bytes[body + 15 + 4], 4);
  EXPECT_EQ(y1, 0.25f);
  EXPECT_EQ(uint8_t(bytes[body + 30 + 12]), 1);
  EXPECT_EQ(uint8_t(bytes[body + 30 + 14]), 3);
  // The reader sees it for what it is.
  auto mesh = read_mesh(dir.file("p.ply"));
  ASSERT_FALSE(mesh.ok());
  EXPECT_NE(mesh.status().message().find("point cloud with 3 points"), std::string::npos);
  ASSERT_TRUE(write_point_ply(dir.file("q.ply"), &points[0][0], 3, nullptr).ok());
  EXPECT_EQ(read_bytes(dir.file("q.ply")).size() - (read_bytes(dir.file("q.ply")).find("end_header\n") + 11), 36u);
}

}  // namespace
}  // namespace vpr
