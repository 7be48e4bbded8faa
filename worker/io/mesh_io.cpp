// Format dispatch, files, the saliency color ramp and the text scanning the
// parsers share. The per-format parsers live in {obj,ply,off,stl,draco}_io.cpp.
#include "io/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <new>

#include "core/color.h"
#include "io/parsers.h"

namespace vpr {
namespace io_detail {

// ---- Text scanning ----------------------------------------------------------

bool LineReader::next(std::string_view* line) {
  if (p_ >= end_) return false;
  const char* nl = static_cast<const char*>(std::memchr(p_, '\n', size_t(end_ - p_)));
  const char* stop = nl ? nl : end_;
  const char* last = stop;
  if (last > p_ && last[-1] == '\r') --last;
  *line = std::string_view(p_, size_t(last - p_));
  p_ = nl ? nl + 1 : end_;
  ++line_;
  return true;
}

bool TokenReader::next(std::string_view* token) {
  while (p_ < end_) {
    const char c = *p_;
    if (c == '\n') {
      ++line_;
    } else if (!is_blank(c)) {
      break;
    }
    ++p_;
  }
  if (p_ >= end_) return false;
  const char* start = p_;
  while (p_ < end_ && *p_ != '\n' && !is_blank(*p_)) ++p_;
  *token = std::string_view(start, size_t(p_ - start));
  return true;
}

void TokenReader::skip_line() {
  const char* nl = static_cast<const char*>(std::memchr(p_, '\n', size_t(end_ - p_)));
  if (nl) {
    p_ = nl + 1;
    ++line_;
  } else {
    p_ = end_;
  }
}

std::string_view trim(std::string_view s) {
  size_t b = 0, e = s.size();
  while (b < e && is_blank(s[b])) ++b;
  while (e > b && is_blank(s[e - 1])) --e;
  return s.substr(b, e - b);
}

std::string_view next_token(std::string_view* s) {
  size_t b = 0;
  while (b < s->size() && is_blank((*s)[b])) ++b;
  size_t e = b;
  while (e < s->size() && !is_blank((*s)[e])) ++e;
  std::string_view token = s->substr(b, e - b);
  s->remove_prefix(e);
  return token;
}

namespace {

// from_chars rejects a leading '+', which some writers emit.
std::string_view strip_plus(std::string_view t) {
  if (t.size() > 1 && t[0] == '+' && t[1] != '-' && t[1] != '+') t.remove_prefix(1);
  return t;
}

}  // namespace

Status push_fan_triangle(Mesh& mesh, uint32_t first, uint32_t prev, uint32_t v, const MeshLimits& limits,
                         const std::string& where) {
  if (mesh.face_count() >= limits.max_faces)
    return resource_exhausted(where + "the faces triangulate to more than " + std::to_string(limits.max_faces) +
                              " triangles (the limit is " + std::to_string(limits.max_faces) + ")");
  mesh.indices.insert(mesh.indices.end(), {first, prev, v});
  return Status::Ok();
}

namespace {

// from_chars over the whole token (after an optional '+'); false when the
// token is empty or has trailing characters.
template <class T>
bool from_chars_whole(std::string_view token, T* out, std::errc* ec) {
  token = strip_plus(token);
  if (token.empty()) return false;
  const auto result = std::from_chars(token.data(), token.data() + token.size(), *out);
  *ec = result.ec;
  return result.ptr == token.data() + token.size();
}

}  // namespace

bool parse_double(std::string_view token, double* out) {
  std::errc ec{};
  if (!from_chars_whole(token, out, &ec)) return false;
  if (ec == std::errc::result_out_of_range) {
    // from_chars leaves *out untouched here; strtod gives +-HUGE_VAL or a
    // value near zero, which is what the number means. The copy makes the
    // token NUL-terminated (the input buffer is not).
    const std::string copy(strip_plus(token));
    *out = std::strtod(copy.c_str(), nullptr);
    return true;
  }
  return ec == std::errc();
}

bool parse_float(std::string_view token, float* out) {
  std::errc ec{};
  if (!from_chars_whole(token, out, &ec)) return false;
  if (ec == std::errc::result_out_of_range) {
    double d = 0;
    if (!parse_double(token, &d)) return false;
    *out = to_float(d);
    return true;
  }
  return ec == std::errc();
}

float to_float(double v) {
  if (v > double(FLT_MAX)) return HUGE_VALF;
  if (v < -double(FLT_MAX)) return -HUGE_VALF;
  return static_cast<float>(v);  // NaN compares false above and stays NaN
}

bool parse_int(std::string_view token, int64_t* out) {
  token = strip_plus(token);
  if (token.empty()) return false;
  const char* b = token.data();
  const char* e = b + token.size();
  auto [ptr, ec] = std::from_chars(b, e, *out);
  return ec == std::errc() && ptr == e;
}

uint16_t linear16(uint8_t srgb) {
  return uint16_t(std::lround(double(srgb_to_linear(srgb)) * 65535));
}

uint8_t unit_to_byte(double value) {
  if (!(value > 0)) return 0;
  if (value >= 1) return 255;
  return uint8_t(std::lround(value * 255));
}

std::string quote(std::string_view token) {
  constexpr size_t kMaxShown = 32;
  std::string out = "'";
  for (size_t i = 0; i < token.size() && i < kMaxShown; ++i) {
    const unsigned char c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += char(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    }
  }
  if (token.size() > kMaxShown) out += "...";
  out += "'";
  return out;
}

// ---- Files ------------------------------------------------------------------

StatusOr<std::vector<uint8_t>> read_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return invalid_argument("cannot read '" + path + "': it is a directory");
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return not_found("cannot open '" + path + "': " + std::strerror(errno));
  std::vector<uint8_t> bytes;
  Status status;
  try {
    if (std::fseek(f, 0, SEEK_END) == 0) {
      const long size = std::ftell(f);
      if (size > 0) bytes.reserve(size_t(size));
      std::rewind(f);
    }
    // Read in chunks rather than trusting ftell alone (pipes, files that grow).
    uint8_t chunk[1 << 16];
    size_t n;
    while ((n = std::fread(chunk, 1, sizeof chunk, f)) > 0) bytes.insert(bytes.end(), chunk, chunk + n);
    if (std::ferror(f)) status = internal_error("cannot read '" + path + "': " + std::strerror(errno));
  } catch (const std::bad_alloc&) {
    status = resource_exhausted("cannot read '" + path + "': out of memory after " + std::to_string(bytes.size()) +
                                " bytes");
  }
  std::fclose(f);
  if (!status.ok()) return status;
  return bytes;
}

Status write_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  auto open_error = [&](int err) {
    const std::string message = "cannot write '" + path + "': " + std::strerror(err);
    if (err == ENOENT || err == ENOTDIR) return not_found(message);
    if (err == ENOSPC || err == EDQUOT || err == EFBIG) return resource_exhausted(message);
    return internal_error(message);
  };
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return open_error(errno);
  const size_t written = bytes.empty() ? 0 : std::fwrite(bytes.data(), 1, bytes.size(), f);
  const int write_errno = errno;
  if (written != bytes.size()) {
    std::fclose(f);
    return open_error(write_errno);
  }
  if (std::fclose(f) != 0) return open_error(errno);
  return Status::Ok();
}

