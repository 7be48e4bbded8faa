// Flat triangle meshes and polygon soups, the currency of every stage.
// Nothing downstream of input relies on connectivity (paper, Section III):
// a Mesh may be a soup with duplicated, flipped or degenerate faces.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/image.h"
#include "core/status.h"

namespace vpr {

// How texture coordinates outside [0, 1] map into a texture, per axis (glTF
// sampler wrapS / wrapT; REPEAT is glTF's default).
enum class TextureWrap : uint8_t { kRepeat, kClampToEdge, kMirroredRepeat };

// A base-color texture: an 8-bit sRGB image (row 0 at v = 0, as glTF) and its wrap modes.
struct BaseColorTexture {
  std::shared_ptr<const RgbImage> image;  // never null in a valid mesh; shared, so copies of a Mesh are cheap
  TextureWrap wrap_u = TextureWrap::kRepeat;
  TextureWrap wrap_v = TextureWrap::kRepeat;
};

// Base-color textures over a mesh's vertices. A face takes the texture of its
// first corner (a glTF primitive has vertices of its own, so the corners of
// one face always agree). Either every array is empty or uvs has 2 and
// vertex_texture 1 entry per vertex.
struct MeshTextures {
  static constexpr uint32_t kNone = UINT32_MAX;
  std::vector<float> uvs;                // #V x 2 texture coordinates (u right, v down from the image's row 0)
  std::vector<uint32_t> vertex_texture;  // #V indices into textures, or kNone (untextured)
  std::vector<BaseColorTexture> textures;
  bool empty() const { return textures.empty(); }
};

// Positions are floats relative to a double-precision origin, so that a model
// far from the coordinate origin (a scan in georeferenced coordinates, a part
// placed in a plant model) keeps the precision a float has near zero: vertex
// v sits at origin + scale * positions[3v..3v+2] in the model's units.
// Readers set the frame (mesh_from_absolute: the bounding-box centre and
// diagonal, so the floats are scale-free and the same for a model moved or
// resized); stages work on the floats and carry the frame to their output;
// writers apply it in double. Meshes built in code keep origin 0, scale 1.
struct Mesh {
  std::vector<float> positions;   // #V x 3 floats, in the frame below
  std::vector<uint32_t> indices;  // #F x 3 vertex indices, counter-clockwise when oriented
  std::array<double, 3> origin{0, 0, 0};  // model units
  double scale = 1;                       // model units per position unit, > 0
  // Appearance, optional: every stage computes geometry and leaves it empty on
  // its output; the color transfer (pipeline/color_transfer.h) samples the
  // input's for the output's colors; writers write colors (docs/formats.md).
  // A point's color is its face's texture sample times its interpolated
  // vertex color, in linear light; an absent part counts as white.
  std::vector<uint8_t> colors;  // #V x 3 sRGB bytes (0..255), or empty
  MeshTextures textures;        // the input's base-color textures, or empty

  size_t vertex_count() const { return positions.size() / 3; }
  size_t face_count() const { return indices.size() / 3; }
  // Vertex v's coordinate on axis a in the model's units.
  double absolute(size_t v, int a) const {
    return origin[size_t(a)] + scale * double(positions[3 * v + size_t(a)]);
  }
};

// True when the mesh carries colors or textures.
inline bool has_appearance(const Mesh& m) {
  return !m.colors.empty() || !m.textures.empty();
}

struct Aabb {
  std::array<float, 3> lo{0, 0, 0};
  std::array<float, 3> hi{0, 0, 0};
  float diagonal() const;
};

// Limits a mesh must satisfy before it enters the pipeline. Each failure names
// the problem and the limit.
struct MeshLimits {
  size_t max_vertices = 20'000'000;  // upload limit for one job
  size_t max_faces = 40'000'000;
  // Texels of all the base-color textures a file may decode together (3
  // bytes each once decoded, 4 while a PNG decodes): one 8192 x 8192 texture,
  // or four of 4096 x 4096. Checked against each image's header before it is
  // decoded; no side may pass kMaxTextureSide either.
  size_t max_texture_pixels = size_t(64) << 20;
};

// The longest texture side readers accept (glTF viewers' usual GPU limit).
inline constexpr uint32_t kMaxTextureSide = 16384;

// Checks: at least one vertex and one face, every coordinate finite, every
// index in range, positive total area; colors and textures, when present,
// sized to the vertices, texture indices in range and every image whole.
// Degenerate faces alone are accepted.
Status validate_mesh(const Mesh& mesh, const MeshLimits& limits = {});
// The colors and textures part of validate_mesh alone.
Status validate_appearance(const Mesh& mesh);

Aabb bounding_box(const float* positions, size_t vertex_count);
inline Aabb bounding_box(const Mesh& m) {
  return bounding_box(m.positions.data(), m.vertex_count());
}

// A mesh from positions in double (#V x 3, model units) and indices (#F x 3):
// origin and scale are the bounding-box centre and diagonal of the vertices
// the faces use (of all vertices when there are no faces), computed over
// finite coordinates only. A coordinate that is not finite, or beyond the
// float range, becomes +-inf or NaN where validate_mesh finds it.
Mesh mesh_from_absolute(const std::vector<double>& positions, std::vector<uint32_t> indices);

// The same mesh in another frame (positions recomputed in double, then
// rounded to float once; colors and textures as they are).
Mesh rebased(const Mesh& mesh, const std::array<double, 3>& origin, double scale);

// Vertex v's coordinate on axis a as a writer stores it. A coordinate a
// reader took at the edge of the float range can come back past it by the
// frame's rounding (up to scale times a float's spacing), which no reader
// would take again: within that, the edge itself; further out, +-inf.
double writable_absolute(const Mesh& mesh, size_t v, int a);

// Absolute coordinates as floats (writable_absolute, rounded once).
std::vector<float> absolute_positions(const Mesh& mesh);

// True when float absolute coordinates hold the mesh to within 1e-6 of its
// bounding-box diagonal (the vertices faces use lie within 8 diagonals of zero), so a
// writer can store floats; false: store doubles, or the origin beside floats.
bool absolute_fits_float(const Mesh& mesh);

// Drops the vertices no face uses and renumbers the rest, keeping their order
// (and their colors and texture coordinates).
// used (may be null): receives, for each kept vertex, its index in the input;
// left empty when every vertex is used (nothing changes then). Returns the
// number of vertices dropped.
size_t remove_unreferenced_vertices(Mesh* mesh, std::vector<uint32_t>* used);

// The positions and faces with corners at exactly the same position merged
// into one vertex (first occurrence first), so that a soup or an OBJ split at
// texture seams has the connectivity its surface implies. Orientation is not
// touched; other attributes are not carried.
Mesh weld_exact(const Mesh& mesh);
size_t unreferenced_vertex_count(const Mesh& mesh);

// Area of each face (#F doubles) and their sum; degenerate faces have area 0.
std::vector<double> face_areas(const Mesh& mesh);
double total_area(const Mesh& mesh);

// Mean edge length over all face edges (used by AWLOP's paper-default h).
double mean_edge_length(const Mesh& mesh);

}  // namespace vpr
