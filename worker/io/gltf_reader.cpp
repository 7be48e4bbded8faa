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
// included). Output: one GLB (or .gltf with the buffer as a data: URI) whose
// node carries the mesh frame (translation = origin, scale = scale, mesh.h),
// so the float positions are written as they are; the saliency field is the
// vertex attribute _SALIENCY (glTF's prefix for application attributes).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "draco/compression/decode.h"
#include "draco/core/decoder_buffer.h"
#include "io/mesh_io.h"
#include "io/parsers.h"

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

double component(const uint8_t* p, int64_t type, bool normalized);

// An accessor's elements inside its bufferView, checked to fit.
struct AccessorView {
  const uint8_t* data = nullptr;
  size_t count = 0, components = 0, step = 0, size = 0;
  int64_t type = 0;
  bool normalized = false;
  double at(size_t e, size_t c) const { return component(data + e * step + c * size, type, normalized); }
};

class GltfReader {
 public:
  GltfReader(const MeshLimits& limits, const std::string* base_dir) : limits_(limits), base_dir_(base_dir) {}

  Status parse(const uint8_t* data, size_t size, std::vector<float>* saliency);
  Mesh take_mesh() { return mesh_from_absolute(positions_, std::move(indices_)); }

 private:
  Status load_container(const uint8_t* data, size_t size);
  Status load_buffers();
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
        const size_t comma = u.find(";base64,");
        if (comma == std::string::npos) return bad("buffer " + std::to_string(i) + ": only base64 data: URIs are supported");
        owned_.emplace_back();
        if (!decode_base64(std::string_view(u).substr(comma + 8), &owned_.back()))
          return bad("buffer " + std::to_string(i) + ": the data: URI is not valid base64");
      } else if (!base_dir_) {
        return bad("buffer " + std::to_string(i) + " is the external file " + quote(u) +
                   ", which an upload cannot carry: send a .glb with the buffers inside");
      } else {
        if (u.find("..") != std::string::npos || u.empty() || u[0] == '/')
          return bad("buffer " + std::to_string(i) + ": external file " + quote(u) +
                     " must be a relative path inside the model's folder");
        StatusOr<std::vector<uint8_t>> file = read_file(*base_dir_ + "/" + u);
        if (!file.ok()) return bad("external buffer " + quote(u) + " is missing or unreadable (" + file.status().message() + ")");
        owned_.push_back(std::move(*file));
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

Status GltfReader::add_primitive(const json& primitive, const Matrix& m, std::vector<float>* want_saliency) {
  std::vector<double> local;  // #V x 3, the primitive's own frame
  std::vector<uint32_t> corners;
  std::vector<float> saliency;
  bool has_saliency = false;
  const json* extensions = primitive.contains("extensions") ? &primitive["extensions"] : nullptr;
  if (extensions && extensions->is_object() && extensions->contains(kDracoExtension)) {
    const json& ext = (*extensions)[kDracoExtension];
    int64_t view = -1, stride = 0;
    if (!ext.is_object() || !get_index(ext, "bufferView", -1, &view) || view < 0)
      return bad(std::string(kDracoExtension) + " has no bufferView");
    Bytes bytes;
    VPR_RETURN_IF_ERROR(view_bytes(view, &bytes, &stride));
    MeshLimits remaining{limits_.max_vertices - positions_.size() / 3, limits_.max_faces - indices_.size() / 3};
    std::vector<float> draco_saliency;
    StatusOr<Mesh> decoded = parse_draco(bytes.data, bytes.size, remaining, want_saliency ? &draco_saliency : nullptr);
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
