// libFuzzer harness for one mesh reader, built once per format
// (VPR_FUZZ_FORMAT = Obj, Ply, Off, Stl or Draco) so that each has its own
// coverage and corpus. Every reader sees bytes from the network or a user's
// disk. parse_mesh must return an error or a mesh that validate_mesh accepts;
// an accepted mesh must come back unchanged through our PLY and OBJ writers
// and readers (and, for Draco, through the lossless Draco encoder); where the
// format carries saliency, the values must be one per vertex.
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "io/mesh_io.h"
#include "io/parsers.h"

#define VPR_CAT(a, b) a##b
#define VPR_FORMAT(f) VPR_CAT(vpr::MeshFormat::k, f)

namespace {

using namespace vpr;

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "reader_fuzzer: broken promise: %s\n", what);
  std::abort();
}

MeshLimits fuzz_limits() {
  MeshLimits limits;
  limits.max_vertices = 1 << 20;  // keeps the fuzzer's memory bounded
  limits.max_faces = 1 << 21;
  return limits;
}

void expect_same(const Mesh& a, const StatusOr<Mesh>& b, const char* what) {
  if (!b.ok()) {
    std::fprintf(stderr, "%s\n", b.status().to_string().c_str());
    fail(what);
  }
  if (a.positions != b->positions || a.indices != b->indices) fail(what);
}

void round_trip(const Mesh& mesh, const MeshLimits& limits) {
  const std::vector<uint8_t> ply = io_detail::encode_ply(mesh, nullptr);
  expect_same(mesh, parse_mesh(ply.data(), ply.size(), MeshFormat::kPly, limits), "PLY write and read changed it");
  const std::vector<uint8_t> obj = io_detail::encode_obj(mesh, nullptr);
  expect_same(mesh, parse_mesh(obj.data(), obj.size(), MeshFormat::kObj, limits), "OBJ write and read changed it");
}

// Draco's sequential, unquantized encoding keeps every vertex and face.
void draco_round_trip(const Mesh& mesh, const MeshLimits& limits) {
  DracoOptions lossless;
  lossless.position_bits = 0;
  lossless.speed = 10;
  auto drc = encode_draco(mesh, nullptr, lossless);
  if (!drc.ok()) {
    std::fprintf(stderr, "%s\n", drc.status().to_string().c_str());
    fail("Draco cannot encode a mesh it read");
  }
  expect_same(mesh, parse_mesh(drc->data(), drc->size(), MeshFormat::kDraco, limits),
              "Draco write and read changed it");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  constexpr MeshFormat kFormat = VPR_FORMAT(VPR_FUZZ_FORMAT);
  const MeshLimits limits = fuzz_limits();
  const StatusOr<Mesh> mesh = parse_mesh(data, size, kFormat, limits);
  if (mesh.ok()) {
    if (!validate_mesh(*mesh, limits).ok()) fail("parse_mesh returned a mesh that validate_mesh refuses");
    round_trip(*mesh, limits);
    if (kFormat == MeshFormat::kDraco) draco_round_trip(*mesh, limits);
  }
  // The saliency attribute (PLY property, Draco attribute) on the same bytes.
  std::vector<float> saliency;
  StatusOr<Mesh> with_saliency = invalid_argument("not read");
  if (size > 0 && kFormat == MeshFormat::kPly) with_saliency = io_detail::parse_ply(data, size, limits, &saliency);
  if (size > 0 && kFormat == MeshFormat::kDraco) with_saliency = io_detail::parse_draco(data, size, limits, &saliency);
  if (with_saliency.ok()) {
    if (!saliency.empty() && saliency.size() != with_saliency->vertex_count())
      fail("saliency is not one value per vertex");
    if (mesh.ok()) expect_same(*mesh, with_saliency, "reading the saliency changed the mesh");
  }
  return 0;
}