// Writers refuse what would crash an encoder or produce an unreadable file.
Status check_writable(const Mesh& mesh, const float* saliency) {
  if (mesh.positions.size() % 3 != 0 || mesh.indices.size() % 3 != 0)
    return invalid_argument("cannot write a mesh whose arrays are not multiples of 3");
  const size_t nv = mesh.vertex_count();
  if (nv > UINT32_MAX) return invalid_argument("cannot write more than 2^32 - 1 vertices");
  for (size_t i = 0; i < mesh.indices.size(); ++i) {
    if (mesh.indices[i] >= nv)
      return invalid_argument("cannot write: face " + std::to_string(i / 3) + " references vertex " +
                              std::to_string(mesh.indices[i]) + " but the mesh has " + std::to_string(nv) +
                              " vertices");
  }
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    if (!std::isfinite(mesh.positions[i]))
      return invalid_argument("cannot write: vertex " + std::to_string(i / 3) +
                              " has a non-finite coordinate (NaN or infinity)");
  }
  if (saliency) {
    for (size_t i = 0; i < nv; ++i) {
      if (!std::isfinite(saliency[i]))
        return invalid_argument("cannot write: saliency of vertex " + std::to_string(i) + " is not finite");
    }
  }
  if (!mesh.colors.empty() && mesh.colors.size() != 3 * nv)
    return invalid_argument("cannot write " + std::to_string(mesh.colors.size()) + " color bytes for " +
                            std::to_string(nv) + " vertices (3 per vertex are needed)");
  return Status::Ok();
}

}  // namespace io_detail

