// Wavefront OBJ: "v x y z [w | r g b]" and "f" lines whose tokens are v,
// v/vt, v//vn or v/vt/vn, 1-based or negative (relative to the vertices read
// so far). Polygons become triangle fans; every other line is ignored. Colors
// (r g b in [0, 1], clamped: the common extension MeshLab and others write)
// are kept when any vertex has them; vertices without are white. Materials
// and their textures (mtllib, usemtl, vt) are not read.
#include <charconv>
#include <cstring>
#include <string>

#include "io/mesh_io.h"
#include "io/parsers.h"

namespace vpr::io_detail {

namespace {

std::string at_line(size_t line) {
  return "OBJ line " + std::to_string(line) + ": ";
}

// Appends the shortest text that reads back as exactly the same float.
void append_float(std::string* out, float v) {
  char buf[32];
  auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  (void)ec;  // 32 bytes always hold a float
  out->append(buf, end);
}

void append_double(std::string* out, double v) {
  char buf[32];
  auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  (void)ec;  // 32 bytes always hold a double
  out->append(buf, end);
}

void append_uint(std::string* out, uint64_t v) {
  char buf[24];
  auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  (void)ec;
  out->append(buf, end);
}

}  // namespace

StatusOr<Mesh> parse_obj(const uint8_t* data, size_t size, const MeshLimits& limits) {
  const char* begin = reinterpret_cast<const char*>(data);
  const char* end = begin + size;
  if (size >= 3 && std::memcmp(begin, "\xEF\xBB\xBF", 3) == 0) begin += 3;  // UTF-8 byte order mark

  Mesh mesh;                      // faces and colors; positions come from `positions` at the end
  std::vector<double> positions;  // as written, in double
  bool saliency_ramp = false;     // the colors are our writer's saliency ramp: not read
  LineReader lines(begin, end);
  std::string_view line;
  while (lines.next(&line)) {
    std::string_view rest = line;
    const std::string_view key = next_token(&rest);
    if (!key.empty() && key[0] == '#' && line.find("vpremesh") != std::string_view::npos &&
        line.find(kSaliencyRampNote) != std::string_view::npos) {
      saliency_ramp = true;
      mesh.colors.clear();
    } else if (key == "v") {
      double xyz[3];
      for (int k = 0; k < 3; ++k) {
        const std::string_view token = next_token(&rest);
        if (token.empty())
          return invalid_argument(at_line(lines.line_number()) + "vertex has " + std::to_string(k) +
                                  " coordinates, 3 are needed");
        if (!parse_double(token, &xyz[k]))
          return invalid_argument(at_line(lines.line_number()) + "vertex coordinate " + quote(token) +
                                  " is not a number");
      }
      if (positions.size() / 3 >= limits.max_vertices)
        return resource_exhausted(at_line(lines.line_number()) + "the file has more than " +
                                  std::to_string(limits.max_vertices) + " vertices (the limit is " +
                                  std::to_string(limits.max_vertices) + ")");
      // A fourth w, or r g b, may follow; three numbers and nothing else are colors.
      std::string_view extra[4];
      int n = 0;
      for (std::string_view token = next_token(&rest); !token.empty() && n < 4; token = next_token(&rest))
        extra[n++] = token;
      double rgb[3];
      const bool has_color = n == 3 && parse_double(extra[0], &rgb[0]) && parse_double(extra[1], &rgb[1]) &&
                             parse_double(extra[2], &rgb[2]);
      if (has_color && !saliency_ramp) {
        if (mesh.colors.empty()) mesh.colors.assign(positions.size(), 255);  // white so far
        for (double c : rgb) mesh.colors.push_back(unit_to_byte(c));
      } else if (!mesh.colors.empty()) {
        mesh.colors.insert(mesh.colors.end(), {255, 255, 255});
      }
      positions.insert(positions.end(), xyz, xyz + 3);
    } else if (key == "f") {
      const int64_t nv = int64_t(positions.size() / 3);
      uint32_t first = 0, prev = 0;
      size_t corners = 0;
      for (std::string_view token = next_token(&rest); !token.empty(); token = next_token(&rest)) {
        // Only the position index matters: v, v/vt, v//vn, v/vt/vn.
        const std::string_view vpart = token.substr(0, token.find('/'));
        int64_t index = 0;
        if (!parse_int(vpart, &index))
          return invalid_argument(at_line(lines.line_number()) + "face vertex " + quote(token) +
                                  " does not start with an integer index");
        int64_t resolved;
        if (index > 0) {
          resolved = index - 1;
        } else if (index < 0) {
          resolved = nv + index;  // -1 is the last vertex read so far
        } else {
          return invalid_argument(at_line(lines.line_number()) +
                                  "face index 0 is invalid (OBJ indices start at 1, negative ones count back)");
        }
        if (resolved < 0 || resolved >= nv)
          return invalid_argument(at_line(lines.line_number()) + "face index " + std::to_string(index) +
                                  " is out of range (the file has " + std::to_string(nv) + " vertices so far)");
        const uint32_t v = uint32_t(resolved);
        if (corners == 0) first = v;
        if (corners >= 2)
          VPR_RETURN_IF_ERROR(push_fan_triangle(mesh, first, prev, v, limits, at_line(lines.line_number())));
        prev = v;
        ++corners;
      }
      if (corners < 3)
        return invalid_argument(at_line(lines.line_number()) + "face has " + std::to_string(corners) +
                                " vertices, at least 3 are needed");
    }
  }
  Mesh out = mesh_from_absolute(positions, std::move(mesh.indices));
  out.colors = std::move(mesh.colors);
  return out;
}

std::vector<uint8_t> encode_obj(const Mesh& mesh, const float* saliency) {
  std::string out;
  // Real colors when the mesh has them; else, with saliency, its color ramp.
  const bool ramp = saliency && mesh.colors.empty();
  const bool colors = ramp || !mesh.colors.empty();
  out.reserve(mesh.vertex_count() * (colors ? 64 : 36) + mesh.face_count() * 24 + 64);
  out += "# vpremesh: ";
  append_uint(&out, mesh.vertex_count());
  out += " vertices, ";
  append_uint(&out, mesh.face_count());
  out += ramp ? std::string(" triangles, ") + kSaliencyRampNote + "\n" : std::string(" triangles\n");
  // Floats where they hold the model to 1e-6 of its size, else the origin
  // plus the relative float in double, as many digits as that takes.
  const bool as_float = absolute_fits_float(mesh);
  const std::vector<float> absolute = as_float ? absolute_positions(mesh) : std::vector<float>();
  for (size_t i = 0; i < mesh.vertex_count(); ++i) {
    out += "v";
    for (int a = 0; a < 3; ++a) {
      out += ' ';
      if (as_float)
        append_float(&out, absolute[3 * i + size_t(a)]);
      else
        append_double(&out, writable_absolute(mesh, i, a));
    }
    if (colors) {
      uint8_t rgb[3];
      if (ramp)
        saliency_color(saliency[i], rgb);
      else
        std::memcpy(rgb, &mesh.colors[3 * i], 3);
      for (uint8_t c : rgb) {
        out += ' ';
        append_float(&out, float(c) / 255.0f);
      }
    }
    out += '\n';
  }
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    out += 'f';
    for (int k = 0; k < 3; ++k) {
      out += ' ';
      append_uint(&out, uint64_t(mesh.indices[3 * f + k]) + 1);
    }
    out += '\n';
  }
  return std::vector<uint8_t>(out.begin(), out.end());
}

}  // namespace vpr::io_detail
