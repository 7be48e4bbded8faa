// Draco bitstreams older than 2.2: the legacy files in ../shared/drc (from
// Draco's own test data) decode, and hostile legacy headers are refused by
// the pre-scan before libdraco sizes anything from them.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>

#include "io/mesh_io.h"

namespace vpr {
namespace {

struct LegacyFile {
  const char* name;
  size_t vertices;  // as libdraco 1.5.5 decodes them (Decoder::DecodeMeshFromBuffer)
  size_t faces;
};

// All three hold Draco's test_nm.obj: 170 faces. The sequential file keeps
// 97 points; edgebreaker splits two non-manifold vertices (99).
const LegacyFile kLegacy[] = {
    {"test_nm.obj.edgebreaker.0.10.0.drc", 99, 170},  // bitstream 1.2
    {"test_nm.obj.edgebreaker.1.0.0.drc", 99, 170},   // bitstream 2.0
    {"test_nm.obj.sequential.1.1.0.drc", 97, 170},    // bitstream 2.1
};

TEST(DracoLegacy, SharedFilesDecodeToTheSameMesh) {
  Aabb first{};
  for (size_t i = 0; i < std::size(kLegacy); ++i) {
    const std::string path = std::string("../shared/drc/") + kLegacy[i].name;
    auto mesh = read_mesh(path);
    ASSERT_TRUE(mesh.ok()) << path << ": " << mesh.status().to_string();
    EXPECT_EQ(mesh->vertex_count(), kLegacy[i].vertices) << path;
    EXPECT_EQ(mesh->face_count(), kLegacy[i].faces) << path;
    const std::vector<float> absolute = absolute_positions(*mesh);
    const Aabb box = bounding_box(absolute.data(), mesh->vertex_count());
    if (i == 0) {
      first = box;
      EXPECT_GT(first.hi[0] - first.lo[0], 0.0f);
      continue;
    }
    // Same model, same bounding box up to the encoders' quantization.
    const float tolerance = 1e-4f * (first.hi[0] - first.lo[0]);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(box.lo[a], first.lo[a], tolerance) << path;
      EXPECT_NEAR(box.hi[a], first.hi[a], tolerance) << path;
    }
  }
}

std::string le32(uint32_t v) {
  std::string s(4, '\0');
  for (int i = 0; i < 4; ++i) s[size_t(i)] = char((v >> (8 * i)) & 0xff);
  return s;
}

StatusOr<Mesh> parse(const std::string& bytes, const MeshLimits& limits = {}) {
  return parse_mesh(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), MeshFormat::kDraco, limits);
}

void expect_error(const StatusOr<Mesh>& mesh, StatusCode code, const std::string& needle) {
  ASSERT_FALSE(mesh.ok());
  EXPECT_EQ(mesh.status().code(), code) << mesh.status().to_string();
  EXPECT_NE(mesh.status().message().find(needle), std::string::npos) << mesh.status().to_string();
}

TEST(DracoLegacy, HugeCountsInSmallFilesAreRefused) {
  // Sequential 2.1: uint32 faces and points; 1e9 points in 64 bytes.
  std::string sequential = std::string("DRACO\x02\x01\x01\x00\x00\x00", 11) + le32(10) + le32(1'000'000'000);
  sequential.resize(64, '\0');
  expect_error(parse(sequential), StatusCode::kResourceExhausted,
               "declares 1000000000 vertices, the limit is 20000000");
  // Below the vertex limit but far beyond the bytes present.
  std::string dense = std::string("DRACO\x02\x01\x01\x00\x00\x00", 11) + le32(10) + le32(1'000'000);
  dense.resize(64, '\0');
  expect_error(parse(dense), StatusCode::kInvalidArgument, "declares 1000000 vertices in 64 bytes, more than 1000 per byte");
  // Edgebreaker 1.2: traversal, then uint32 added vertices, vertices, faces,
  // a byte of attribute data, symbols and split symbols.
  const std::string eb12 = std::string("DRACO\x01\x02\x01\x01\x00\x00", 11) + std::string("\x00", 1);
  std::string faces = eb12 + le32(0) + le32(3) + le32(1'000'000'000) + std::string("\x00", 1) + le32(1) + le32(0);
  faces.resize(80, '\0');
  expect_error(parse(faces), StatusCode::kResourceExhausted, "declares 1000000000 faces, the limit is 40000000");
  std::string added = eb12 + le32(1'000'000'000) + le32(3) + le32(1) + std::string("\x00", 1) + le32(1) + le32(0);
  added.resize(80, '\0');
  expect_error(parse(added), StatusCode::kResourceExhausted, "declares 1000000000 added vertices, the limit is 20000000");
  // Edgebreaker 2.0: varints, still with the added-vertex count.
  std::string eb20 = std::string("DRACO\x02\x00\x01\x01\x00\x00", 11) + std::string("\x00\x00\x03", 3) +
                     std::string("\x80\x94\xeb\xdc\x03", 5) + std::string("\x00\x01\x00", 3);
  eb20.resize(64, '\0');
  expect_error(parse(eb20), StatusCode::kResourceExhausted, "declares 1000000000 faces, the limit is 40000000");
  // Truncated inside the uint32 counts.
  expect_error(parse(eb12 + std::string("\x00\x00", 2)), StatusCode::kInvalidArgument,
               "ends inside the connectivity header");
}

TEST(DracoLegacy, UnknownVersionsNameTheSupportedOnes) {
  for (const char* version : {"\x00\x09", "\x01\x04", "\x02\x03", "\x03\x00"}) {
    std::string bytes = std::string("DRACO", 5) + std::string(version, 2) + std::string("\x01\x00\x00\x00", 4);
    bytes.resize(64, '\0');
    expect_error(parse(bytes), StatusCode::kInvalidArgument, "is not supported (supported: 1.0 to 1.3 and 2.0 to 2.2)");
  }
}

}  // namespace
}  // namespace vpr