// ---- Public API -------------------------------------------------------------

namespace {

using namespace io_detail;

constexpr const char* kSupported = "(supported: .drc .glb .gltf .obj .ply .off .stl)";

const char* format_name(MeshFormat format) {
  switch (format) {
    case MeshFormat::kDraco:
      return "Draco";
    case MeshFormat::kObj:
      return "OBJ";
    case MeshFormat::kPly:
      return "PLY";
    case MeshFormat::kOff:
      return "OFF";
    case MeshFormat::kStl:
      return "STL";
    case MeshFormat::kGltf:
      return "glTF";
  }
  return "mesh";
}

// Adds context in front of a failure's message, keeping its code.
Status prefixed(const Status& status, const std::string& prefix) {
  if (status.ok()) return status;
  return Status(status.code(), prefix + status.message());
}

StatusOr<Mesh> parse_format(const uint8_t* data, size_t size, MeshFormat format, const MeshLimits& limits,
                            std::vector<float>* saliency, const std::string* base_dir) {
  switch (format) {
    case MeshFormat::kDraco:
      return parse_draco(data, size, limits, saliency);
    case MeshFormat::kObj:
      return parse_obj(data, size, limits);
    case MeshFormat::kPly:
      return parse_ply(data, size, limits, saliency);
    case MeshFormat::kOff:
      return parse_off(data, size, limits);
    case MeshFormat::kStl:
      return parse_stl(data, size, limits);
    case MeshFormat::kGltf:
      return parse_gltf(data, size, limits, saliency, base_dir);
  }
  return internal_error("unknown MeshFormat " + std::to_string(int(format)));
}

StatusOr<Mesh> parse_any(const uint8_t* data, size_t size, MeshFormat format, const MeshLimits& limits,
                         std::vector<float>* saliency, const std::string* base_dir = nullptr) {
  assert(data != nullptr || size == 0);
  if (saliency) saliency->clear();
  const std::string name = format_name(format);
  if (size == 0) return invalid_argument(name + ": the input is empty (0 bytes)");
  try {
    StatusOr<Mesh> parsed = parse_format(data, size, format, limits, saliency, base_dir);
    if (!parsed.ok()) return parsed.status();
    // NaN/Inf, empty, point cloud, index range and size limits, reported the
    // same way for every format.
    VPR_RETURN_IF_ERROR(prefixed(validate_mesh(*parsed, limits), name + ": "));
    if (saliency && !saliency->empty() && saliency->size() != parsed->vertex_count())
      return internal_error(name + ": saliency has " + std::to_string(saliency->size()) + " values for " +
                            std::to_string(parsed->vertex_count()) + " vertices");
    return parsed;
  } catch (const std::bad_alloc&) {
    // Counts are checked against the limits and the data before anything is
    // sized from them; this is the machine running out below those limits.
    return resource_exhausted(name + ": out of memory while parsing " + std::to_string(size) + " bytes");
  } catch (const std::length_error&) {
    return resource_exhausted(name + ": out of memory while parsing " + std::to_string(size) + " bytes");
  }
}

// The folder a glTF file's relative external buffers are read from.
std::string folder_of(const std::string& path) {
  const std::string parent = std::filesystem::path(path).parent_path().string();
  return parent.empty() ? "." : parent;
}

}  // namespace

