// Object File Format (ASCII): an optional [ST][C][N][n]OFF keyword, the counts
// "#V #F [#E]" (on the keyword's line or the next), #V vertex lines whose first
// three numbers are the position, then #F lines "n i0 .. i(n-1) [color]"
// triangulated as fans. '#' starts a comment anywhere; blank lines are
// skipped. With C in the keyword, the vertex colors after the position (and
// the normal, with N) are read: r g b [a], integers in 0..255 or numbers with
// a point in [0, 1] (Geomview's two forms); a vertex with another form of
// color (a colormap index) is white. Normals, texture coordinates and face
// colors are ignored.
#include <algorithm>
#include <cstring>
#include <string>

#include "io/parsers.h"

namespace vpr::io_detail {

namespace {

// Lines with comments removed, blank ones skipped.
class ContentLines {
 public:
  ContentLines(const char* begin, const char* end) : lines_(begin, end) {}
  bool next(std::string_view* line) {
    std::string_view raw;
    while (lines_.next(&raw)) {
      const size_t hash = raw.find('#');
      if (hash != std::string_view::npos) raw = raw.substr(0, hash);
      raw = trim(raw);
      if (!raw.empty()) {
        *line = raw;
        return true;
      }
    }
    return false;
  }
  size_t line_number() const { return lines_.line_number(); }

