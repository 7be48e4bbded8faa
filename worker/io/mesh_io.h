// Reading and writing meshes. Input: Draco (.drc, the service's wire format),
// glTF 2.0 (.glb, .gltf; every triangle primitive of the scene with its node
// transforms, KHR_draco_mesh_compression included), OBJ, PLY (ASCII and
// binary), OFF and STL (ASCII and binary). Polygons are triangulated as fans;
// soups are kept as they are (STL corners at exactly the same position are
// merged, first occurrence first). Output: .drc, .glb, .gltf, .ply, .obj, with
// an optional per-vertex saliency value. Vertex colors are read from PLY,
// OBJ, OFF, Draco and glTF, base-color textures from glTF (mesh.h, Mesh::
// colors and textures), and mesh.colors are written to every output format;
// docs/formats.md, "Colors", has the details.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"

namespace vpr {

// kGltf: .glb or .gltf, told apart by the bytes (GLB starts with "glTF").
enum class MeshFormat { kDraco, kObj, kPly, kOff, kStl, kGltf };

// From the file extension (case-insensitive); error names the supported ones.
StatusOr<MeshFormat> format_from_path(const std::string& path);

// Parses bytes of the given format. Every failure is INVALID_ARGUMENT with a
// message naming the problem (line number for text formats), or
// RESOURCE_EXHAUSTED when counts (from the header where the format has one)
// pass the limits; the result is checked with validate_mesh(limits).
// read_mesh: NOT_FOUND for a missing file; messages start with the path.
// glTF external buffers (a uri naming a file) are read by read_mesh only,
// relative to the file's folder; parse_mesh (an upload) refuses them.
StatusOr<Mesh> parse_mesh(const uint8_t* data, size_t size, MeshFormat format, const MeshLimits& limits = {});
StatusOr<Mesh> read_mesh(const std::string& path, const MeshLimits& limits = {});

// A value moves by at most half a quantization step: range / (2^bits - 1) / 2,
// with range the largest extent of the attribute (positions: the bounding box).
struct DracoOptions {
  // Quantization of positions, 1..30; 0 = none (lossless: 64-bit floats).
  // Models far from zero (floats would not hold them to 1e-6 of their size)
  // are stored as 64-bit floats on the same grid.
  int position_bits = 14;
  int saliency_bits = 10;  // quantization of the saliency attribute, 1..30
  // Draco encoder speed 0 (best) .. 10 (fastest). 10 selects sequential
  // connectivity, which keeps every face and vertex as given; 0..9 select
  // edgebreaker, which reorders vertices, drops degenerate (repeated-index)
  // faces and splits non-manifold vertices. 6, the first speed with the
  // standard edgebreaker (5 and below take its valence coder): on remeshed
  // outputs (igea 10,000, horse 5,000, bunny 3,000, fandisk 5,000, nefertiti
  // 20,000; Debian's Draco 1.5.5, 2026-12-07) it encoded in 15-35% less time than 5,
  // and the files came out 0.02-0.08% smaller, not larger.
  int speed = 6;
  // .glb/.gltf output: the primitive as a KHR_draco_mesh_compression
  // bitstream (with the settings above); false, or position_bits 0: plain
  // float accessors.
  bool gltf_draco = true;
};

// saliency: nullptr or #V floats in [0, 1]. Draco stores it as a GENERIC
// attribute whose metadata name is "saliency"; PLY as a vertex property
// "saliency"; PLY and OBJ, when the mesh has no colors, also as vertex
// colors from a color ramp. mesh.colors: Draco's COLOR attribute (3 uint8,
// normalized, sRGB), PLY red/green/blue uchar, OBJ "v x y z r g b".
StatusOr<std::vector<uint8_t>> encode_draco(const Mesh& mesh, const float* saliency, const DracoOptions& options);
// glTF 2.0: one node holding the mesh frame (translation = origin, scale),
// one triangle primitive; saliency as the float vertex attribute _SALIENCY,
// colors as COLOR_0 (VEC3, linear, unsigned short normalized).
// binary: GLB, else JSON with the buffer as a base64 data: URI.
StatusOr<std::vector<uint8_t>> encode_gltf(const Mesh& mesh, const float* saliency, const DracoOptions& options,
                                           bool binary);
// .drc, .glb, .gltf, .ply or .obj by extension (.off and .stl are input formats only).
Status write_mesh(const std::string& path, const Mesh& mesh, const float* saliency, const DracoOptions& options = {});

// Reads back the saliency attribute of a Draco, glTF or PLY file (empty if absent).
StatusOr<std::vector<float>> read_saliency(const std::string& path);

// Points as a binary PLY (debug output): points #N x 3, optional colors #N x 3 bytes.
Status write_point_ply(const std::string& path, const float* points, size_t n, const uint8_t* colors);

// The color ramp used for saliency: linear between blue (0), cyan (0.25),
// green (0.5), yellow (0.75) and red (1); values are clamped, NaN is blue.
void saliency_color(float value, uint8_t rgb[3]);

}  // namespace vpr
