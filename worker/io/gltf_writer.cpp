// glTF 2.0 output (gltf_reader.cpp says why glTF is not written through
// libdraco): one GLB, or .gltf with the buffer as a data: URI, whose node
// carries the mesh frame (translation = origin, scale = scale, mesh.h), so
// the float positions are written as they are; the saliency field is the
// vertex attribute _SALIENCY (glTF's prefix for application attributes), the
// colors are COLOR_0 (linear, unsigned 16-bit normalized), and the primitive
// is Draco-compressed (KHR_draco_mesh_compression) when asked.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/mesh_io.h"
#include "io/parsers.h"

namespace vpr {

namespace {

using io_detail::kDracoExtensionName;
using io_detail::kSaliencyAttributeName;

void append_base64(const std::vector<uint8_t>& bytes, std::string* out) {
  static const char kDigits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t n = uint32_t(bytes[i]) << 16 | (i + 1 < bytes.size() ? uint32_t(bytes[i + 1]) << 8 : 0) |
                       (i + 2 < bytes.size() ? uint32_t(bytes[i + 2]) : 0);
    out->push_back(kDigits[(n >> 18) & 63]);
    out->push_back(kDigits[(n >> 12) & 63]);
    out->push_back(i + 1 < bytes.size() ? kDigits[(n >> 6) & 63] : '=');
    out->push_back(i + 2 < bytes.size() ? kDigits[n & 63] : '=');
  }
}

void append_floats(const float* values, size_t n, std::vector<uint8_t>* out) {
  const size_t at = out->size();
  out->resize(at + 4 * n);
  std::memcpy(out->data() + at, values, 4 * n);  // glTF is little-endian, as are our targets
}

void pad4(std::vector<uint8_t>* bytes, uint8_t fill) {
  while (bytes->size() % 4) bytes->push_back(fill);
}

void put32(std::vector<uint8_t>* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(uint8_t(v >> (8 * i)));
}

}  // namespace

