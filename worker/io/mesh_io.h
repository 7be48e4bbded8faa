// Reading and writing meshes. Input: Draco (.drc, the service's wire format),
// OBJ, PLY (ASCII and binary), OFF and STL (ASCII and binary). Polygons are
// triangulated as fans; soups are kept as they are. Output: .drc, .ply, .obj,
// with an optional per-vertex saliency value.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/mesh.h"
#include "pipeline/status.h"

namespace vpr {

enum class MeshFormat { kDraco, kObj, kPly, kOff, kStl };

// From the file extension (case-insensitive); error names the supported ones.
StatusOr<MeshFormat> format_from_path(const std::string& path);

// Parses bytes of the given format. Every failure is INVALID_ARGUMENT with a
// message naming the problem (line number for text formats); the result is
// checked with validate_mesh(limits).
StatusOr<Mesh> parse_mesh(const uint8_t* data, size_t size, MeshFormat format, const MeshLimits& limits = {});
StatusOr<Mesh> read_mesh(const std::string& path, const MeshLimits& limits = {});

struct DracoOptions {
  int position_bits = 14;  // quantization of positions
  int saliency_bits = 10;  // quantization of the saliency attribute
  int speed = 5;           // Draco encoder speed 0 (best) .. 10 (fastest)
};

// saliency: nullptr or #V floats in [0, 1]. Draco stores it as a GENERIC
// attribute whose metadata name is "saliency"; PLY as a vertex property
// "saliency" plus red/green/blue from a color ramp; OBJ as vertex colors.
StatusOr<std::vector<uint8_t>> encode_draco(const Mesh& mesh, const float* saliency, const DracoOptions& options);
Status write_mesh(const std::string& path, const Mesh& mesh, const float* saliency,
                  const DracoOptions& options = {});

// Reads back the saliency attribute of a Draco file or PLY (empty if absent).
StatusOr<std::vector<float>> read_saliency(const std::string& path);

// Points as a binary PLY (debug output): points #N x 3, optional colors #N x 3 bytes.
Status write_point_ply(const std::string& path, const float* points, size_t n, const uint8_t* colors);

// The color ramp used for saliency (0 -> blue, 0.5 -> green/yellow, 1 -> red).
void saliency_color(float value, uint8_t rgb[3]);

}  // namespace vpr
