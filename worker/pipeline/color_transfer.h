// Colors for a remeshed surface, from the input's vertex colors and
// base-color textures. The output's connectivity is new, so the input's
// texture layout (its UV charts) cannot carry over: each output vertex takes
// the color the input surface shows at the vertex's closest point instead
// (surface/closest_point.h): that face's corner colors interpolated at the
// point's barycentric coordinates, times its texture sampled bilinearly at
// the interpolated texture coordinate, in linear light (glTF 2.0, 3.9.2).
// docs/formats.md says what a user can do to keep texture detail.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"

namespace vpr {

// input: a valid mesh with colors or textures (has_appearance); output: the
// remeshed surface, in any frame (mesh.h; positions are compared in the
// model's units). colors: receives #V_out x 3 sRGB bytes. Runs over the
// output's vertices in parallel; the result does not depend on the thread count.
Status transfer_colors(const Mesh& input, const Mesh& output, std::vector<uint8_t>* colors);

// The input's color, linear RGB in [0, 1], at the point of `face` with
// barycentric coordinates b (of the face's three corners, in order).
std::array<float, 3> surface_color(const Mesh& mesh, uint32_t face, const std::array<double, 3>& b);

// Bilinear sample of a texture at (u, v), linear RGB: texel centres at
// ((i + 0.5) / width, (j + 0.5) / height), row j = 0 at v = 0, coordinates
// outside [0, 1] wrapped by the texture's modes (non-finite ones read as 0).
std::array<float, 3> sample_texture(const BaseColorTexture& texture, double u, double v);

}  // namespace vpr