 private:
  LineReader lines_;
};

std::string at_line(size_t line) {
  return "OFF line " + std::to_string(line) + ": ";
}

// "OFF", "COFF", "NOFF", "CNOFF", "STOFF", "4OFF", "nOFF" ...
bool is_off_keyword(std::string_view token) {
  if (token.size() < 3 || token.substr(token.size() - 3) != "OFF") return false;
  for (char c : token.substr(0, token.size() - 3)) {
    if (std::strchr("STCN4n", c) == nullptr) return false;
  }
  return true;
}

// The color on a COFF vertex line after the position: white unless it is
// r g b [a] in one of Geomview's forms.
void read_vertex_color(std::string_view rest, bool normals, bool texture_coordinates, std::vector<uint8_t>* colors) {
  std::string_view token[9];
  size_t n = 0;
  for (std::string_view t = next_token(&rest); !t.empty() && n < 9; t = next_token(&rest)) token[n++] = t;
  const size_t skip = normals ? 3 : 0;
  const size_t count = n >= skip + (texture_coordinates ? 2 : 0) ? n - skip - (texture_coordinates ? 2 : 0) : 0;
  uint8_t rgb[3] = {255, 255, 255};
  if (count == 3 || count == 4) {
    int64_t whole[3];
    double unit[3];
    bool integers = true, numbers = true;
    for (size_t c = 0; c < 3; ++c) {
      integers = integers && parse_int(token[skip + c], &whole[c]);
      numbers = numbers && parse_double(token[skip + c], &unit[c]);
    }
    for (size_t c = 0; c < 3 && numbers; ++c)
      rgb[c] = integers ? unit_to_byte(double(whole[c]) / 255) : unit_to_byte(unit[c]);
  }
  colors->insert(colors->end(), rgb, rgb + 3);
}

}  // namespace

StatusOr<Mesh> parse_off(const uint8_t* data, size_t size, const MeshLimits& limits) {
  const char* begin = reinterpret_cast<const char*>(data);
  const char* end = begin + size;
  if (size >= 3 && std::memcmp(begin, "\xEF\xBB\xBF", 3) == 0) begin += 3;
  ContentLines lines(begin, end);

  std::string_view line;
  if (!lines.next(&line))
    return invalid_argument("OFF: the file has no header and no counts (only blanks or comments)");
  std::string_view rest = line;
  std::string_view first = next_token(&rest);
  bool colors = false, normals = false, texture_coordinates = false;
  if (is_off_keyword(first)) {
    const std::string_view prefix = first.substr(0, first.size() - 3);
    colors = prefix.find('C') != std::string_view::npos;
    normals = prefix.find('N') != std::string_view::npos;
    texture_coordinates = prefix.find("ST") != std::string_view::npos;
    if (prefix.find('4') != std::string_view::npos)
      return invalid_argument(at_line(lines.line_number()) + quote(first) + ": 4D vertices are not supported");
    if (trim(rest).substr(0, 6) == "BINARY")
      return invalid_argument(at_line(lines.line_number()) + "binary OFF is not supported (use ASCII OFF, PLY or STL)");
    if (prefix.find('n') != std::string_view::npos) {
      // nOFF: the vertex dimension comes first.
      if (trim(rest).empty() && !lines.next(&rest))
        return invalid_argument("OFF: file ends before the vertex dimension of " + quote(first));
      const std::string_view dim = next_token(&rest);
      int64_t d = 0;
      if (!parse_int(dim, &d) || d != 3)
        return invalid_argument(at_line(lines.line_number()) + "vertex dimension " + quote(dim) +
                                " is not supported (only 3)");
    }
    if (trim(rest).empty() && !lines.next(&rest)) return invalid_argument("OFF: file ends before the counts line");
  } else {
    rest = line;  // no keyword: the first line holds the counts
  }

  const size_t counts_line = lines.line_number();
  int64_t counts[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const std::string_view token = next_token(&rest);
    if (!parse_int(token, &counts[k]) || counts[k] < 0)
      return invalid_argument(at_line(counts_line) + "expected the counts '#vertices #faces [#edges]', found " +
                              quote(token.empty() ? std::string_view("end of line") : token));
  }
  const uint64_t nv = uint64_t(counts[0]), nf = uint64_t(counts[1]);
  if (nv > limits.max_vertices)
    return resource_exhausted("OFF: the header declares " + std::to_string(nv) + " vertices, the limit is " +
                              std::to_string(limits.max_vertices));
  if (nf > limits.max_faces)
    return resource_exhausted("OFF: the header declares " + std::to_string(nf) + " faces, the limit is " +
                              std::to_string(limits.max_faces));

  Mesh mesh;
  std::vector<double> positions;
  // A vertex line is at least "0 0 0\n" (6 bytes), a face line "3 0 0 0\n".
  positions.reserve(3 * std::min<uint64_t>(nv, size / 6 + 1));
  mesh.indices.reserve(3 * std::min<uint64_t>(nf, size / 8 + 1));
  for (uint64_t i = 0; i < nv; ++i) {
    if (!lines.next(&line))
      return invalid_argument("OFF: file ends after " + std::to_string(i) + " of " + std::to_string(nv) + " vertices");
    rest = line;
    for (int k = 0; k < 3; ++k) {
      const std::string_view token = next_token(&rest);
      double v = 0;
      if (token.empty())
        return invalid_argument(at_line(lines.line_number()) + "vertex " + std::to_string(i) + " has " +
                                std::to_string(k) + " coordinates, 3 are needed");
      if (!parse_double(token, &v))
        return invalid_argument(at_line(lines.line_number()) + "vertex coordinate " + quote(token) +
                                " is not a number");
      positions.push_back(v);
    }
    if (colors) read_vertex_color(rest, normals, texture_coordinates, &mesh.colors);
  }
  for (uint64_t i = 0; i < nf; ++i) {
    if (!lines.next(&line))
      return invalid_argument("OFF: file ends after " + std::to_string(i) + " of " + std::to_string(nf) + " faces");
    const size_t n_line = lines.line_number();
    rest = line;
    const std::string_view count_token = next_token(&rest);
    int64_t n = 0;
    if (!parse_int(count_token, &n))
      return invalid_argument(at_line(n_line) + "face vertex count " + quote(count_token) + " is not an integer");
    if (n < 3)
      return invalid_argument(at_line(n_line) + "face has " + std::to_string(n) + " vertices, at least 3 are needed");
    uint32_t first = 0, prev = 0;
    for (int64_t k = 0; k < n; ++k) {
      const std::string_view token = next_token(&rest);
      if (token.empty())
        return invalid_argument(at_line(n_line) + "face announces " + std::to_string(n) + " vertices but lists " +
                                std::to_string(k));
      int64_t index = 0;
      if (!parse_int(token, &index))
        return invalid_argument(at_line(n_line) + "face index " + quote(token) + " is not an integer");
      if (index < 0 || uint64_t(index) >= nv)
        return invalid_argument(at_line(n_line) + "face index " + std::to_string(index) +
                                " is out of range (the file has " + std::to_string(nv) + " vertices)");
      const uint32_t v = uint32_t(index);
      if (k == 0) first = v;
      if (k >= 2) VPR_RETURN_IF_ERROR(push_fan_triangle(mesh, first, prev, v, limits, at_line(n_line)));
      prev = v;
    }
    // Anything after the indices is a face color; ignored.
  }
  Mesh out = mesh_from_absolute(positions, std::move(mesh.indices));
  out.colors = std::move(mesh.colors);
  return out;
}

}  // namespace vpr::io_detail
