// glTF 2.0 (.glb and .gltf), read and written here rather than through
// libdraco's GltfDecoder: Debian's libdraco-dev ships gltf_decoder.h but not
// the tiny_gltf.h it includes, and tinygltf sizes arrays from declared counts
// and reads any file an external URI names. This reader checks every count
// against the bytes present and MeshLimits before it allocates, and reads
// external buffers only for a file on disk (never for an upload).
//
// Input: every triangle primitive (mode 4, 5 or 6) of every node of the
// default scene, with the node transforms applied in double, as one surface;
// KHR_draco_mesh_compression primitives go through parse_draco (its pre-scan
// included). Appearance (docs/formats.md, "Colors"): each vertex's color is
// its material's baseColorFactor times its COLOR_0 (linear), and a material's
// baseColorTexture (PNG or JPEG, from a bufferView, a data: URI or, for a
// file on disk, a file beside it) is kept with the TEXCOORD_n it names, with
// KHR_texture_transform applied; an image that cannot be read fails the
// file, and images are decoded within MeshLimits::max_texture_pixels. Output: one GLB (or .gltf with the buffer as a
// data: URI) whose node carries the mesh frame (translation = origin, scale = scale, mesh.h), so the float positions
// are written as they are; the saliency field is the vertex attribute _SALIENCY (glTF's prefix for application
// attributes).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/color.h"
#include "draco/compression/decode.h"
#include "draco/core/decoder_buffer.h"
#include "io/mesh_io.h"
#include "io/parsers.h"
#include "io/texture_io.h"

namespace vpr {

namespace io_detail {

namespace {

using json = nlohmann::json;
using Matrix = std::array<double, 16>;  // column-major, as glTF's node.matrix

constexpr uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;
constexpr uint32_t kChunkBin = 0x004E4942;
constexpr const char* kSaliencyAttribute = kSaliencyAttributeName;
constexpr const char* kDracoExtension = kDracoExtensionName;
// Node nesting the reader follows (the walk is iterative; this only refuses
// absurd files early).
constexpr size_t kMaxNodeDepth = 1024;
// JSON values a document may hold (nodes, accessors, numbers...): real assets
// have thousands to a few hundred thousand; 4 million keep the parsed
// document to a few hundred MB whatever the upload.
constexpr size_t kMaxJsonValues = 4'000'000;
// Nodes a scene may hold: each costs a 4 x 4 matrix while the scene is walked.
constexpr size_t kMaxNodes = 1'000'000;

Status bad(const std::string& what) { return invalid_argument("glTF: " + what); }

uint32_t le32(const uint8_t* p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24; }

struct Bytes {
  const uint8_t* data = nullptr;
  size_t size = 0;
};

// Non-negative integer member (absent: fallback); false when present but not one.
bool get_index(const json& object, const char* key, int64_t fallback, int64_t* out) {
  auto it = object.find(key);
  if (it == object.end()) {
    *out = fallback;
    return true;
  }
  if (!it->is_number_integer() && !it->is_number_unsigned()) return false;
  const int64_t v = it->get<int64_t>();
  if (v < 0) return false;
  *out = v;
  return true;
}

const json* element(const json& root, const char* array, int64_t index) {
  auto it = root.find(array);
  if (it == root.end() || !it->is_array() || index < 0 || uint64_t(index) >= it->size()) return nullptr;
  const json& e = (*it)[size_t(index)];
  return e.is_object() ? &e : nullptr;
}

int base64_value(uint8_t c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+' || c == '-') return 62;
  if (c == '/' || c == '_') return 63;
  return -1;
}

bool decode_base64(std::string_view text, std::vector<uint8_t>* out) {
  out->clear();
  out->reserve(text.size() / 4 * 3 + 3);
  uint32_t acc = 0;
  int bits = 0;
  for (const char ch : text) {
    if (ch == '=') break;
    const int v = base64_value(uint8_t(ch));
    if (v < 0) return false;
    acc = (acc << 6) | uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out->push_back(uint8_t((acc >> bits) & 0xff));
    }
  }
  return true;
}

// The bytes of a base64 data: URI; what: the element, for messages.
Status data_uri(const std::string& uri, const std::string& what, std::vector<uint8_t>* out) {
  const size_t comma = uri.find(";base64,");
  if (comma == std::string::npos) return bad(what + ": only base64 data: URIs are supported");
  if (!decode_base64(std::string_view(uri).substr(comma + 8), out))
    return bad(what + ": the data: URI is not valid base64");
  return Status::Ok();
}

double component(const uint8_t* p, int64_t type, bool normalized);

// An accessor's elements inside its bufferView, checked to fit.
struct AccessorView {
  const uint8_t* data = nullptr;
  size_t count = 0, components = 0, step = 0, size = 0;
  int64_t type = 0;
  bool normalized = false;
  double at(size_t e, size_t c) const { return component(data + e * step + c * size, type, normalized); }
};

// What a primitive's material asks of its vertices' colors (glTF 2.0, 3.9.2).
struct BaseColor {
  double factor[3] = {1, 1, 1};  // baseColorFactor, linear RGB (alpha is not kept)
  int64_t texture = -1;          // baseColorTexture.index, -1 for none
  int64_t tex_coord = 0;         // n of the TEXCOORD_n it reads
  // KHR_texture_transform as u' = t[0] u + t[1] v + t[2], v' = t[3] u + t[4] v + t[5].
  double transform[6] = {1, 0, 0, 0, 1, 0};
};

class GltfReader {
 public:
  GltfReader(const MeshLimits& limits, const std::string* base_dir) : limits_(limits), base_dir_(base_dir) {}

