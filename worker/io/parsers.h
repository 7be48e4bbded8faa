// Internal to vpr_io: one parse function per format, and the bounded text
// scanning they share. Every parser reads only inside [data, data + size),
// never allocates more than the bytes it was given can justify (header counts
// are checked against the data and against MeshLimits first), and reports the
// problem and where it is (line number for text, element number for binary).
// parse_mesh() in mesh_io.cpp runs validate_mesh() on the result.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"
#include "io/mesh_io.h"

namespace vpr::io_detail {

// glTF names the reader and the writer share.
inline constexpr const char* kSaliencyAttributeName = "_SALIENCY";  // glTF's prefix for application attributes
inline constexpr const char* kDracoExtensionName = "KHR_draco_mesh_compression";
// In a PLY comment or an OBJ comment that starts with "vpremesh": the file's
// vertex colors are the saliency ramp our writers draw (no input had colors),
// which readers leave out rather than take for the model's colors.
inline constexpr const char* kSaliencyRampNote = "vertex colors show saliency";

// Every parser fills mesh.colors (and the glTF reader mesh.textures) when the
// file has them (docs/formats.md, "Colors"). saliency (may be nullptr):
// receives the per-vertex "saliency" values when the file carries them (PLY
// vertex property, Draco attribute), else is cleared.
StatusOr<Mesh> parse_obj(const uint8_t* data, size_t size, const MeshLimits& limits);
StatusOr<Mesh> parse_ply(const uint8_t* data, size_t size, const MeshLimits& limits, std::vector<float>* saliency);
StatusOr<Mesh> parse_off(const uint8_t* data, size_t size, const MeshLimits& limits);
StatusOr<Mesh> parse_stl(const uint8_t* data, size_t size, const MeshLimits& limits);

// An attribute of a Draco stream by its unique id (KHR_draco_mesh_compression
// names COLOR_0 and TEXCOORD_n so): out receives `components` values per
// point, normalized integers in [0, 1] and other values as they are; a
// missing id, or one with fewer components, is INVALID_ARGUMENT.
struct DracoAttributeRequest {
  int unique_id = -1;
  int components = 0;
  std::vector<float>* out = nullptr;
};
// A .drc file's first COLOR attribute becomes mesh.colors (stored 8-bit
// sRGB, as Draco's own PLY and OBJ readers store them).
StatusOr<Mesh> parse_draco(const uint8_t* data, size_t size, const MeshLimits& limits, std::vector<float>* saliency,
                           const std::vector<DracoAttributeRequest>& requests = {});
// base_dir: the folder external buffers are read from; nullptr refuses them.
StatusOr<Mesh> parse_gltf(const uint8_t* data, size_t size, const MeshLimits& limits, std::vector<float>* saliency,
                          const std::string* base_dir);

// Vertex colors as a Draco stream stores them: 8-bit sRGB (a .drc file) or
// linear unsigned 16-bit normalized (glTF's COLOR_0 is linear, glTF 2.0
// 3.7.2.1; 16 bits keep every sRGB byte apart, 8 would merge the darks).
enum class DracoColors { kSrgb8, kLinear16 };
// A color byte as a linear 16-bit value.
uint16_t linear16(uint8_t srgb);
// The unique ids encode_draco_stream gave its attributes; -1 when absent.
struct DracoIds {
  int position = -1, saliency = -1, color = -1;
};
// encode_draco (mesh_io.h) with the colors in the given encoding.
StatusOr<std::vector<uint8_t>> encode_draco_stream(const Mesh& mesh, const float* saliency, const DracoOptions& options,
                                                   DracoColors colors, DracoIds* ids);

// ---- Shared text scanning (implemented in mesh_io.cpp) ----------------------

inline bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

// Splits [begin, end) into lines at '\n'; a trailing '\r' (CRLF files) is
// dropped. The buffer need not be NUL-terminated.
class LineReader {
 public:
  LineReader(const char* begin, const char* end) : p_(begin), end_(end) {}
  // False at the end of the data. line_number() is then the last line's.
  bool next(std::string_view* line);
  size_t line_number() const { return line_; }
  const char* position() const { return p_; }

 private:
  const char* p_;
  const char* end_;
  size_t line_ = 0;
};

// Whitespace-separated tokens over a byte range, counting lines for messages.
class TokenReader {
 public:
  TokenReader(const char* begin, const char* end) : p_(begin), end_(end) {}
  // False when only whitespace is left.
  bool next(std::string_view* token);
  // Line (1-based) of the token last returned.
  size_t line_number() const { return line_; }
  // Skips to the start of the next line.
  void skip_line();

 private:
  const char* p_;
  const char* end_;
  size_t line_ = 1;
};

// Removes leading and trailing blanks.
std::string_view trim(std::string_view s);
// Pops the next blank-separated token off the front of *s ("" when none is left).
std::string_view next_token(std::string_view* s);

// The whole token must be a number. Accepts a leading '+', "nan" and "inf" (so
// that validate_mesh reports them uniformly); values beyond the float range
// become +-inf, values below it round to zero or a denormal.
bool parse_float(std::string_view token, float* out);
bool parse_double(std::string_view token, double* out);
// double -> float without undefined behaviour: beyond the float range gives
// +-inf (reported later by validate_mesh), NaN stays NaN.
float to_float(double v);

// The whole token must be a decimal integer (leading '+' or '-' allowed).
bool parse_int(std::string_view token, int64_t* out);

// A color channel in [0, 1] as a byte: clamped, rounded, NaN gives 0.
uint8_t unit_to_byte(double value);

// Token for messages: quoted, cut to 32 characters, non-printable bytes escaped.
std::string quote(std::string_view token);

// Fan triangulation of a polygon: corner k >= 2 adds (first, prev, v). Fails
// with RESOURCE_EXHAUSTED, prefixed by `where`, when the face limit is reached.
Status push_fan_triangle(Mesh& mesh, uint32_t first, uint32_t prev, uint32_t v, const MeshLimits& limits,
                         const std::string& where);

// ---- Writers and files (encode_* in their format's file, files in mesh_io.cpp)

// Binary little-endian PLY: x y z float [saliency float] [red green blue uchar],
// faces as "list uchar uint vertex_indices". saliency: nullptr or #V floats.
// Colors are mesh.colors, or else, with saliency, saliency_color's ramp
// (and the comment kSaliencyRampNote).
std::vector<uint8_t> encode_ply(const Mesh& mesh, const float* saliency);
// "v x y z [r g b]" and "f a b c", 1-based; colors in 0..1, from mesh.colors
// or else, with saliency, from saliency_color (noted in the first comment).
std::vector<uint8_t> encode_obj(const Mesh& mesh, const float* saliency);

// INVALID_ARGUMENT for what would crash an encoder or make an unreadable file:
// ragged arrays, indices out of range, non-finite positions or saliency,
// colors that are not 3 bytes per vertex.
Status check_writable(const Mesh& mesh, const float* saliency);

// NOT_FOUND when the file is missing; RESOURCE_EXHAUSTED when it cannot be held.
StatusOr<std::vector<uint8_t>> read_file(const std::string& path);
Status write_file(const std::string& path, const std::vector<uint8_t>& bytes);

}  // namespace vpr::io_detail