StatusOr<std::vector<uint8_t>> encode_gltf(const Mesh& mesh, const float* saliency, const DracoOptions& options,
                                           bool binary) {
  VPR_RETURN_IF_ERROR(io_detail::check_writable(mesh, saliency));
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (nv == 0 || nf == 0)
    return invalid_argument("glTF: cannot write a mesh with " + std::to_string(nv) + " vertices and " +
                            std::to_string(nf) + " faces");
  using json = nlohmann::json;
  // The frame goes into the node, so the floats are written as they are.
  json node = {{"mesh", 0},
               {"translation", {mesh.origin[0], mesh.origin[1], mesh.origin[2]}},
               {"scale", {mesh.scale, mesh.scale, mesh.scale}}};
  float lo[3] = {HUGE_VALF, HUGE_VALF, HUGE_VALF}, hi[3] = {-HUGE_VALF, -HUGE_VALF, -HUGE_VALF};
  for (size_t i = 0; i < 3 * nv; ++i) {
    lo[i % 3] = std::min(lo[i % 3], mesh.positions[i]);
    hi[i % 3] = std::max(hi[i % 3], mesh.positions[i]);
  }
  json position = {{"componentType", 5126}, {"count", nv}, {"type", "VEC3"},
                   {"min", {lo[0], lo[1], lo[2]}}, {"max", {hi[0], hi[1], hi[2]}}};
  json index = {{"componentType", 5125}, {"count", 3 * nf}, {"type", "SCALAR"}};
  json value = {{"componentType", 5126}, {"count", nv}, {"type", "SCALAR"}};
  json color = {{"componentType", 5123}, {"normalized", true}, {"count", nv}, {"type", "VEC3"}};
  const bool colors = !mesh.colors.empty();
  json primitive = {{"attributes", {{"POSITION", 0}}}, {"indices", 1}, {"mode", 4}};
  if (saliency) primitive["attributes"][kSaliencyAttributeName] = 2;
  if (colors) primitive["attributes"]["COLOR_0"] = saliency ? 3 : 2;
  json views = json::array();
  std::vector<uint8_t> bin;
  // Lossless output (position_bits 0) stays uncompressed: the extension
  // needs float positions that Draco would otherwise quantize.
  const bool compress = options.gltf_draco && options.position_bits > 0;
  if (compress) {
    Mesh relative = mesh;
    relative.origin = {0, 0, 0};
    relative.scale = 1;
    io_detail::DracoIds ids;
    VPR_ASSIGN_OR_RETURN(
        bin, io_detail::encode_draco_stream(relative, saliency, options, io_detail::DracoColors::kLinear16, &ids));
    // Edgebreaker may drop degenerate faces: the accessors give what decodes.
    std::vector<float> decoded_saliency;
    StatusOr<Mesh> decoded = io_detail::parse_draco(bin.data(), bin.size(), MeshLimits{}, nullptr);
    if (!decoded.ok()) return internal_error("glTF: the Draco primitive written does not decode: " + decoded.status().message());
    for (json* accessor : {&position, &value, &color}) (*accessor)["count"] = decoded->vertex_count();
    index["count"] = 3 * decoded->face_count();
    views.push_back({{"buffer", 0}, {"byteOffset", 0}, {"byteLength", bin.size()}});
    json attributes = {{"POSITION", ids.position}};
    if (saliency) attributes[kSaliencyAttributeName] = ids.saliency;
    if (colors) attributes["COLOR_0"] = ids.color;
    primitive["extensions"] = {{kDracoExtensionName, {{"bufferView", 0}, {"attributes", attributes}}}};
  } else {
    append_floats(mesh.positions.data(), 3 * nv, &bin);
    views.push_back({{"buffer", 0}, {"byteOffset", 0}, {"byteLength", bin.size()}, {"target", 34962}});
    const size_t indices_at = bin.size();
    bin.resize(indices_at + 4 * 3 * nf);
    std::memcpy(bin.data() + indices_at, mesh.indices.data(), 4 * 3 * nf);
    views.push_back({{"buffer", 0}, {"byteOffset", indices_at}, {"byteLength", 4 * 3 * nf}, {"target", 34963}});
    position["bufferView"] = 0;
    index["bufferView"] = 1;
    if (saliency) {
      const size_t at = bin.size();
      append_floats(saliency, nv, &bin);
      views.push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", 4 * nv}, {"target", 34962}});
      value["bufferView"] = views.size() - 1;
    }
    if (colors) {
      // 6 bytes a vertex, strided to 8: vertex attributes start on 4-byte
      // boundaries (glTF 2.0, 3.6.2.4).
      const size_t at = bin.size();
      bin.resize(at + 8 * nv, 0);
      for (size_t v = 0; v < nv; ++v)
        for (size_t c = 0; c < 3; ++c) {
          const uint16_t linear = io_detail::linear16(mesh.colors[3 * v + c]);
          bin[at + 8 * v + 2 * c] = uint8_t(linear);
          bin[at + 8 * v + 2 * c + 1] = uint8_t(linear >> 8);
        }
      views.push_back(
          {{"buffer", 0}, {"byteOffset", at}, {"byteLength", 8 * nv}, {"byteStride", 8}, {"target", 34962}});
      color["bufferView"] = views.size() - 1;
    }
  }
  pad4(&bin, 0);
  json accessors = {position, index};
  if (saliency) accessors.push_back(value);
  if (colors) accessors.push_back(color);
  json root = {{"asset", {{"version", "2.0"}, {"generator", "vpremesh"}}},
               {"scene", 0},
               {"scenes", {{{"nodes", {0}}}}},
               {"nodes", {node}},
               {"meshes", {{{"primitives", {primitive}}}}},
               {"accessors", accessors},
               {"bufferViews", views},
               {"buffers", {{{"byteLength", bin.size()}}}}};
  if (compress) {
    root["extensionsUsed"] = {kDracoExtensionName};
    root["extensionsRequired"] = {kDracoExtensionName};
  }
  if (!binary) {
    std::string uri = "data:application/octet-stream;base64,";
    append_base64(bin, &uri);
    root["buffers"][0]["uri"] = uri;
    const std::string text = root.dump(1);
    return std::vector<uint8_t>(text.begin(), text.end());
  }
  const std::string text = root.dump();
  std::vector<uint8_t> json_chunk(text.begin(), text.end());
  pad4(&json_chunk, ' ');
  std::vector<uint8_t> out;
  put32(&out, 0x46546C67);
  put32(&out, 2);
  put32(&out, uint32_t(12 + 8 + json_chunk.size() + 8 + bin.size()));
  put32(&out, uint32_t(json_chunk.size()));
  put32(&out, 0x4E4F534A);
  out.insert(out.end(), json_chunk.begin(), json_chunk.end());
  put32(&out, uint32_t(bin.size()));
  put32(&out, 0x004E4942);
  out.insert(out.end(), bin.begin(), bin.end());
  return out;
}

}  // namespace vpr
