// Stanford PLY: ascii, binary_little_endian and binary_big_endian. The vertex
// element gives x, y, z (any scalar type, among any other properties, lists
// included) and optionally "saliency" and colors red, green, blue (or
// diffuse_red, ...: uchar as they are, ushort over 65535, float and double in
// [0, 1], other integers clamped to 0..255); the face element gives a list named
// vertex_indices or vertex_index (any count and index types), triangulated as
// a fan. Every other element is skipped.
#include <algorithm>
#include <cstring>
#include <string>

#include "io/mesh_io.h"
#include "io/parsers.h"

namespace vpr {
namespace io_detail {

namespace {

enum class PlyType : uint8_t { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool ply_type_from_name(std::string_view name, PlyType* type) {
  static const struct {
    const char* name;
    PlyType type;
  } kNames[] = {{"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
                {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
                {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
                {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
                {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
                {"float64", PlyType::kFloat64}};
  for (const auto& entry : kNames) {
    if (name == entry.name) {
      *type = entry.type;
      return true;
    }
  }
  return false;
}

size_t ply_type_size(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 1;
}

bool ply_type_is_integer(PlyType t) {
  return t != PlyType::kFloat32 && t != PlyType::kFloat64;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;  // the item type for lists
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyEncoding { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::kAscii;
  std::vector<PlyElement> elements;
  size_t body_offset = 0;  // bytes from the start of the data
  size_t body_line = 0;    // line number of the first body line (ASCII messages)
  bool saliency_ramp = false;  // the colors are our writer's saliency ramp (kSaliencyRampNote)
};

std::string header_line(size_t line) {
  return "PLY header line " + std::to_string(line) + ": ";
}

StatusOr<PlyHeader> parse_ply_header(const char* begin, const char* end, const MeshLimits& limits) {
  LineReader lines(begin, end);
  std::string_view line;
  if (!lines.next(&line) || trim(line) != "ply")
    return invalid_argument("PLY: the file does not start with the line 'ply'");
  PlyHeader header;
  bool have_format = false;
  while (true) {
    if (!lines.next(&line)) return invalid_argument("PLY: the header has no end_header line");
    const size_t n = lines.line_number();
    std::string_view rest = line;
    const std::string_view key = next_token(&rest);
    if (key == "comment" && rest.find("vpremesh") != std::string_view::npos &&
        rest.find(kSaliencyRampNote) != std::string_view::npos)
      header.saliency_ramp = true;
    if (key.empty() || key == "comment" || key == "obj_info") continue;
    if (key == "end_header") {
      header.body_offset = size_t(lines.position() - begin);
      header.body_line = n + 1;
      break;
    }
    if (key == "format") {
      const std::string_view encoding = next_token(&rest);
      if (encoding == "ascii") {
        header.encoding = PlyEncoding::kAscii;
      } else if (encoding == "binary_little_endian") {
        header.encoding = PlyEncoding::kBinaryLittleEndian;
      } else if (encoding == "binary_big_endian") {
        header.encoding = PlyEncoding::kBinaryBigEndian;
      } else {
        return invalid_argument(header_line(n) + "unknown format " + quote(encoding) +
                                " (expected ascii, binary_little_endian or binary_big_endian)");
      }
      have_format = true;
    } else if (key == "element") {
      PlyElement element;
      element.name = std::string(next_token(&rest));
      const std::string_view count = next_token(&rest);
      int64_t value = 0;
      if (element.name.empty() || !parse_int(count, &value) || value < 0)
        return invalid_argument(header_line(n) + "expected 'element <name> <count>', found " + quote(line));
      element.count = uint64_t(value);
      // Fail before reading the body when the declared size is over the limit.
      if (element.name == "vertex" && element.count > limits.max_vertices)
        return resource_exhausted("PLY: the header declares " + std::to_string(element.count) +
                                  " vertices, the limit is " + std::to_string(limits.max_vertices));
      if (element.name == "face" && element.count > limits.max_faces)
        return resource_exhausted("PLY: the header declares " + std::to_string(element.count) +
                                  " faces, the limit is " + std::to_string(limits.max_faces));
      header.elements.push_back(std::move(element));
    } else if (key == "property") {
      if (header.elements.empty()) return invalid_argument(header_line(n) + "property before any element");
      PlyProperty property;
      std::string_view type = next_token(&rest);
      if (type == "list") {
        property.is_list = true;
        const std::string_view count_type = next_token(&rest);
        if (!ply_type_from_name(count_type, &property.count_type) || !ply_type_is_integer(property.count_type))
          return invalid_argument(header_line(n) + "list count type " + quote(count_type) + " is not an integer type");
        type = next_token(&rest);
      }
      if (!ply_type_from_name(type, &property.type))
        return invalid_argument(header_line(n) + "unknown property type " + quote(type));
      property.name = std::string(next_token(&rest));
      if (property.name.empty()) return invalid_argument(header_line(n) + "property has no name");
      header.elements.back().properties.push_back(std::move(property));
    } else {
      return invalid_argument(header_line(n) + "unknown keyword " + quote(key));
    }
  }
  if (!have_format) return invalid_argument("PLY: the header has no format line");
  return header;
}

// ---- Value sources: one for binary data, one for ASCII tokens ---------------
// read() returns kEnd when the data ran out and kBad for a malformed token.

enum class Read { kOk, kEnd, kBad };

// A value of type T from little-endian bytes (memcpy: b need not be aligned).
template <class T>
double load(const uint8_t* b) {
  T v;
  std::memcpy(&v, b, sizeof v);
  return double(v);
}

class BinarySource {
 public:
  BinarySource(const uint8_t* p, const uint8_t* end, bool big_endian) : p_(p), end_(end), big_(big_endian) {}

  Read read(PlyType t, double* out) {
    const size_t n = ply_type_size(t);
    if (size_t(end_ - p_) < n) return Read::kEnd;
    uint8_t b[8];
    if (big_) {
      for (size_t i = 0; i < n; ++i) b[i] = p_[n - 1 - i];
    } else {
      std::memcpy(b, p_, n);
    }
    p_ += n;
    switch (t) {
      case PlyType::kInt8:
        *out = load<int8_t>(b);
        break;
      case PlyType::kUint8:
        *out = load<uint8_t>(b);
        break;
      case PlyType::kInt16:
        *out = load<int16_t>(b);
        break;
      case PlyType::kUint16:
        *out = load<uint16_t>(b);
        break;
      case PlyType::kInt32:
        *out = load<int32_t>(b);
        break;
      case PlyType::kUint32:
        *out = load<uint32_t>(b);
        break;
      case PlyType::kFloat32:
        *out = load<float>(b);
        break;
      case PlyType::kFloat64:
        *out = load<double>(b);
        break;
    }
    return Read::kOk;
  }
  // Integer-valued types only (checked by the caller); exact for 32 bits.
  Read read_int(PlyType t, int64_t* out) {
    double v = 0;
    const Read r = read(t, &v);
    *out = int64_t(v);
    return r;
  }
  Read skip(PlyType t, uint64_t count) {
    const uint64_t bytes = count * ply_type_size(t);  // count < 2^32, no overflow
    if (uint64_t(end_ - p_) < bytes) {
      p_ = end_;
      return Read::kEnd;
    }
    p_ += bytes;
    return Read::kOk;
  }
  size_t remaining() const { return size_t(end_ - p_); }
  std::string where() const { return "PLY: "; }
  std::string bad_token() const { return ""; }

 private:
  const uint8_t* p_;
  const uint8_t* end_;
  bool big_;
};

class AsciiSource {
 public:
  AsciiSource(const char* p, const char* end, size_t first_line)
      : tokens_(p, end), first_line_(first_line), size_(size_t(end - p)) {}

  Read read(PlyType, double* out) {
    if (!tokens_.next(&token_)) return Read::kEnd;
    return parse_double(token_, out) ? Read::kOk : Read::kBad;
  }
  Read read_int(PlyType, int64_t* out) {
    if (!tokens_.next(&token_)) return Read::kEnd;
    return parse_int(token_, out) ? Read::kOk : Read::kBad;
  }
  Read skip(PlyType t, uint64_t count) {
    double ignored;
    for (uint64_t i = 0; i < count; ++i) {
      const Read r = read(t, &ignored);
      if (r != Read::kOk) return r;
    }
    return Read::kOk;
  }
  // An upper bound (the whole body), enough to cap reservations.
  size_t remaining() const { return size_; }
  std::string where() const { return "PLY line " + std::to_string(first_line_ + tokens_.line_number() - 1) + ": "; }
  std::string bad_token() const { return quote(token_); }

 private:
  TokenReader tokens_;
  size_t first_line_;
  size_t size_;
  std::string_view token_;
};

// The fewest bytes one element can occupy, to bound reservations by the data.
size_t min_element_bytes(const PlyElement& e, bool ascii) {
  size_t bytes = 0;
  for (const PlyProperty& p : e.properties) bytes += ascii ? 2 : ply_type_size(p.is_list ? p.count_type : p.type);
  return bytes == 0 ? 1 : bytes;
}

const char* plural(const std::string& element) {
  if (element == "vertex") return "vertices";
  if (element == "face") return "faces";
  return nullptr;
}

std::string ends_after(const PlyElement& e, uint64_t done) {
  const char* name = plural(e.name);
  return "PLY: file ends after " + std::to_string(done) + " of " + std::to_string(e.count) + " " +
         (name ? std::string(name) : "'" + e.name + "' elements");
}

template <class Source>
Status read_list_count(Source& src, const PlyElement& e, const PlyProperty& p, uint64_t i, uint64_t* count) {
  int64_t n = 0;
  const Read r = src.read_int(p.count_type, &n);
  if (r == Read::kEnd) return invalid_argument(ends_after(e, i));
  if (r == Read::kBad)
    return invalid_argument(src.where() + "list length " + src.bad_token() + " of " + e.name + " " + std::to_string(i) +
                            " is not an integer");
  if (n < 0 || n > int64_t(UINT32_MAX))
    return invalid_argument(src.where() + e.name + " " + std::to_string(i) + " has a list '" + p.name + "' of length " +
                            std::to_string(n));
  *count = uint64_t(n);
  return Status::Ok();
}

// Reads (into *value, when not null) or skips one property of element i.
template <class Source>
Status read_property(Source& src, const PlyElement& e, const PlyProperty& p, uint64_t i, double* value) {
  if (p.is_list) {
    uint64_t n = 0;
    VPR_RETURN_IF_ERROR(read_list_count(src, e, p, i, &n));
    const Read r = src.skip(p.type, n);
    if (r == Read::kEnd) return invalid_argument(ends_after(e, i));
    if (r == Read::kBad)
      return invalid_argument(src.where() + src.bad_token() + " is not a number (" + e.name + " " + std::to_string(i) +
                              ", list '" + p.name + "')");
    return Status::Ok();
  }
  double v = 0;
  const Read r = src.read(p.type, &v);
  if (r == Read::kEnd) return invalid_argument(ends_after(e, i));
  if (r == Read::kBad)
    return invalid_argument(src.where() + src.bad_token() + " is not a number (" + e.name + " " + std::to_string(i) +
                            ", property '" + p.name + "')");
  if (value) *value = v;
  return Status::Ok();
}

// A color channel of the given type as a byte (the file header's comment).
uint8_t color_byte(double value, PlyType type) {
  switch (type) {
    case PlyType::kFloat32:
    case PlyType::kFloat64:
      return unit_to_byte(value);
    case PlyType::kUint16:
      return unit_to_byte(value / 65535);
    default:
      return unit_to_byte(value / 255);
  }
}

template <class Source>
Status read_body(Source& src, const PlyHeader& header, bool ascii, const MeshLimits& limits, Mesh* mesh,
                 std::vector<double>* positions, std::vector<float>* saliency) {
  const PlyElement* vertex = nullptr;
  for (const PlyElement& e : header.elements) {
    if (e.name == "vertex") {
      if (vertex) return invalid_argument("PLY: the header has more than one vertex element");
      vertex = &e;
    }
  }
  if (!vertex) return invalid_argument("PLY: the header has no vertex element");
  const uint64_t nv = vertex->count;
  bool seen_face = false;

  for (const PlyElement& e : header.elements) {
    // Reserve no more than the remaining bytes could hold.
    const uint64_t plausible = std::min<uint64_t>(e.count, src.remaining() / min_element_bytes(e, ascii) + 1);
    if (&e == vertex) {
      // Roles: 0..2 = x, y, z; 3 = saliency; 4..6 = red, green, blue.
      constexpr int kRoles = 7;
      std::vector<int> roles(e.properties.size(), -1);
      bool have[kRoles] = {};
      PlyType color_type[3] = {};
      static const char* kRoleNames[kRoles] = {"x", "y", "z", "saliency", "red", "green", "blue"};
      static const char* kAliases[kRoles] = {"", "", "", "", "diffuse_red", "diffuse_green", "diffuse_blue"};
      for (size_t j = 0; j < e.properties.size(); ++j) {
        const std::string& name = e.properties[j].name;
        for (int r = 0; r < kRoles; ++r) {
          if ((name == kRoleNames[r] || name == kAliases[r]) && !have[r]) {
            if (e.properties[j].is_list) return invalid_argument("PLY: vertex property '" + name + "' is a list");
            roles[j] = r;
            have[r] = true;
            if (r >= 4) color_type[r - 4] = e.properties[j].type;
          }
        }
      }
      for (int r = 0; r < 3; ++r) {
        if (!have[r])
          return invalid_argument(std::string("PLY: the vertex element has no '") + kRoleNames[r] + "' property");
      }
      positions->reserve(3 * plausible);
      const bool want_saliency = saliency && have[3];
      if (want_saliency) saliency->reserve(plausible);
      const bool want_colors = have[4] && have[5] && have[6] && !header.saliency_ramp;
      if (want_colors) mesh->colors.reserve(3 * plausible);
      for (uint64_t i = 0; i < e.count; ++i) {
        double v[kRoles] = {};
        for (size_t j = 0; j < e.properties.size(); ++j)
          VPR_RETURN_IF_ERROR(read_property(src, e, e.properties[j], i, roles[j] >= 0 ? &v[roles[j]] : nullptr));
        positions->insert(positions->end(), v, v + 3);
        if (want_saliency) saliency->push_back(to_float(v[3]));
        if (want_colors)
          for (int c = 0; c < 3; ++c) mesh->colors.push_back(color_byte(v[4 + c], color_type[c]));
      }
    } else if (e.name == "face" && !seen_face) {
      seen_face = true;
      int list = -1;
      for (size_t j = 0; j < e.properties.size(); ++j) {
        const PlyProperty& p = e.properties[j];
        if ((p.name == "vertex_indices" || p.name == "vertex_index") && list < 0) {
          if (!p.is_list) return invalid_argument("PLY: face property '" + p.name + "' is not a list");
          if (!ply_type_is_integer(p.type))
            return invalid_argument("PLY: face property '" + p.name + "' has a non-integer index type");
          list = int(j);
        }
      }
      if (list < 0) return invalid_argument("PLY: the face element has no vertex_indices (or vertex_index) list");
      mesh->indices.reserve(3 * plausible);
      for (uint64_t i = 0; i < e.count; ++i) {
        for (size_t j = 0; j < e.properties.size(); ++j) {
          const PlyProperty& p = e.properties[j];
          if (int(j) != list) {
            // Other face properties (colors, texture coordinates) are skipped.
            VPR_RETURN_IF_ERROR(read_property(src, e, p, i, nullptr));
            continue;
          }
          uint64_t n = 0;
          VPR_RETURN_IF_ERROR(read_list_count(src, e, p, i, &n));
          if (n < 3)
            return invalid_argument("PLY: face " + std::to_string(i) + " has " + std::to_string(n) +
                                    " vertices, at least 3 are needed");
          uint32_t first = 0, prev = 0;
          for (uint64_t k = 0; k < n; ++k) {
            int64_t index = 0;
            const Read r = src.read_int(p.type, &index);
            if (r == Read::kEnd) return invalid_argument(ends_after(e, i));
            if (r == Read::kBad)
              return invalid_argument(src.where() + "vertex index " + src.bad_token() + " of face " +
                                      std::to_string(i) + " is not an integer");
            if (index < 0 || uint64_t(index) >= nv)
              return invalid_argument("PLY: face " + std::to_string(i) + " references vertex " + std::to_string(index) +
                                      " but the file has " + std::to_string(nv) + " vertices");
            const uint32_t v = uint32_t(index);
            if (k == 0) first = v;
            if (k >= 2) VPR_RETURN_IF_ERROR(push_fan_triangle(*mesh, first, prev, v, limits, "PLY: "));
            prev = v;
          }
        }
      }
    } else {
      if (e.properties.empty()) continue;  // occupies no bytes
      for (uint64_t i = 0; i < e.count; ++i) {
        for (const PlyProperty& p : e.properties) VPR_RETURN_IF_ERROR(read_property(src, e, p, i, nullptr));
      }
    }
  }
  return Status::Ok();
}

void put_bytes(std::vector<uint8_t>* out, const void* p, size_t n) {
  const uint8_t* b = static_cast<const uint8_t*>(p);
  out->insert(out->end(), b, b + n);
}

// Little-endian regardless of the host.
void put_u32(std::vector<uint8_t>* out, uint32_t v) {
  const uint8_t b[4] = {uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)};
  put_bytes(out, b, 4);
}

void put_f32(std::vector<uint8_t>* out, float f) {
  uint32_t v;
  std::memcpy(&v, &f, 4);
  put_u32(out, v);
}

void put_f64(std::vector<uint8_t>* out, double d) {
  uint64_t v;
  std::memcpy(&v, &d, 8);
  put_u32(out, uint32_t(v));
  put_u32(out, uint32_t(v >> 32));
}

}  // namespace

StatusOr<Mesh> parse_ply(const uint8_t* data, size_t size, const MeshLimits& limits, std::vector<float>* saliency) {
  const char* begin = reinterpret_cast<const char*>(data);
  const char* end = begin + size;
  VPR_ASSIGN_OR_RETURN(const PlyHeader header, parse_ply_header(begin, end, limits));
  Mesh mesh;  // faces; positions in double until the end
  std::vector<double> positions;
  std::vector<float> values;
  if (header.encoding == PlyEncoding::kAscii) {
    AsciiSource src(begin + header.body_offset, end, header.body_line);
    VPR_RETURN_IF_ERROR(read_body(src, header, true, limits, &mesh, &positions, &values));
  } else {
    BinarySource src(data + header.body_offset, data + size, header.encoding == PlyEncoding::kBinaryBigEndian);
    VPR_RETURN_IF_ERROR(read_body(src, header, false, limits, &mesh, &positions, &values));
  }
  if (saliency) *saliency = std::move(values);
  Mesh out = mesh_from_absolute(positions, std::move(mesh.indices));
  out.colors = std::move(mesh.colors);
  return out;
}

std::vector<uint8_t> encode_ply(const Mesh& mesh, const float* saliency) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  // Real colors when the mesh has them; else, with saliency, its color ramp.
  const bool colors = !mesh.colors.empty() || saliency;
  const bool ramp = saliency && mesh.colors.empty();
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment vpremesh\n";
  if (ramp) header += std::string("comment vpremesh: ") + kSaliencyRampNote + "\n";
  header += "element vertex " + std::to_string(nv) + "\n";
  // Floats where they hold the model to 1e-6 of its size, else doubles.
  const bool as_float = absolute_fits_float(mesh);
  header += as_float ? "property float x\nproperty float y\nproperty float z\n"
                     : "property double x\nproperty double y\nproperty double z\n";
  if (saliency) header += "property float saliency\n";
  if (colors) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  header += "element face " + std::to_string(nf) + "\n";
  header += "property list uchar uint vertex_indices\nend_header\n";

  std::vector<uint8_t> out;
  out.reserve(header.size() + nv * ((as_float ? 12 : 24) + (saliency ? 4 : 0) + (colors ? 3 : 0)) + nf * 13);
  put_bytes(&out, header.data(), header.size());
  const std::vector<float> absolute = as_float ? absolute_positions(mesh) : std::vector<float>();
  for (size_t i = 0; i < nv; ++i) {
    for (int a = 0; a < 3; ++a) {
      if (as_float)
        put_f32(&out, absolute[3 * i + size_t(a)]);
      else
        put_f64(&out, writable_absolute(mesh, i, a));
    }
    if (saliency) put_f32(&out, saliency[i]);
    if (ramp) {
      uint8_t rgb[3];
      saliency_color(saliency[i], rgb);
      put_bytes(&out, rgb, 3);
    } else if (colors) {
      put_bytes(&out, &mesh.colors[3 * i], 3);
    }
  }
  for (size_t f = 0; f < nf; ++f) {
    out.push_back(3);
    for (int k = 0; k < 3; ++k) put_u32(&out, mesh.indices[3 * f + k]);
  }
  return out;
}

}  // namespace io_detail

Status write_point_ply(const std::string& path, const float* points, size_t n, const uint8_t* colors) {
  using namespace io_detail;
  if (n > 0 && points == nullptr)
    return invalid_argument("write_point_ply: points is null for " + std::to_string(n) + " points");
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment vpremesh debug points\n";
  header += "element vertex " + std::to_string(n) + "\n";
  header += "property float x\nproperty float y\nproperty float z\n";
  if (colors) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  header += "end_header\n";
  std::vector<uint8_t> out;
  out.reserve(header.size() + n * (colors ? 15 : 12));
  put_bytes(&out, header.data(), header.size());
  for (size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) put_f32(&out, points[3 * i + a]);
    if (colors) put_bytes(&out, colors + 3 * i, 3);
  }
  return write_file(path, out);
}

}  // namespace vpr
