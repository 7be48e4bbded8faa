// The pipeline fuzzer's input: a tiny mesh or point set, a target and a few
// options, packed in bytes. Shared by the harness (pipeline_fuzzer.cpp) and
// the seed generator (fuzz_seeds.cpp), so seeds made from real models decode
// to those models. Little-endian:
//   byte 0     what runs: 0 run_pipeline, 1 mesh_points on the vertices (a
//              point set), 2 repair_triangle_soup on the vertices and faces
//   byte 1     bit 0: 14 views (else 6); bit 1: no PCA alignment; bits 2-5:
//              resolution 64 + 4 x (0..15); bits 6-7: the back half's
//              density (DensityMode: perception, curvature, uniform, paper)
//   bytes 2-3  target = 4 + value % (2 #V - 3), so 4 .. 2 #V
//   byte 4     sampling seed; for the meshing modes, points per slab (0: one
//              slab, else 16 + 2 x value, so a few hundred points still cut)
//   byte 5     bit 0: coordinates are float32, else int8 steps on a grid
//              (coincident, collinear and coplanar points come easily);
//              bit 1: uniform sampling (the paper's back half)
//   bytes 6-7  #V = 1 + value % kMaxVertices
//   then #V x 3 coordinates, then triangles as 3 uint16 each (index % #V)
//   until the data ends (at most kMaxFaces; a trailing partial one is dropped).
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <optional>
#include <vector>

#include "core/mesh.h"
#include "surface/surface_density.h"

namespace vpr::fuzz {

inline constexpr uint32_t kMaxVertices = 400;
inline constexpr size_t kMaxFaces = 1024;
inline constexpr size_t kHeaderBytes = 8;

enum class Mode : uint8_t { kPipeline = 0, kPoints = 1, kSoup = 2 };

struct PipelineInput {
  Mode mode = Mode::kPipeline;
  bool fourteen_views = false;
  bool pca_align = true;
  int resolution = 64;
  DensityMode density = DensityMode::kPerception;
  bool uniform_sampling = false;
  uint32_t target = 4;
  uint8_t seed = 0;  // also points per slab in the meshing modes
  bool float_coordinates = true;
  Mesh mesh;  // indices may be empty (a point set)
};

inline std::optional<PipelineInput> decode(const uint8_t* data, size_t size) {
  if (size < kHeaderBytes) return std::nullopt;
  PipelineInput in;
  in.mode = Mode(data[0] % 3);
  in.fourteen_views = data[1] & 1;
  in.pca_align = !(data[1] & 2);
  in.resolution = 64 + 4 * ((data[1] >> 2) & 15);
  in.density = DensityMode(data[1] >> 6);
  const uint32_t target_bits = uint32_t(data[2]) | uint32_t(data[3]) << 8;
  in.seed = data[4];
  in.float_coordinates = data[5] & 1;
  in.uniform_sampling = data[5] & 2;
  const uint32_t nv = 1 + (uint32_t(data[6]) | uint32_t(data[7]) << 8) % kMaxVertices;
  in.target = 4 + target_bits % (2 * nv - 3);
  const size_t coordinate_bytes = in.float_coordinates ? 4 : 1;
  const uint8_t* p = data + kHeaderBytes;
  const uint8_t* end = data + size;
  if (size_t(end - p) < 3 * nv * coordinate_bytes) return std::nullopt;
  in.mesh.positions.resize(3 * size_t(nv));
  for (float& x : in.mesh.positions) {
    if (in.float_coordinates) {
      std::memcpy(&x, p, 4);
    } else {
      x = float(int8_t(*p)) / 16.0f;
    }
    p += coordinate_bytes;
  }
  const size_t faces = std::min(size_t(end - p) / 6, kMaxFaces);
  in.mesh.indices.resize(3 * faces);
  for (uint32_t& index : in.mesh.indices) {
    index = (uint32_t(p[0]) | uint32_t(p[1]) << 8) % nv;
    p += 2;
  }
  return in;
}

// The bytes that decode() turns back into `in` (float coordinates, the
// target as given when it is in range).
inline std::vector<uint8_t> encode(const PipelineInput& in) {
  const uint32_t nv = uint32_t(std::min<size_t>(in.mesh.vertex_count(), kMaxVertices));
  const uint32_t target_bits = std::max<uint32_t>(in.target, 4) - 4;
  std::vector<uint8_t> out = {uint8_t(in.mode),
                              uint8_t((in.fourteen_views ? 1 : 0) | (in.pca_align ? 0 : 2) |
                                      (((in.resolution - 64) / 4) & 15) << 2 | int(in.density) << 6),
                              uint8_t(target_bits),
                              uint8_t(target_bits >> 8),
                              in.seed,
                              uint8_t(1 | (in.uniform_sampling ? 2 : 0)),
                              uint8_t(nv - 1),
                              uint8_t((nv - 1) >> 8)};
  for (size_t i = 0; i < 3 * size_t(nv); ++i) {
    uint8_t b[4];
    std::memcpy(b, &in.mesh.positions[i], 4);
    out.insert(out.end(), b, b + 4);
  }
  for (size_t f = 0; f < std::min(in.mesh.face_count(), kMaxFaces); ++f) {
    const uint32_t* t = &in.mesh.indices[3 * f];
    if (t[0] >= nv || t[1] >= nv || t[2] >= nv) continue;
    for (int k = 0; k < 3; ++k) out.insert(out.end(), {uint8_t(t[k]), uint8_t(t[k] >> 8)});
  }
  return out;
}

}  // namespace vpr::fuzz
