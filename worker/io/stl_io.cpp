// STL, binary and ASCII. Binary is recognised by its size (84 + 50 * n bytes,
// n from the header), not by the "solid" prefix, which many binary writers
// also put in their 80-byte header. STL stores three positions per facet and
// no sharing; exactly identical positions are merged (first occurrence keeps
// its index, so the order is deterministic) and the facets are kept as they
// are, duplicated or degenerate.
#include <cstring>
#include <string>
#include <unordered_map>

#include "io/parsers.h"

namespace vpr::io_detail {

namespace {

struct PositionKey {
  uint64_t bits[3];
  bool operator==(const PositionKey& o) const {
    return bits[0] == o.bits[0] && bits[1] == o.bits[1] && bits[2] == o.bits[2];
  }
};

struct PositionKeyHash {
  size_t operator()(const PositionKey& k) const {
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (uint64_t b : k.bits) h = (h ^ b) * 0xBF58476D1CE4E5B9ull;
    return size_t(h ^ (h >> 31));
  }
};

class VertexMerger {
 public:
  // positions: receives x, y, z of each distinct position, in double.
  VertexMerger(std::vector<double>* positions, size_t expected) : positions_(positions) { map_.reserve(expected); }
  uint32_t add(const double p[3]) {
    PositionKey key;
    for (int a = 0; a < 3; ++a) {
      // -0 and +0 are the same position.
      const double v = p[a] == 0.0 ? 0.0 : p[a];
      std::memcpy(&key.bits[a], &v, 8);
    }
    auto [it, inserted] = map_.try_emplace(key, uint32_t(positions_->size() / 3));
    if (inserted) positions_->insert(positions_->end(), p, p + 3);
    return it->second;
  }

 private:
  std::vector<double>* positions_;
  std::unordered_map<PositionKey, uint32_t, PositionKeyHash> map_;
};

float load_f32_le(const uint8_t* p) {
  const uint32_t v = uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}

bool iequals(std::string_view a, const char* b) {
  const size_t n = std::strlen(b);
  if (a.size() != n) return false;
  for (size_t i = 0; i < n; ++i) {
    char c = a[i];
    if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
    if (c != b[i]) return false;
  }
  return true;
}

Status too_many_facets(uint64_t n, const MeshLimits& limits) {
  return resource_exhausted("STL: " + std::to_string(n) + " facets, the limit is " + std::to_string(limits.max_faces) +
                            " faces");
}

StatusOr<Mesh> parse_binary_stl(const uint8_t* data, uint32_t n, const MeshLimits& limits) {
  if (n > limits.max_faces) return too_many_facets(n, limits);
  Mesh mesh;
  std::vector<double> positions;
  mesh.indices.reserve(3 * size_t(n));
  VertexMerger merger(&positions, size_t(n) / 2 + 1);  // closed meshes have about n/2 vertices
  const uint8_t* p = data + 84;
  for (uint32_t f = 0; f < n; ++f, p += 50) {
    // 12 bytes of normal, 3 x 12 bytes of corners, 2 attribute bytes.
    for (int c = 0; c < 3; ++c) {
      const double xyz[3] = {load_f32_le(p + 12 + 12 * c), load_f32_le(p + 16 + 12 * c), load_f32_le(p + 20 + 12 * c)};
      mesh.indices.push_back(merger.add(xyz));
    }
  }
  return mesh_from_absolute(positions, std::move(mesh.indices));
}

StatusOr<Mesh> parse_ascii_stl(const char* begin, const char* end, const MeshLimits& limits) {
  Mesh mesh;
  std::vector<double> positions;
  VertexMerger merger(&positions, 0);
  TokenReader tokens(begin, end);
  std::string_view token;
  tokens.next(&token);  // "solid" (checked by the caller)
  tokens.skip_line();   // and the solid's name
  std::vector<uint32_t> loop;
  // ASCII STL has no counts; a missing "endsolid" is how truncation shows.
  bool closed = false;
  // Keywords other than "vertex" and "endloop" (facet normal, outer loop,
  // endfacet, solid names, a second solid) carry nothing we keep.
  while (tokens.next(&token)) {
    if (iequals(token, "endsolid")) {
      closed = true;
    } else if (iequals(token, "facet") || iequals(token, "solid")) {
      closed = false;
    } else if (iequals(token, "vertex")) {
      double xyz[3];
      for (int k = 0; k < 3; ++k) {
        std::string_view value;
        if (!tokens.next(&value))
          return invalid_argument("STL: file ends inside a vertex (line " + std::to_string(tokens.line_number()) + ")");
        if (!parse_double(value, &xyz[k]))
          return invalid_argument("STL line " + std::to_string(tokens.line_number()) + ": vertex coordinate " +
                                  quote(value) + " is not a number");
      }
      loop.push_back(merger.add(xyz));
    } else if (iequals(token, "endloop")) {
      if (loop.size() < 3)
        return invalid_argument("STL line " + std::to_string(tokens.line_number()) + ": facet has " +
                                std::to_string(loop.size()) + " vertices, at least 3 are needed");
      // Triangles are the norm; a polygon loop becomes a fan.
      for (size_t k = 2; k < loop.size(); ++k) {
        if (mesh.face_count() >= limits.max_faces) return too_many_facets(mesh.face_count() + 1, limits);
        mesh.indices.push_back(loop[0]);
        mesh.indices.push_back(loop[k - 1]);
        mesh.indices.push_back(loop[k]);
      }
      loop.clear();
    }
  }
  if (!loop.empty())
    return invalid_argument("STL: file ends inside a facet (" + std::to_string(loop.size()) +
                            " vertices read, no 'endloop')");
  if (!closed)
    return invalid_argument("STL: the file ends after " + std::to_string(mesh.face_count()) +
                            " triangles without 'endsolid' (truncated?)");
  return mesh_from_absolute(positions, std::move(mesh.indices));
}

}  // namespace

StatusOr<Mesh> parse_stl(const uint8_t* data, size_t size, const MeshLimits& limits) {
  const char* begin = reinterpret_cast<const char*>(data);
  const char* end = begin + size;
  uint32_t n = 0;
  if (size >= 84) {
    n = uint32_t(data[80]) | uint32_t(data[81]) << 8 | uint32_t(data[82]) << 16 | uint32_t(data[83]) << 24;
    if (uint64_t(size) == 84 + 50 * uint64_t(n)) return parse_binary_stl(data, n, limits);
  }
  const char* p = begin;
  while (p < end && (is_blank(*p) || *p == '\n')) ++p;
  if (end - p >= 5 && iequals(std::string_view(p, 5), "solid")) return parse_ascii_stl(begin, end, limits);
  if (size < 84)
    return invalid_argument("STL: " + std::to_string(size) +
                            " bytes is shorter than a binary STL header (84 bytes) and the text does not start "
                            "with 'solid'");
  return invalid_argument("STL: neither ASCII (no 'solid' at the start) nor binary: the header declares " +
                          std::to_string(n) + " facets, which take " + std::to_string(84 + 50 * uint64_t(n)) +
                          " bytes, but the file has " + std::to_string(size));
}

}  // namespace vpr::io_detail