  Status parse(const uint8_t* data, size_t size, std::vector<float>* saliency);
  Mesh take_mesh();  // after parse

 private:
  Status load_container(const uint8_t* data, size_t size);
  Status load_buffers();
  Status external_file(const std::string& uri, const char* kind, size_t i, std::vector<uint8_t>* out);
  Status base_color(const json& primitive, BaseColor* out);
  Status texture(int64_t index, uint32_t* out);
  Status image(int64_t index, std::shared_ptr<const RgbImage>* out);
  Status read_vertex_values(const json& attributes, const std::string& name, size_t nv, size_t components,
                            std::vector<float>* out);
  Status add_appearance(const BaseColor& look, size_t nv, const std::vector<float>& rgb, const std::vector<float>& uv);
  Status view_bytes(int64_t view, Bytes* out, int64_t* stride);
  Status locate_accessor(int64_t index, bool indices, size_t components, struct AccessorView* out);
  Status walk_scene(std::vector<std::pair<int64_t, Matrix>>* instances);
  Status count_primitive(const json& primitive, uint64_t* vertices, uint64_t* faces);
  Status add_primitive(const json& primitive, const Matrix& m, std::vector<float>* saliency);

  const MeshLimits& limits_;
  const std::string* base_dir_;
  json root_;
  Bytes bin_;
  std::vector<std::vector<uint8_t>> owned_;
  std::vector<Bytes> buffers_;
  std::vector<double> positions_;  // absolute, model units
  std::vector<uint32_t> indices_;
  std::vector<float> saliency_;
  bool all_have_saliency_ = true;
  // Appearance, one entry per vertex of positions_ once a primitive needs it
  // (the vertices before it are then white, or untextured).
  bool colored_ = false, textured_ = false;
  std::vector<float> linear_colors_;  // #V x 3, baseColorFactor x COLOR_0
  std::vector<float> uvs_;            // #V x 2
  std::vector<uint32_t> vertex_texture_;
  std::vector<BaseColorTexture> textures_;
  std::map<int64_t, uint32_t> texture_slot_;                   // glTF texture -> textures_
  std::map<int64_t, std::shared_ptr<const RgbImage>> images_;  // decoded, by glTF image
  size_t texture_pixels_ = 0;                                  // decoded so far
};

Status GltfReader::load_container(const uint8_t* data, size_t size) {
  const uint8_t* json_data = data;
  size_t json_size = size;
  if (size >= 4 && le32(data) == kGlbMagic) {
    if (size < 20) return bad("the GLB header is truncated (" + std::to_string(size) + " bytes)");
    const uint32_t version = le32(data + 4), length = le32(data + 8);
    if (version != 2) return bad("GLB version " + std::to_string(version) + " is not supported (supported: 2)");
    if (length > size)
      return bad("the GLB header declares " + std::to_string(length) + " bytes, the file has " + std::to_string(size));
    size_t at = 12;
    json_size = 0;
    while (at + 8 <= length) {
      const uint32_t chunk_length = le32(data + at), type = le32(data + at + 4);
      if (chunk_length > length - at - 8)
        return bad("a GLB chunk declares " + std::to_string(chunk_length) + " bytes, beyond the file's end");
      if (type == kChunkJson && json_size == 0 && at == 12) {
        json_data = data + at + 8;
        json_size = chunk_length;
      } else if (type == kChunkBin && bin_.data == nullptr) {
        bin_ = {data + at + 8, chunk_length};
      }
      at += 8 + size_t(chunk_length);
    }
    if (json_size == 0) return bad("the GLB file has no JSON chunk first");
  }
  // A JSON value costs tens of bytes in memory for one or two of input:
  // count them (an upper bound: separators and openers outside strings)
  // before building the document.
  size_t values = 1;
  bool in_string = false;
  for (size_t i = 0; i < json_size; ++i) {
    const uint8_t c = json_data[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == ',' || c == ':' || c == '[' || c == '{') {
      ++values;
    }
  }
  if (values > kMaxJsonValues)
    return resource_exhausted("glTF: the JSON holds about " + std::to_string(values) + " values, the limit is " +
                              std::to_string(kMaxJsonValues));
  root_ = json::parse(json_data, json_data + json_size, nullptr, false);
  if (root_.is_discarded() || !root_.is_object()) return bad("the JSON is malformed");
  auto asset = root_.find("asset");
  if (asset == root_.end() || !asset->is_object() || !asset->contains("version") || !(*asset)["version"].is_string())
    return bad("asset.version is missing (not a glTF file)");
  const std::string version = (*asset)["version"].get<std::string>();
  if (version.rfind("2.", 0) != 0) return bad("version " + quote(version) + " is not supported (supported: 2.x)");
  return Status::Ok();
}

Status GltfReader::load_buffers() {
  auto it = root_.find("buffers");
  if (it == root_.end()) return Status::Ok();
  if (!it->is_array()) return bad("buffers is not an array");
  for (size_t i = 0; i < it->size(); ++i) {
    const json& b = (*it)[i];
    int64_t declared = 0;
    if (!b.is_object() || !get_index(b, "byteLength", -1, &declared) || declared < 0)
      return bad("buffer " + std::to_string(i) + " has no valid byteLength");
    Bytes bytes;
    auto uri = b.find("uri");
    if (uri == b.end()) {
      if (i != 0 || !bin_.data) return bad("buffer " + std::to_string(i) + " has no uri and there is no GLB BIN chunk");
      bytes = bin_;
    } else {
      if (!uri->is_string()) return bad("buffer " + std::to_string(i) + " has a uri that is not a string");
      const std::string& u = uri->get_ref<const std::string&>();
      if (u.rfind("data:", 0) == 0) {
        owned_.emplace_back();
        VPR_RETURN_IF_ERROR(data_uri(u, "buffer " + std::to_string(i), &owned_.back()));
      } else {
        owned_.emplace_back();
        VPR_RETURN_IF_ERROR(external_file(u, "buffer", i, &owned_.back()));
      }
      bytes = {owned_.back().data(), owned_.back().size()};
    }
    if (uint64_t(declared) > bytes.size)
      return bad("buffer " + std::to_string(i) + " declares " + std::to_string(declared) + " bytes but holds " +
                 std::to_string(bytes.size));
    bytes.size = size_t(declared);
    buffers_.push_back(bytes);
  }
  return Status::Ok();
}

// A file a uri names, beside the model on disk (never for an upload).
// kind: "buffer" or "image", element i of its array.
Status GltfReader::external_file(const std::string& uri, const char* kind, size_t i, std::vector<uint8_t>* out) {
  const std::string what = std::string(kind) + " " + std::to_string(i);
  if (!base_dir_)
    return bad(what + " is the external file " + quote(uri) + ", which an upload cannot carry: send a .glb with the " +
               kind + "s inside");
  if (uri.find("..") != std::string::npos || uri.empty() || uri[0] == '/')
    return bad(what + ": external file " + quote(uri) + " must be a relative path inside the model's folder");
  StatusOr<std::vector<uint8_t>> file = read_file(*base_dir_ + "/" + uri);
  if (!file.ok())
    return bad(std::string("external ") + kind + " " + quote(uri) + " is missing or unreadable (" +
               file.status().message() + ")");
  *out = std::move(*file);
  return Status::Ok();
}

Status GltfReader::view_bytes(int64_t view, Bytes* out, int64_t* stride) {
  const json* v = element(root_, "bufferViews", view);
  if (!v) return bad("bufferView " + std::to_string(view) + " does not exist");
  int64_t buffer = 0, offset = 0, length = 0;
  if (!get_index(*v, "buffer", -1, &buffer) || !get_index(*v, "byteOffset", 0, &offset) ||
      !get_index(*v, "byteLength", -1, &length) || !get_index(*v, "byteStride", 0, stride) || buffer < 0 || length < 0)
    return bad("bufferView " + std::to_string(view) + " has a missing or negative buffer, byteOffset or byteLength");
  if (uint64_t(buffer) >= buffers_.size()) return bad("bufferView " + std::to_string(view) + " names a missing buffer");
  const Bytes& b = buffers_[size_t(buffer)];
  if (uint64_t(offset) > b.size || uint64_t(length) > b.size - uint64_t(offset))
    return bad("bufferView " + std::to_string(view) + " (" + std::to_string(offset) + " + " + std::to_string(length) +
               " bytes) lies beyond its buffer's " + std::to_string(b.size) + " bytes");
  *out = {b.data + offset, size_t(length)};
  return Status::Ok();
}

size_t component_size(int64_t type) {
  switch (type) {
    case 5120:
    case 5121:
      return 1;
    case 5122:
    case 5123:
      return 2;
    case 5125:
    case 5126:
      return 4;
  }
  return 0;
}

double component(const uint8_t* p, int64_t type, bool normalized) {
  switch (type) {
    case 5120: {
      const double v = double(int8_t(p[0]));
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case 5121:
      return normalized ? p[0] / 255.0 : double(p[0]);
    case 5122: {
      const double v = double(int16_t(uint16_t(p[0] | p[1] << 8)));
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case 5123: {
      const double v = double(uint16_t(p[0] | p[1] << 8));
      return normalized ? v / 65535.0 : v;
    }
    case 5125:
      return double(le32(p));
    case 5126: {
      const uint32_t bits = le32(p);
      float f;
      std::memcpy(&f, &bits, 4);
      return double(f);
    }
  }
  return NAN;
}

size_t type_components(const std::string& type) {
  if (type == "SCALAR") return 1;
  if (type == "VEC2") return 2;
  if (type == "VEC3") return 3;
  if (type == "VEC4") return 4;
  return 0;
}

// Finds accessor `index` (components per element as expected); counts are
// checked against the limits and the bufferView before anything is sized.
Status GltfReader::locate_accessor(int64_t index, bool indices, size_t components, AccessorView* out) {
  const std::string name = "accessor " + std::to_string(index);
  const json* a = element(root_, "accessors", index);
  if (!a) return bad(name + " does not exist");
  int64_t view = -1, offset = 0, count = 0, type = 0;
  if (!get_index(*a, "bufferView", -1, &view) || !get_index(*a, "byteOffset", 0, &offset) ||
      !get_index(*a, "count", -1, &count) || !get_index(*a, "componentType", -1, &type) || count < 0)
    return bad(name + " has a missing or invalid count, componentType, bufferView or byteOffset");
  if (a->contains("sparse")) return bad(name + " is sparse, which is not supported");
  if (view < 0) return bad(name + " has no bufferView (all zeros), which cannot hold a mesh");
  const std::string element_type = a->contains("type") && (*a)["type"].is_string() ? (*a)["type"].get<std::string>() : "";
  const size_t size = component_size(type);
  if (size == 0 || type_components(element_type) != components || (indices && (type == 5126 || type == 5120 || type == 5122)))
    return bad(name + " has type " + quote(element_type) + " / componentType " + std::to_string(type) + ", expected " +
               (indices ? "SCALAR unsigned integers" : std::to_string(components) + " components"));
  const size_t limit = indices ? 3 * limits_.max_faces : limits_.max_vertices;
  if (uint64_t(count) > limit)
    return resource_exhausted("glTF: " + name + " declares " + std::to_string(count) + " elements, the limit is " +
                              std::to_string(limit));
  Bytes bytes;
  int64_t stride = 0;
  VPR_RETURN_IF_ERROR(view_bytes(view, &bytes, &stride));
  const size_t element_size = size * components;
  // glTF 2.0, 5.11: byteStride is 4..252 when present.
  if (stride > 0 && (size_t(stride) < element_size || stride > 252))
    return bad(name + ": byteStride " + std::to_string(stride) + " is outside [element size " +
               std::to_string(element_size) + ", 252]");
  const size_t step = stride > 0 ? size_t(stride) : element_size;
  if (count > 0 && (uint64_t(offset) > bytes.size ||
                    (uint64_t(count) - 1) * step + element_size > bytes.size - uint64_t(offset)))
    return bad(name + " declares " + std::to_string(count) + " elements, more than its bufferView's " +
               std::to_string(bytes.size) + " bytes hold");
  auto normalized = a->find("normalized");
  out->data = bytes.data + size_t(offset);
  out->count = size_t(count);
  out->components = components;
  out->step = step;
  out->size = size;
  out->type = type;
  out->normalized = normalized != a->end() && normalized->is_boolean() && normalized->get<bool>();
  return Status::Ok();
}

Matrix multiply(const Matrix& a, const Matrix& b) {
  Matrix r{};
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 4; ++row) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a[size_t(k * 4 + row)] * b[size_t(col * 4 + k)];
      r[size_t(col * 4 + row)] = s;
    }
  return r;
}

bool numbers(const json& node, const char* key, size_t n, double* out) {
  auto it = node.find(key);
  if (it == node.end()) return true;
  if (!it->is_array() || it->size() != n) return false;
  for (size_t i = 0; i < n; ++i) {
    if (!(*it)[i].is_number()) return false;
    out[i] = (*it)[i].get<double>();
  }
  return true;
}

// A node's local transform: matrix, or T * R * S (glTF 2.0, section 5.25).
bool local_matrix(const json& node, Matrix* m) {
  *m = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  if (node.contains("matrix")) return numbers(node, "matrix", 16, m->data());
  double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
  if (!numbers(node, "translation", 3, t) || !numbers(node, "rotation", 4, q) || !numbers(node, "scale", 3, s)) return false;
  const double x = q[0], y = q[1], z = q[2], w = q[3];
  const double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                       2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                       2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
  for (int col = 0; col < 3; ++col)
    for (int row = 0; row < 3; ++row) (*m)[size_t(col * 4 + row)] = r[col * 3 + row] * s[col];
  for (int row = 0; row < 3; ++row) (*m)[size_t(12 + row)] = t[row];
  return true;
}

// Every (mesh, world matrix) pair of the default scene (scene 0 when none is
// named), walked with an explicit stack; a node met twice is a cycle or a
// node with two parents, both invalid glTF.
Status GltfReader::walk_scene(std::vector<std::pair<int64_t, Matrix>>* instances) {
  int64_t scene_index = 0;
  if (!get_index(root_, "scene", 0, &scene_index)) return bad("scene is not a valid index");
  const json* scene = element(root_, "scenes", scene_index);
  if (!scene) return bad("scene " + std::to_string(scene_index) + " does not exist: no triangles to read");
  const json* all_nodes = root_.contains("nodes") ? &root_["nodes"] : nullptr;
  const size_t node_count = all_nodes && all_nodes->is_array() ? all_nodes->size() : 0;
  if (node_count > kMaxNodes)
    return resource_exhausted("glTF: the file has " + std::to_string(node_count) + " nodes, the limit is " +
                              std::to_string(kMaxNodes));
  // Marked when pushed, so the stack holds each node at most once.
  std::vector<char> seen(node_count, 0);
  auto reached = [&](int64_t node) -> Status {
    if (node < 0 || uint64_t(node) >= node_count) return bad("node " + std::to_string(node) + " does not exist");
    if (seen[size_t(node)]) return bad("node " + std::to_string(node) + " is reached twice (a cycle or two parents)");
    seen[size_t(node)] = 1;
    return Status::Ok();
  };
  struct Item {
    int64_t node;
    Matrix parent;
    size_t depth;
  };
  std::vector<Item> stack;
  const Matrix identity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  if (scene->contains("nodes")) {
    const json& roots = (*scene)["nodes"];
    if (!roots.is_array()) return bad("scene.nodes is not an array");
    // Reversed onto the stack, so that nodes are read in the file's order.
    for (auto n = roots.rbegin(); n != roots.rend(); ++n) {
      if (!n->is_number_integer() && !n->is_number_unsigned()) return bad("scene.nodes holds a non-index");
      VPR_RETURN_IF_ERROR(reached(n->get<int64_t>()));
      stack.push_back({n->get<int64_t>(), identity, 0});
    }
  }
  while (!stack.empty()) {
    const Item item = stack.back();
    stack.pop_back();
    const json* node = element(root_, "nodes", item.node);
    if (!node) return bad("node " + std::to_string(item.node) + " is not an object");
    if (item.depth > kMaxNodeDepth) return bad("nodes are nested deeper than " + std::to_string(kMaxNodeDepth) + " levels");
    Matrix local;
    if (!local_matrix(*node, &local)) return bad("node " + std::to_string(item.node) + " has a malformed transform");
    const Matrix world = multiply(item.parent, local);
    int64_t mesh = -1;
    if (!get_index(*node, "mesh", -1, &mesh)) return bad("node " + std::to_string(item.node) + " has an invalid mesh index");
    if (mesh >= 0) instances->push_back({mesh, world});
    if (node->contains("children")) {
      const json& children = (*node)["children"];
      if (!children.is_array()) return bad("node " + std::to_string(item.node) + ".children is not an array");
      for (auto c = children.rbegin(); c != children.rend(); ++c) {
        if (!c->is_number_integer() && !c->is_number_unsigned()) return bad("node children hold a non-index");
        VPR_RETURN_IF_ERROR(reached(c->get<int64_t>()));
        stack.push_back({c->get<int64_t>(), world, item.depth + 1});
      }
    }
  }
  return Status::Ok();
}

bool is_triangles(const json& primitive) {
  int64_t mode = 4;
  return get_index(primitive, "mode", 4, &mode) && mode >= 4 && mode <= 6;
}

// Declared counts, for the totals checked before any primitive is read.
Status GltfReader::count_primitive(const json& primitive, uint64_t* vertices, uint64_t* faces) {
  auto count_of = [&](int64_t accessor, uint64_t* out) {
    const json* a = element(root_, "accessors", accessor);
    int64_t count = 0;
    if (!a || !get_index(*a, "count", -1, &count) || count < 0) return bad("accessor " + std::to_string(accessor) + " is missing or has no count");
    *out = uint64_t(count);
    return Status::Ok();
  };
  const json* attributes = primitive.contains("attributes") && primitive["attributes"].is_object() ? &primitive["attributes"] : nullptr;
  int64_t position = -1, indices = -1;
  if (!attributes || !get_index(*attributes, "POSITION", -1, &position) || position < 0)
    return bad("a triangle primitive has no POSITION attribute");
  uint64_t nv = 0, ni = 0;
  VPR_RETURN_IF_ERROR(count_of(position, &nv));
  if (!get_index(primitive, "indices", -1, &indices)) return bad("a primitive has an invalid indices index");
  ni = nv;
  if (indices >= 0) VPR_RETURN_IF_ERROR(count_of(indices, &ni));
  int64_t mode = 4;
  get_index(primitive, "mode", 4, &mode);
  *vertices += nv;
  *faces += mode == 4 ? ni / 3 : (ni >= 2 ? ni - 2 : 0);  // strips and fans: one triangle per index after two
  return Status::Ok();
}

// The primitive's material's base color: factor, texture, coordinates.
Status GltfReader::base_color(const json& primitive, BaseColor* out) {
  int64_t index = -1;
  if (!get_index(primitive, "material", -1, &index)) return bad("a primitive has an invalid material index");
  if (index < 0) return Status::Ok();  // the default material: white, untextured
  const std::string name = "material " + std::to_string(index);
  const json* material = element(root_, "materials", index);
  if (!material) return bad(name + " does not exist");
  auto pbr = material->find("pbrMetallicRoughness");
  if (pbr == material->end()) return Status::Ok();
  if (!pbr->is_object()) return bad(name + ": pbrMetallicRoughness is not an object");
  double factor[4] = {1, 1, 1, 1};
  if (!numbers(*pbr, "baseColorFactor", 4, factor)) return bad(name + ": baseColorFactor is not 4 numbers");
  for (int c = 0; c < 3; ++c) out->factor[c] = std::clamp(factor[c], 0.0, 1.0);
  auto info = pbr->find("baseColorTexture");
  if (info == pbr->end()) return Status::Ok();
  if (!info->is_object() || !get_index(*info, "index", -1, &out->texture) || out->texture < 0 ||
      !get_index(*info, "texCoord", 0, &out->tex_coord))
    return bad(name + ": baseColorTexture has no valid index or texCoord");
  auto extensions = info->find("extensions");
  if (extensions == info->end() || !extensions->is_object()) return Status::Ok();
  auto transform = extensions->find("KHR_texture_transform");
  if (transform == extensions->end()) return Status::Ok();
  // T * R * S of the extension's specification, applied to the coordinates.
  double offset[2] = {0, 0}, rotation = 0, scale[2] = {1, 1};
  if (!transform->is_object() || !numbers(*transform, "offset", 2, offset) || !numbers(*transform, "scale", 2, scale) ||
      !get_index(*transform, "texCoord", out->tex_coord, &out->tex_coord))
    return bad(name + ": KHR_texture_transform is malformed");
  auto angle = transform->find("rotation");
  if (angle != transform->end()) {
    if (!angle->is_number()) return bad(name + ": KHR_texture_transform.rotation is not a number");
    rotation = angle->get<double>();
  }
  const double c = std::cos(rotation), s = std::sin(rotation);
  const double t[6] = {c * scale[0], s * scale[1], offset[0], -s * scale[0], c * scale[1], offset[1]};
  std::copy(t, t + 6, out->transform);
  return Status::Ok();
}

// glTF texture `index` as a slot of textures_ (decoded once however many
// materials use it).
Status GltfReader::texture(int64_t index, uint32_t* out) {
  if (auto found = texture_slot_.find(index); found != texture_slot_.end()) {
    *out = found->second;
    return Status::Ok();
  }
  const std::string name = "texture " + std::to_string(index);
  const json* t = element(root_, "textures", index);
  if (!t) return bad(name + " does not exist");
  int64_t source = -1, sampler = -1;
  if (!get_index(*t, "source", -1, &source) || !get_index(*t, "sampler", -1, &sampler))
    return bad(name + " has an invalid source or sampler index");
  if (source < 0)
    return bad(name +
               " has no PNG or JPEG image (an image only an extension names, such as KHR_texture_basisu's "
               "or EXT_texture_webp's, is not read)");
  BaseColorTexture texture;
  if (sampler >= 0) {
    const json* settings = element(root_, "samplers", sampler);
    if (!settings) return bad("sampler " + std::to_string(sampler) + " does not exist");
    int64_t wrap[2] = {10497, 10497};
    TextureWrap* modes[2] = {&texture.wrap_u, &texture.wrap_v};
    for (int a = 0; a < 2; ++a) {
      const char* key = a == 0 ? "wrapS" : "wrapT";
      if (!get_index(*settings, key, 10497, &wrap[a]))
        return bad("sampler " + std::to_string(sampler) + ": invalid " + key);
      if (wrap[a] == 10497)
        *modes[a] = TextureWrap::kRepeat;
      else if (wrap[a] == 33071)
        *modes[a] = TextureWrap::kClampToEdge;
      else if (wrap[a] == 33648)
        *modes[a] = TextureWrap::kMirroredRepeat;
      else
        return bad("sampler " + std::to_string(sampler) + ": " + key + " " + std::to_string(wrap[a]) +
                   " is not a wrap mode (10497, 33071 or 33648)");
    }
  }
  VPR_RETURN_IF_ERROR(image(source, &texture.image));
  *out = uint32_t(textures_.size());
  textures_.push_back(std::move(texture));
  texture_slot_[index] = *out;
  return Status::Ok();
}

// glTF image `index`, decoded once, within the texture pixel budget.
Status GltfReader::image(int64_t index, std::shared_ptr<const RgbImage>* out) {
  if (auto found = images_.find(index); found != images_.end()) {
    *out = found->second;
    return Status::Ok();
  }
  const std::string name = "image " + std::to_string(index);
  const json* entry = element(root_, "images", index);
  if (!entry) return bad(name + " does not exist");
  int64_t view = -1;
  if (!get_index(*entry, "bufferView", -1, &view)) return bad(name + " has an invalid bufferView");
  std::vector<uint8_t> owned;
  Bytes bytes;
  auto uri = entry->find("uri");
  if (view >= 0) {
    int64_t stride = 0;
    VPR_RETURN_IF_ERROR(view_bytes(view, &bytes, &stride));
  } else if (uri != entry->end() && uri->is_string()) {
    const std::string& u = uri->get_ref<const std::string&>();
    if (u.rfind("data:", 0) == 0)
      VPR_RETURN_IF_ERROR(data_uri(u, name, &owned));
    else
      VPR_RETURN_IF_ERROR(external_file(u, "image", size_t(index), &owned));
    bytes = {owned.data(), owned.size()};
  } else {
    return bad(name + " has neither a bufferView nor a uri");
  }
  StatusOr<RgbImage> decoded =
      decode_texture(bytes.data, bytes.size, kMaxTextureSide, limits_.max_texture_pixels - texture_pixels_);
  if (!decoded.ok()) {
    std::string message = "glTF: " + name + ": " + decoded.status().message();
    if (decoded.status().code() == StatusCode::kResourceExhausted && texture_pixels_ > 0)
      message += " (the file's other textures took " + std::to_string(texture_pixels_) + " of " +
                 std::to_string(limits_.max_texture_pixels) + ")";
    return Status(decoded.status().code(), message);
  }
  texture_pixels_ += decoded->pixels.size();
  auto shared = std::make_shared<const RgbImage>(std::move(*decoded));
  images_[index] = shared;
  *out = std::move(shared);
  return Status::Ok();
}

// Attribute `name` of a plain primitive (COLOR_0, TEXCOORD_n: float, or
// unsigned byte or short normalized) as `components` floats a vertex; VEC4
// colors lose alpha. out is left empty when the attribute is absent.
Status GltfReader::read_vertex_values(const json& attributes, const std::string& name, size_t nv, size_t components,
                                      std::vector<float>* out) {
  out->clear();
  int64_t index = -1;
  if (!attributes.is_object() || !get_index(attributes, name.c_str(), -1, &index))
    return bad(name + " is not a valid accessor index");
  if (index < 0) return Status::Ok();
  const json* a = element(root_, "accessors", index);
  auto type = a ? a->find("type") : json::const_iterator();
  const size_t stored = a && type != a->end() && type->is_string() ? type_components(type->get<std::string>()) : 0;
  if (stored != components && !(components == 3 && stored == 4))
    return bad("accessor " + std::to_string(index) + " (" + name + ") is not " +
               (components == 3 ? "VEC3 or VEC4" : "VEC2"));
  AccessorView view;
  VPR_RETURN_IF_ERROR(locate_accessor(index, false, stored, &view));
  if (view.type != 5126 && view.type != 5121 && view.type != 5123)
    return bad("accessor " + std::to_string(index) + " (" + name + ") has componentType " + std::to_string(view.type) +
               ", expected float, unsigned byte or unsigned short");
  if (view.count != nv)
    return bad(name + " has " + std::to_string(view.count) + " elements for the primitive's " + std::to_string(nv) +
               " vertices");
  view.normalized = view.type != 5126;  // integers are normalized here (glTF 2.0, 3.7.2.1)
  out->resize(nv * components);
  for (size_t v = 0; v < nv; ++v)
    for (size_t c = 0; c < components; ++c) (*out)[v * components + c] = float(view.at(v, c));
  return Status::Ok();
}

// Appends a primitive's nv vertex colors (factor x COLOR_0) and texture
// coordinates, before its positions are appended.
Status GltfReader::add_appearance(const BaseColor& look, size_t nv, const std::vector<float>& rgb,
                                  const std::vector<float>& uv) {
  const size_t before = positions_.size() / 3;
  const bool tinted = !rgb.empty() || look.factor[0] != 1 || look.factor[1] != 1 || look.factor[2] != 1;
  if (tinted && !colored_) {
    colored_ = true;
    linear_colors_.assign(3 * before, 1.0f);
  }
  if (colored_)
    for (size_t v = 0; v < nv; ++v)
      for (size_t c = 0; c < 3; ++c)
        linear_colors_.push_back(
            float(look.factor[c] * (rgb.empty() ? 1.0 : std::clamp(double(rgb[3 * v + c]), 0.0, 1.0))));
  uint32_t slot = MeshTextures::kNone;
  if (look.texture >= 0) VPR_RETURN_IF_ERROR(texture(look.texture, &slot));
  if (slot != MeshTextures::kNone && !textured_) {
    textured_ = true;
    uvs_.assign(2 * before, 0.0f);
    vertex_texture_.assign(before, MeshTextures::kNone);
  }
  if (!textured_) return Status::Ok();
  const double* t = look.transform;
  for (size_t v = 0; v < nv; ++v) {
    const double u = slot == MeshTextures::kNone ? 0 : uv[2 * v], w = slot == MeshTextures::kNone ? 0 : uv[2 * v + 1];
    // A transform may take coordinates beyond the float range (+-inf then; the sampler reads those as 0).
    uvs_.push_back(to_float(t[0] * u + t[1] * w + t[2]));
    uvs_.push_back(to_float(t[3] * u + t[4] * w + t[5]));
    vertex_texture_.push_back(slot);
  }
  return Status::Ok();
}

Mesh GltfReader::take_mesh() {
  Mesh mesh = mesh_from_absolute(positions_, std::move(indices_));
  mesh.colors.resize(linear_colors_.size());
  for (size_t i = 0; i < linear_colors_.size(); ++i) mesh.colors[i] = srgb_from_linear(linear_colors_[i]);
  if (!textures_.empty()) {
    mesh.textures.uvs = std::move(uvs_);
    mesh.textures.vertex_texture = std::move(vertex_texture_);
    mesh.textures.textures = std::move(textures_);
  }
  return mesh;
}

Status GltfReader::add_primitive(const json& primitive, const Matrix& m, std::vector<float>* want_saliency) {
  std::vector<double> local;  // #V x 3, the primitive's own frame
  std::vector<uint32_t> corners;
  std::vector<float> saliency;
  bool has_saliency = false;
  BaseColor look;
  VPR_RETURN_IF_ERROR(base_color(primitive, &look));
  const std::string uv_name = "TEXCOORD_" + std::to_string(look.tex_coord);
  std::vector<float> rgb, uv;  // COLOR_0 (#V x 3) and the texture's coordinates (#V x 2), when present
  const json* extensions = primitive.contains("extensions") ? &primitive["extensions"] : nullptr;
  if (extensions && extensions->is_object() && extensions->contains(kDracoExtension)) {
    const json& ext = (*extensions)[kDracoExtension];
    int64_t view = -1, stride = 0;
    if (!ext.is_object() || !get_index(ext, "bufferView", -1, &view) || view < 0)
      return bad(std::string(kDracoExtension) + " has no bufferView");
    Bytes bytes;
    VPR_RETURN_IF_ERROR(view_bytes(view, &bytes, &stride));
    MeshLimits remaining{limits_.max_vertices - positions_.size() / 3, limits_.max_faces - indices_.size() / 3};
    // The extension names the Draco attributes of COLOR_0 and TEXCOORD_n by unique id.
    std::vector<DracoAttributeRequest> requests;
    auto ids = ext.find("attributes");
    auto request = [&](const std::string& name, int components, std::vector<float>* out) -> Status {
      int64_t id = -1;
      if (ids == ext.end() || !ids->is_object() || !get_index(*ids, name.c_str(), -1, &id) || id > INT32_MAX)
        return bad(std::string(kDracoExtension) + ": the id of " + name + " is not a valid attribute id");
      if (id >= 0) requests.push_back({int(id), components, out});
      return Status::Ok();
    };
    VPR_RETURN_IF_ERROR(request("COLOR_0", 3, &rgb));
    if (look.texture >= 0) VPR_RETURN_IF_ERROR(request(uv_name, 2, &uv));
    std::vector<float> draco_saliency;
    StatusOr<Mesh> decoded =
        parse_draco(bytes.data, bytes.size, remaining, want_saliency ? &draco_saliency : nullptr, requests);
    if (!decoded.ok()) return Status(decoded.status().code(), "glTF: the Draco-compressed primitive: " + decoded.status().message());
    local.resize(decoded->positions.size());
    for (size_t v = 0; v < decoded->vertex_count(); ++v)
      for (int a = 0; a < 3; ++a) local[3 * v + size_t(a)] = decoded->absolute(v, a);
    corners = std::move(decoded->indices);
    has_saliency = !draco_saliency.empty();
    saliency = std::move(draco_saliency);
  } else {
    const json& attributes = primitive["attributes"];
    AccessorView position;
    VPR_RETURN_IF_ERROR(locate_accessor(attributes["POSITION"].get<int64_t>(), false, 3, &position));
    const size_t nv = position.count;
    local.resize(3 * nv);
    for (size_t v = 0; v < nv; ++v)
      for (size_t a = 0; a < 3; ++a) local[3 * v + a] = position.at(v, a);
    int64_t indices = -1;
    get_index(primitive, "indices", -1, &indices);
    std::vector<uint32_t> raw;
    if (indices >= 0) {
      AccessorView view;
      VPR_RETURN_IF_ERROR(locate_accessor(indices, true, 1, &view));
      raw.resize(view.count);
      for (size_t i = 0; i < view.count; ++i) {
        const double index = view.at(i, 0);  // an unsigned integer of at most 32 bits
        if (!(index < double(nv)))
          return bad("index " + std::to_string(uint64_t(index)) + " is beyond the primitive's " + std::to_string(nv) +
                     " vertices");
        raw[i] = uint32_t(index);
      }
    } else {
      raw.resize(nv);
      for (size_t i = 0; i < nv; ++i) raw[i] = uint32_t(i);
    }
    int64_t mode = 4;
    get_index(primitive, "mode", 4, &mode);
    if (mode == 4) {
      raw.resize(raw.size() / 3 * 3);
      corners = std::move(raw);
    } else {
      for (size_t i = 2; i < raw.size(); ++i) {
        if (mode == 5 && i % 2)  // strip: every other triangle flips to keep the winding
          corners.insert(corners.end(), {raw[i - 1], raw[i - 2], raw[i]});
        else if (mode == 5)
          corners.insert(corners.end(), {raw[i - 2], raw[i - 1], raw[i]});
        else  // fan
          corners.insert(corners.end(), {raw[0], raw[i - 1], raw[i]});
      }
    }
    VPR_RETURN_IF_ERROR(read_vertex_values(attributes, "COLOR_0", nv, 3, &rgb));
    if (look.texture >= 0) VPR_RETURN_IF_ERROR(read_vertex_values(attributes, uv_name, nv, 2, &uv));
    int64_t sal = -1;
    if (want_saliency && attributes.is_object() && get_index(attributes, kSaliencyAttribute, -1, &sal) && sal >= 0) {
      AccessorView values;
      VPR_RETURN_IF_ERROR(locate_accessor(sal, false, 1, &values));
      if (values.count == nv) {
        has_saliency = true;
        saliency.resize(nv);
        for (size_t v = 0; v < nv; ++v) saliency[v] = to_float(values.at(v, 0));
      }
    }
  }
  const size_t nv = local.size() / 3;
  if (positions_.size() / 3 + nv > limits_.max_vertices)
    return resource_exhausted("glTF: the primitives hold more than " + std::to_string(limits_.max_vertices) +
                              " vertices (the limit is " + std::to_string(limits_.max_vertices) + ")");
  if (indices_.size() / 3 + corners.size() / 3 > limits_.max_faces)
    return resource_exhausted("glTF: the primitives hold more than " + std::to_string(limits_.max_faces) +
                              " triangles (the limit is " + std::to_string(limits_.max_faces) + ")");
  if (look.texture >= 0 && uv.size() != 2 * nv)
    return bad("a primitive whose material has a base-color texture has no " + uv_name + " for it");
  VPR_RETURN_IF_ERROR(add_appearance(look, nv, rgb, uv));
  const uint32_t base = uint32_t(positions_.size() / 3);
  for (size_t v = 0; v < nv; ++v) {
    const double* p = &local[3 * v];
    for (int row = 0; row < 3; ++row)
      positions_.push_back(m[size_t(row)] * p[0] + m[size_t(4 + row)] * p[1] + m[size_t(8 + row)] * p[2] + m[size_t(12 + row)]);
  }
  for (const uint32_t c : corners) indices_.push_back(base + c);
  all_have_saliency_ = all_have_saliency_ && has_saliency;
  if (has_saliency) saliency_.insert(saliency_.end(), saliency.begin(), saliency.end());
  return Status::Ok();
}

Status GltfReader::parse(const uint8_t* data, size_t size, std::vector<float>* saliency) {
  VPR_RETURN_IF_ERROR(load_container(data, size));
  VPR_RETURN_IF_ERROR(load_buffers());
  std::vector<std::pair<int64_t, Matrix>> instances;
  VPR_RETURN_IF_ERROR(walk_scene(&instances));
  // Declared totals first: a mesh used by many nodes counts once per node.
  uint64_t vertices = 0, faces = 0;
  for (const auto& [mesh_index, matrix] : instances) {
    const json* mesh = element(root_, "meshes", mesh_index);
    if (!mesh || !mesh->contains("primitives") || !(*mesh)["primitives"].is_array())
      return bad("mesh " + std::to_string(mesh_index) + " is missing or has no primitives");
    for (const json& p : (*mesh)["primitives"]) {
      if (!p.is_object()) return bad("mesh " + std::to_string(mesh_index) + " has a primitive that is not an object");
      if (is_triangles(p)) VPR_RETURN_IF_ERROR(count_primitive(p, &vertices, &faces));
    }
    if (vertices > limits_.max_vertices)
      return resource_exhausted("glTF: the scene declares more than " + std::to_string(vertices) + " vertices, the limit is " +
                                std::to_string(limits_.max_vertices));
    if (faces > limits_.max_faces)
      return resource_exhausted("glTF: the scene declares more than " + std::to_string(faces) +
                                " triangles, the limit is " + std::to_string(limits_.max_faces));
  }
  for (const auto& [mesh_index, matrix] : instances)
    for (const json& p : (*element(root_, "meshes", mesh_index))["primitives"])
      if (is_triangles(p)) VPR_RETURN_IF_ERROR(add_primitive(p, matrix, saliency));
  if (indices_.empty()) return bad("the scene has no triangles (no mesh primitive with mode 4, 5 or 6 and 3 or more vertices)");
  if (saliency && all_have_saliency_ && saliency_.size() == positions_.size() / 3) *saliency = std::move(saliency_);
  return Status::Ok();
}

}  // namespace

StatusOr<Mesh> parse_gltf(const uint8_t* data, size_t size, const MeshLimits& limits, std::vector<float>* saliency,
                          const std::string* base_dir) {
  GltfReader reader(limits, base_dir);
  try {
    VPR_RETURN_IF_ERROR(reader.parse(data, size, saliency));
  } catch (const json::exception& e) {
    // Every access is checked first; this is the backstop for one that is not.
    return invalid_argument(std::string("glTF: unexpected JSON content (") + e.what() + ")");
  }
  return reader.take_mesh();
}

}  // namespace io_detail

}  // namespace vpr
