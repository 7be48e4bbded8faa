// libFuzzer harness for one mesh reader, built once per format
// (VPR_FUZZ_FORMAT = Obj, Ply, Off, Stl, Draco or Gltf) so that each has its own
// coverage and corpus. Every reader sees bytes from the network or a user's
// disk. parse_mesh must return an error or a mesh that validate_mesh accepts;
// an accepted mesh must come back through our PLY and OBJ writers and readers
// within a float's precision (and unchanged, frame and all, through the
// lossless Draco encoder), its vertex colors within 1 of 255 (every writer
// keeps them exactly); where the format carries saliency, the values must be
// one per vertex.
#include <cmath>
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
  limits.max_texture_pixels = 1 << 22;  // a 2048 x 2048 texture: decoded well within the 10 s per input
  return limits;
}

// exact: the same floats in the same frame; else the same model within a
// float's precision (PLY and OBJ store absolute coordinates, as floats where
// those hold the model to 1e-6 of its size: mesh.h).
void expect_same(const Mesh& a, const StatusOr<Mesh>& b, const char* what, bool exact) {
  if (!b.ok()) {
    // A sliver surface (area below 1e-6 of the squared diagonal, the unit of
    // a reader's positions: mesh.h) may come back degenerate from absolute
    // float coordinates, which hold the model to about 1e-6 of its size.
    if (!exact && b.status().message().find("zero area") != std::string::npos && total_area(a) < 1e-6) return;
    std::fprintf(stderr, "%s\n", b.status().to_string().c_str());
    fail(what);
  }
  if (a.indices != b->indices || a.positions.size() != b->positions.size()) fail(what);
  if (a.colors.size() != b->colors.size()) fail(what);
  for (size_t i = 0; i < a.colors.size(); ++i)
    if (std::abs(int(a.colors[i]) - int(b->colors[i])) > 1) {
      std::fprintf(stderr, "color byte %zu: %d became %d\n", i, int(a.colors[i]), int(b->colors[i]));
      fail(what);
    }
  if (exact) {
    if (a.positions != b->positions || a.origin != b->origin || a.scale != b->scale) fail(what);
    return;
  }
  // A vertex's float is relative to the frame, so its precision is relative to
  // its distance from the origin: a stray vertex (no face uses it, so it does
  // not set the frame) far outside a tiny model keeps about 7 digits of that
  // distance, not of the model's size.
  for (size_t i = 0; i < a.positions.size(); ++i) {
    const int axis = int(i % 3);
    const double x = a.absolute(i / 3, axis), y = b->absolute(i / 3, axis);
    const double from_origin = std::fabs(x - a.origin[size_t(axis)]);
    if (!(std::fabs(x - y) <= 1e-6 * a.scale + 2e-7 * std::fabs(x) + 3e-7 * from_origin)) {
      std::fprintf(stderr, "coordinate %zu: %.17g became %.17g (scale %.17g)\n", i, x, y, a.scale);
      fail(what);
    }
  }
}

void round_trip(const Mesh& mesh, const MeshLimits& limits) {
  const std::vector<uint8_t> ply = io_detail::encode_ply(mesh, nullptr);
  expect_same(mesh, parse_mesh(ply.data(), ply.size(), MeshFormat::kPly, limits), "PLY write and read changed it",
              false);
  const std::vector<uint8_t> obj = io_detail::encode_obj(mesh, nullptr);
  expect_same(mesh, parse_mesh(obj.data(), obj.size(), MeshFormat::kObj, limits), "OBJ write and read changed it",
              false);
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
              "Draco write and read changed it", true);
}

// Our glTF writer with plain accessors keeps every vertex and face; the
// floats are recomputed in the reader's frame, so within a float's precision.
void gltf_round_trip(const Mesh& mesh, const MeshLimits& limits) {
  DracoOptions plain;
  plain.gltf_draco = false;
  auto glb = encode_gltf(mesh, nullptr, plain, true);
  if (!glb.ok()) {
    std::fprintf(stderr, "%s\n", glb.status().to_string().c_str());
    fail("glTF cannot encode a mesh it read");
  }
  expect_same(mesh, parse_mesh(glb->data(), glb->size(), MeshFormat::kGltf, limits), "glTF write and read changed it",
              false);
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
    if (kFormat == MeshFormat::kGltf) gltf_round_trip(*mesh, limits);
  }
  // The saliency attribute (PLY property, Draco attribute) on the same bytes.
  std::vector<float> saliency;
  StatusOr<Mesh> with_saliency = invalid_argument("not read");
  if (size > 0 && kFormat == MeshFormat::kPly) with_saliency = io_detail::parse_ply(data, size, limits, &saliency);
  if (size > 0 && kFormat == MeshFormat::kDraco) with_saliency = io_detail::parse_draco(data, size, limits, &saliency);
  if (size > 0 && kFormat == MeshFormat::kGltf)
    with_saliency = io_detail::parse_gltf(data, size, limits, &saliency, nullptr);
  if (with_saliency.ok()) {
    if (!saliency.empty() && saliency.size() != with_saliency->vertex_count())
      fail("saliency is not one value per vertex");
    if (mesh.ok()) expect_same(*mesh, with_saliency, "reading the saliency changed the mesh", true);
  }
  return 0;
}