StatusOr<MeshFormat> format_from_path(const std::string& path) {
  const std::filesystem::path p(path);
  std::string ext = p.extension().string();
  if (ext.empty()) return invalid_argument("'" + path + "' has no file extension " + kSupported);
  std::string lower = ext;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (lower == ".drc") return MeshFormat::kDraco;
  if (lower == ".obj") return MeshFormat::kObj;
  if (lower == ".ply") return MeshFormat::kPly;
  if (lower == ".off") return MeshFormat::kOff;
  if (lower == ".stl") return MeshFormat::kStl;
  if (lower == ".glb" || lower == ".gltf") return MeshFormat::kGltf;
  return invalid_argument("unsupported format '" + ext + "' " + kSupported);
}

StatusOr<Mesh> parse_mesh(const uint8_t* data, size_t size, MeshFormat format, const MeshLimits& limits) {
  return parse_any(data, size, format, limits, nullptr);
}

StatusOr<Mesh> read_mesh(const std::string& path, const MeshLimits& limits) {
  VPR_ASSIGN_OR_RETURN(const MeshFormat format, format_from_path(path));
  VPR_ASSIGN_OR_RETURN(const std::vector<uint8_t> bytes, read_file(path));
  const std::string folder = folder_of(path);
  StatusOr<Mesh> mesh = parse_any(bytes.data(), bytes.size(), format, limits, nullptr, &folder);
  if (!mesh.ok()) return prefixed(mesh.status(), path + ": ");
  return mesh;
}

StatusOr<std::vector<float>> read_saliency(const std::string& path) {
  VPR_ASSIGN_OR_RETURN(const MeshFormat format, format_from_path(path));
  VPR_ASSIGN_OR_RETURN(const std::vector<uint8_t> bytes, read_file(path));
  std::vector<float> saliency;
  // Only Draco, glTF and PLY carry the value itself; OBJ colors are a lossy ramp.
  const std::string folder = folder_of(path);
  StatusOr<Mesh> mesh = parse_any(bytes.data(), bytes.size(), format, MeshLimits{}, &saliency, &folder);
  if (!mesh.ok()) return prefixed(mesh.status(), path + ": ");
  return saliency;
}

Status write_mesh(const std::string& path, const Mesh& mesh, const float* saliency, const DracoOptions& options) {
  VPR_ASSIGN_OR_RETURN(const MeshFormat format, format_from_path(path));
  VPR_RETURN_IF_ERROR(check_writable(mesh, saliency));
  std::vector<uint8_t> bytes;
  switch (format) {
    case MeshFormat::kDraco: {
      VPR_ASSIGN_OR_RETURN(bytes, encode_draco(mesh, saliency, options));
      break;
    }
    case MeshFormat::kGltf: {
      const std::string ext = std::filesystem::path(path).extension().string();
      const bool binary = ext.size() == 4;  // ".glb"; ".gltf" is JSON
      VPR_ASSIGN_OR_RETURN(bytes, encode_gltf(mesh, saliency, options, binary));
      break;
    }
    case MeshFormat::kPly:
      bytes = encode_ply(mesh, saliency);
      break;
    case MeshFormat::kObj:
      bytes = encode_obj(mesh, saliency);
      break;
    case MeshFormat::kOff:
    case MeshFormat::kStl:
      return invalid_argument("cannot write '" + path + "': " + format_name(format) +
                              " is an input format only (output formats: .drc .glb .gltf .obj .ply)");
  }
  return write_file(path, bytes);
}

void saliency_color(float value, uint8_t rgb[3]) {
  // Five stops, evenly spaced: blue, cyan, green, yellow, red.
  static const float kStops[5][3] = {{0, 0, 255}, {0, 255, 255}, {0, 255, 0}, {255, 255, 0}, {255, 0, 0}};
  float t = std::isfinite(value) ? std::min(1.0f, std::max(0.0f, value)) : 0.0f;
  const float x = t * 4.0f;
  const int i = std::min(3, int(x));
  const float f = x - float(i);
  for (int c = 0; c < 3; ++c) {
    const float v = kStops[i][c] + f * (kStops[i + 1][c] - kStops[i][c]);
    rgb[c] = uint8_t(std::lround(v));
  }
}

}  // namespace vpr
