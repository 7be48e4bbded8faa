// Draco (.drc), the service's wire format. Decoding goes through
// draco::Decoder after a pre-scan of the header (below); encoding through
// draco::ExpertEncoder with quantized positions, optionally a GENERIC float
// attribute whose attribute metadata entry "name" is "saliency", and
// optionally the vertex colors as a COLOR attribute (3 normalized uint8,
// sRGB, as Draco's PLY reader stores PLY colors).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <memory>
#include <type_traits>
#include <new>
#include <string>

#include "draco/compression/decode.h"
#include "draco/compression/expert_encode.h"
#include "draco/core/decoder_buffer.h"
#include "draco/core/encoder_buffer.h"
#include "draco/mesh/mesh.h"
#include "draco/metadata/geometry_metadata.h"
#include "io/mesh_io.h"
#include "io/parsers.h"

namespace vpr {
namespace io_detail {

namespace {

constexpr const char* kSaliencyName = "saliency";
// Metadata of a 64-bit position attribute: the frame the writer's mesh had
// (origin x, y, z and scale, mesh.h), so that a reader gets back exactly its
// floats; readers without it see ordinary absolute positions.
constexpr const char* kFrameName = "vpremesh_frame";
// Nesting of sub-metadata that the pre-scan accepts (the encoder writes 0).
constexpr int kMaxMetadataDepth = 16;
// Declared faces (and vertices) per byte of input that the pre-scan accepts.
// The densest real stream measured, a regular 400 x 400 grid at speed 0,
// holds 39 faces per byte; 1000 leaves a wide margin while keeping a few
// hostile bytes from making the decoder allocate gigabytes.
constexpr uint64_t kMaxElementsPerByte = 1000;

// ---- Header pre-scan -------------------------------------------------------
// draco::Decoder (1.5.5) sizes tables from counts in the stream before it
// checks them against the data: the edgebreaker corner table from num_faces,
// metadata entries from their declared size, and it recurses once per level
// of sub-metadata. A few hostile bytes could therefore ask for gigabytes or
// overflow the stack. The pre-scan walks the same fields (bitstreams 1.0 to
// 2.2, whose layouts differ in count widths and fields; see
// point_cloud_decoder.cc, metadata_decoder.cc, mesh_sequential_decoder.cc and
// mesh_edgebreaker_decoder_impl.cc) and refuses counts beyond MeshLimits or
// the bytes present, before the decoder allocates anything.

class ByteReader {
 public:
  ByteReader(const uint8_t* p, size_t n) : p_(p), end_(p + n) {}
  bool u8(uint8_t* v) {
    if (p_ >= end_) return false;
    *v = *p_++;
    return true;
  }
  // Draco's DecodeVarint for uint32: at most 5 bytes, low 7 bits first, bits
  // beyond 32 dropped as Draco's shifts drop them.
  bool varint(uint32_t* v) {
    uint64_t value = 0;
    for (int i = 0; i < 5; ++i) {
      uint8_t b;
      if (!u8(&b)) return false;
      value |= uint64_t(b & 0x7f) << (7 * i);
      if (!(b & 0x80)) {
        *v = uint32_t(value);
        return true;
      }
    }
    return false;
  }
  bool skip(uint64_t n) {
    if (uint64_t(end_ - p_) < n) return false;
    p_ += n;
    return true;
  }

 private:
  const uint8_t* p_;
  const uint8_t* end_;
};

Status truncated(const char* what) {
  return invalid_argument(std::string("Draco: the data ends inside the ") + what + " (truncated or corrupt)");
}

Status scan_metadata(ByteReader* r, int depth) {
  if (depth > kMaxMetadataDepth)
    return invalid_argument("Draco: metadata is nested deeper than " + std::to_string(kMaxMetadataDepth) +
                            " levels (corrupt data)");
  uint32_t entries = 0;
  if (!r->varint(&entries)) return truncated("metadata");
  for (uint32_t i = 0; i < entries; ++i) {
    uint8_t name_length = 0;
    uint32_t value_size = 0;
    if (!r->u8(&name_length) || !r->skip(name_length) || !r->varint(&value_size)) return truncated("metadata");
    if (value_size == 0) return invalid_argument("Draco: a metadata entry has an empty value (corrupt data)");
    if (!r->skip(value_size)) return truncated("metadata");
  }
  uint32_t children = 0;
  if (!r->varint(&children)) return truncated("metadata");
  for (uint32_t i = 0; i < children; ++i) {
    uint8_t name_length = 0;
    if (!r->u8(&name_length) || !r->skip(name_length)) return truncated("metadata");
    VPR_RETURN_IF_ERROR(scan_metadata(r, depth + 1));
  }
  return Status::Ok();
}

Status check_count(uint32_t count, size_t limit, const char* what) {
  if (count > limit)
    return resource_exhausted("Draco: the header declares " + std::to_string(count) + " " + what + ", the limit is " +
                              std::to_string(limit));
  return Status::Ok();
}

Status check_density(uint32_t count, size_t size, const char* what) {
  if (count > kMaxElementsPerByte * size)
    return invalid_argument("Draco: the header declares " + std::to_string(count) + " " + what + " in " +
                            std::to_string(size) + " bytes, more than " + std::to_string(kMaxElementsPerByte) +
                            " per byte (corrupt data)");
  return Status::Ok();
}

// Bitstream versions whose connectivity header the pre-scan knows: 1.0 to 1.3
// and 2.0 to 2.2, every one libdraco 1.5 reads (major 0 it refuses).
bool known_version(uint8_t major, uint8_t minor) { return (major == 1 && minor <= 3) || (major == 2 && minor <= 2); }

// A count the connectivity header stores: a little-endian uint32 before
// bitstream 2.0, a varint from 2.0 on (mesh_edgebreaker_decoder_impl.cc,
// DecodeConnectivity).
bool read_count(ByteReader* r, bool fixed_width, uint32_t* v) {
  if (!fixed_width) return r->varint(v);
  uint8_t b[4];
  for (uint8_t& x : b)
    if (!r->u8(&x)) return false;
  *v = uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
  return true;
}

Status check_vertices_and_faces(uint32_t vertices, uint32_t faces, size_t size, const MeshLimits& limits) {
  VPR_RETURN_IF_ERROR(check_count(faces, limits.max_faces, "faces"));
  VPR_RETURN_IF_ERROR(check_count(vertices, limits.max_vertices, "vertices"));
  VPR_RETURN_IF_ERROR(check_density(faces, size, "faces"));
  return check_density(vertices, size, "vertices");
}

Status prescan_draco(const uint8_t* data, size_t size, const MeshLimits& limits) {
  if (size < 5 || std::memcmp(data, "DRACO", 5) != 0)
    return invalid_argument("Draco: the data does not start with 'DRACO' (not a Draco file)");
  ByteReader r(data + 5, size - 5);
  uint8_t major = 0, minor = 0, type = 0, method = 0, flags_lo = 0, flags_hi = 0;
  if (!r.u8(&major) || !r.u8(&minor) || !r.u8(&type) || !r.u8(&method) || !r.u8(&flags_lo) || !r.u8(&flags_hi))
    return truncated("header");
  if (type == 0)
    return invalid_argument("Draco: no faces: the input is a point cloud, a triangle mesh or polygon soup is required");
  if (type != 1) return invalid_argument("Draco: unknown geometry type " + std::to_string(type) + " (corrupt data)");
  if (!known_version(major, minor))
    return invalid_argument("Draco: bitstream version " + std::to_string(major) + "." + std::to_string(minor) +
                            " is not supported (supported: 1.0 to 1.3 and 2.0 to 2.2)");
  const int version = major * 256 + minor;  // DRACO_BITSTREAM_VERSION
  const bool fixed_width = version < 0x200;
  const uint16_t flags = uint16_t(flags_lo | flags_hi << 8);
  // Metadata exists from bitstream 1.3 on; older decoders ignore the flag.
  if (version >= 0x103 && (flags & 0x8000)) {  // METADATA_FLAG_MASK
    uint32_t attribute_metadata = 0;
    if (!r.varint(&attribute_metadata)) return truncated("metadata");
    for (uint32_t i = 0; i < attribute_metadata; ++i) {
      uint32_t unique_id = 0;
      if (!r.varint(&unique_id)) return truncated("metadata");
      VPR_RETURN_IF_ERROR(scan_metadata(&r, 0));
    }
    VPR_RETURN_IF_ERROR(scan_metadata(&r, 0));
  }
  if (method == 0) {  // MESH_SEQUENTIAL_ENCODING (mesh_sequential_decoder.cc): uint32 before 2.2
    uint32_t faces = 0, points = 0;
    const bool fixed = version < 0x202;
    if (!read_count(&r, fixed, &faces) || !read_count(&r, fixed, &points)) return truncated("connectivity header");
    VPR_RETURN_IF_ERROR(check_vertices_and_faces(points, faces, size, limits));
  } else if (method == 1) {  // MESH_EDGEBREAKER_ENCODING (mesh_edgebreaker_decoder_impl.cc)
    uint8_t traversal = 0, attribute_data = 0;
    uint32_t new_vertices = 0, vertices = 0, faces = 0, symbols = 0, split_symbols = 0;
    if (!r.u8(&traversal)) return truncated("connectivity header");
    // Before 2.2 the stream names the vertices added to split non-manifold ones.
    if (version < 0x202 && !read_count(&r, fixed_width, &new_vertices)) return truncated("connectivity header");
    if (!read_count(&r, fixed_width, &vertices) || !read_count(&r, fixed_width, &faces) || !r.u8(&attribute_data) ||
        !read_count(&r, fixed_width, &symbols) || !read_count(&r, fixed_width, &split_symbols))
      return truncated("connectivity header");
    VPR_RETURN_IF_ERROR(check_vertices_and_faces(vertices, faces, size, limits));
    VPR_RETURN_IF_ERROR(check_count(new_vertices, limits.max_vertices, "added vertices"));
    VPR_RETURN_IF_ERROR(check_density(new_vertices, size, "added vertices"));
    // Each split symbol is one of the symbols, and there is at most one symbol per face.
    if (symbols > faces || split_symbols > symbols)
      return invalid_argument("Draco: inconsistent connectivity header (" + std::to_string(symbols) + " symbols, " +
                              std::to_string(split_symbols) + " split symbols, " + std::to_string(faces) +
                              " faces): corrupt data");
  } else {
    return invalid_argument("Draco: unknown mesh encoding method " + std::to_string(method) + " (corrupt data)");
  }
  return Status::Ok();
}

// An attribute's stored type, when we can read numbers from it. Booleans are
// not: Draco would load any byte of the stream as a bool.
Status check_numeric(const draco::PointAttribute& att, const char* what) {
  const draco::DataType t = att.data_type();
  if (t == draco::DT_BOOL || t <= draco::DT_INVALID || t >= draco::DT_TYPES_COUNT)
    return invalid_argument(std::string("Draco: the ") + what + " attribute has data type " + std::to_string(int(t)) +
                            ", a numeric type is needed (corrupt data)");
  return Status::Ok();
}

// Reads one attribute value per point; false when the mapping or the data is
// inconsistent. Through double and to_float: a float64 value beyond the
// float range becomes +-inf (refused by validate_mesh) rather than an
// undefined conversion inside Draco.
template <class T>
bool gather(const draco::PointAttribute& att, uint32_t num_points, int components, T* out) {
  if (!att.is_mapping_identity() && att.indices_map_size() < num_points) return false;
  if (components < 1 || components > 4) return false;
  // Floats are read as they are stored (what ConvertValue gives them, without
  // its per-value dispatch); other types through ConvertValue.
  const draco::DataType type = att.data_type();
  const bool plain = (type == draco::DT_FLOAT32 || type == draco::DT_FLOAT64) && att.num_components() >= components &&
                     att.buffer() != nullptr;
  std::atomic<bool> ok{true};
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, num_points, 16384), [&](const tbb::blocked_range<uint32_t>& r) {
    double value[4];
    for (uint32_t p = r.begin(); p != r.end(); ++p) {
      const draco::AttributeValueIndex index = att.mapped_index(draco::PointIndex(p));
      if (index.value() >= att.size()) {
        ok = false;
        return;
      }
      if (plain) {
        const uint8_t* at = att.GetAddress(index);
        for (int c = 0; c < components; ++c) {
          if (type == draco::DT_FLOAT32) {
            float f;
            std::memcpy(&f, at + c * sizeof f, sizeof f);
            value[c] = f;
          } else {
            std::memcpy(&value[c], at + c * sizeof(double), sizeof(double));
          }
        }
      } else if (!att.ConvertValue<double>(index, int8_t(components), value)) {
        ok = false;
        return;
      }
      for (int c = 0; c < components; ++c) {
        if constexpr (std::is_same_v<T, float>)
          out[size_t(p) * components + c] = to_float(value[c]);
        else
          out[size_t(p) * components + c] = value[c];
      }
    }
  });
  return ok.load();
}

// Positions on the grid Draco's quantizer would use (AttributeQuantization-
// Transform: the minimum per axis, one step size from the largest extent),
// in the mesh's relative frame; returned in absolute double coordinates.
std::vector<double> quantized_absolute(const Mesh& mesh, int bits) {
  const size_t nv = mesh.vertex_count();
  std::vector<double> out(3 * nv);
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (size_t i = 0; i < 3 * nv; ++i) {
    lo[i % 3] = std::min(lo[i % 3], double(mesh.positions[i]));
    hi[i % 3] = std::max(hi[i % 3], double(mesh.positions[i]));
  }
  const double range = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  const double steps = double((uint64_t(1) << bits) - 1);
  for (size_t i = 0; i < 3 * nv; ++i) {
    double relative = mesh.positions[i];
    if (bits > 0 && range > 0) relative = lo[i % 3] + std::floor((relative - lo[i % 3]) * steps / range + 0.5) * range / steps;
    out[i] = mesh.origin[i % 3] + mesh.scale * relative;
  }
  return out;
}

}  // namespace

StatusOr<Mesh> parse_draco(const uint8_t* data, size_t size, const MeshLimits& limits, std::vector<float>* saliency,
                           const std::vector<DracoAttributeRequest>& requests) {
  VPR_RETURN_IF_ERROR(prescan_draco(data, size, limits));
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(data), size);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok())
    return invalid_argument("Draco: cannot decode the mesh (" + decoded.status().error_msg_string() +
                            "): the data is corrupt or truncated");
  const std::unique_ptr<draco::Mesh> dm = std::move(decoded).value();
  if (!dm) return invalid_argument("Draco: the decoder returned no mesh (corrupt data)");

  const uint32_t num_points = dm->num_points();
  const uint32_t num_faces = dm->num_faces();
  VPR_RETURN_IF_ERROR(check_count(num_points, limits.max_vertices, "vertices"));
  VPR_RETURN_IF_ERROR(check_count(num_faces, limits.max_faces, "faces"));
  const draco::PointAttribute* position = dm->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  if (!position) return invalid_argument("Draco: the mesh has no POSITION attribute");
  if (position->num_components() != 3)
    return invalid_argument("Draco: positions have " + std::to_string(int(position->num_components())) +
                            " components, 3 are needed");

  VPR_RETURN_IF_ERROR(check_numeric(*position, "position"));

  std::vector<double> positions(size_t(num_points) * 3);
  if (!gather(*position, num_points, 3, positions.data()))
    return invalid_argument("Draco: the position attribute does not cover every point (corrupt data)");
  std::vector<uint32_t> indices(size_t(num_faces) * 3);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, num_faces, 32768), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t f = r.begin(); f != r.end(); ++f) {
      const draco::Mesh::Face& face = dm->face(draco::FaceIndex(f));
      for (int k = 0; k < 3; ++k) indices[3 * size_t(f) + k] = face[k].value();
    }
  });
  Mesh mesh = mesh_from_absolute(positions, std::move(indices));
  // The writer's frame, when it left one and it is usable: the same floats.
  const draco::AttributeMetadata* position_metadata =
      dm->GetAttributeMetadataByAttributeId(dm->GetNamedAttributeId(draco::GeometryAttribute::POSITION));
  std::vector<double> frame;
  // Only a frame within 1e-6 of the one computed here (what a writer of the
  // same mesh leaves): another would cost the floats their precision.
  auto near_computed = [&](const std::vector<double>& f) {
    if (f.size() != 4) return false;
    for (int a = 0; a < 3; ++a)
      if (!(std::fabs(f[size_t(a)] - mesh.origin[size_t(a)]) <= 1e-6 * mesh.scale)) return false;
    return std::fabs(f[3] - mesh.scale) <= 1e-6 * mesh.scale;
  };
  if (position_metadata && position_metadata->GetEntryDoubleArray(kFrameName, &frame) && near_computed(frame)) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, positions.size(), 32768), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) {
        const double x = (positions[i] - frame[i % 3]) / frame[3];
        mesh.positions[i] = std::isnan(positions[i]) ? NAN : to_float(x);
      }
    });
    mesh.origin = {frame[0], frame[1], frame[2]};
    mesh.scale = frame[3];
  }

  // The first COLOR attribute of 3 or 4 components, as 8-bit sRGB.
  const draco::PointAttribute* color = dm->GetNamedAttribute(draco::GeometryAttribute::COLOR);
  if (color && color->num_components() >= 3) {
    VPR_RETURN_IF_ERROR(check_numeric(*color, "color"));
    std::vector<double> values(size_t(num_points) * 3);
    if (!gather(*color, num_points, 3, values.data()))
      return invalid_argument("Draco: the color attribute does not cover every point (corrupt data)");
    // Normalized integers and floats come in [0, 1]; other integers as stored.
    const draco::DataType t = color->data_type();
    const bool integer = t != draco::DT_FLOAT32 && t != draco::DT_FLOAT64;
    const double full = !integer || color->normalized()                   ? 1
                        : (t == draco::DT_UINT16 || t == draco::DT_INT16) ? 65535
                                                                          : 255;
    mesh.colors.resize(values.size());
    for (size_t i = 0; i < values.size(); ++i) mesh.colors[i] = unit_to_byte(values[i] / full);
  }
  for (const DracoAttributeRequest& request : requests) {
    const draco::PointAttribute* att = dm->GetAttributeByUniqueId(uint32_t(request.unique_id));
    if (request.unique_id < 0 || !att)
      return invalid_argument("Draco: the stream has no attribute with unique id " + std::to_string(request.unique_id));
    if (att->num_components() < request.components)
      return invalid_argument("Draco: attribute " + std::to_string(request.unique_id) + " has " +
                              std::to_string(int(att->num_components())) + " components, " +
                              std::to_string(request.components) + " are needed");
    VPR_RETURN_IF_ERROR(check_numeric(*att, "requested"));
    request.out->resize(size_t(num_points) * size_t(request.components));
    if (!gather(*att, num_points, request.components, request.out->data()))
      return invalid_argument("Draco: attribute " + std::to_string(request.unique_id) +
                              " does not cover every point (corrupt data)");
  }

  if (saliency) {
    saliency->clear();
    const int id = dm->GetAttributeIdByMetadataEntry("name", kSaliencyName);
    if (id >= 0) {
      const draco::PointAttribute* att = dm->attribute(id);
      if (att->num_components() != 1)
        return invalid_argument("Draco: the saliency attribute has " + std::to_string(int(att->num_components())) +
                                " components, 1 is expected");
      VPR_RETURN_IF_ERROR(check_numeric(*att, "saliency"));
      saliency->resize(num_points);
      if (!gather(*att, num_points, 1, saliency->data()))
        return invalid_argument("Draco: the saliency attribute does not cover every point (corrupt data)");
    }
  }
  return mesh;
}

}  // namespace io_detail

StatusOr<std::vector<uint8_t>> encode_draco(const Mesh& mesh, const float* saliency, const DracoOptions& options) {
  return io_detail::encode_draco_stream(mesh, saliency, options, io_detail::DracoColors::kSrgb8, nullptr);
}

namespace io_detail {

StatusOr<std::vector<uint8_t>> encode_draco_stream(const Mesh& mesh, const float* saliency, const DracoOptions& options,
                                                   DracoColors color_encoding, DracoIds* ids) {
  // Draco's quantizer takes 1..30 bits (0: positions stay 32-bit floats); speeds run 0..10.
  if (options.position_bits < 0 || options.position_bits > 30)
    return invalid_argument("DracoOptions.position_bits is " + std::to_string(options.position_bits) +
                            ", it must be in 0..30 (0 = lossless)");
  if (options.saliency_bits < 1 || options.saliency_bits > 30)
    return invalid_argument("DracoOptions.saliency_bits is " + std::to_string(options.saliency_bits) +
                            ", it must be in 1..30");
  if (options.speed < 0 || options.speed > 10)
    return invalid_argument("DracoOptions.speed is " + std::to_string(options.speed) + ", it must be in 0..10");
  VPR_RETURN_IF_ERROR(io_detail::check_writable(mesh, saliency));
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (nv == 0 || nf == 0)
    return invalid_argument("Draco: cannot encode a mesh with " + std::to_string(nv) + " vertices and " +
                            std::to_string(nf) + " faces");

  draco::Mesh dm;
  dm.set_num_points(uint32_t(nv));
  // Draco quantizes 32-bit floats only, with a float origin: where floats
  // cannot hold the model to 1e-6 of its size (far from zero), positions are
  // stored as 64-bit floats, snapped to the grid the quantizer would use in
  // the mesh's own frame, so both kinds of file move a vertex by at most half
  // a quantization step. Lossless files (position_bits 0) are 64-bit too: a
  // reader gets back exactly the floats of the mesh's frame (mesh.h), so an
  // upload runs on what `vpremesh local` runs on.
  const bool as_float = options.position_bits > 0 && absolute_fits_float(mesh);
  draco::GeometryAttribute position;
  if (as_float) {
    position.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, sizeof(float) * 3, 0);
  } else {
    position.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT64, false, sizeof(double) * 3, 0);
  }
  const int position_id = dm.AddAttribute(position, true, uint32_t(nv));
  if (as_float) {
    const std::vector<float> absolute = absolute_positions(mesh);
    for (size_t i = 0; i < nv; ++i)
      dm.attribute(position_id)->SetAttributeValue(draco::AttributeValueIndex(uint32_t(i)), &absolute[3 * i]);
  } else {
    const std::vector<double> absolute = io_detail::quantized_absolute(mesh, options.position_bits);
    for (size_t i = 0; i < nv; ++i)
      dm.attribute(position_id)->SetAttributeValue(draco::AttributeValueIndex(uint32_t(i)), &absolute[3 * i]);
    auto frame = std::make_unique<draco::AttributeMetadata>();
    frame->AddEntryDoubleArray(io_detail::kFrameName, {mesh.origin[0], mesh.origin[1], mesh.origin[2], mesh.scale});
    dm.AddAttributeMetadata(position_id, std::move(frame));
  }
  int saliency_id = -1;
  if (saliency) {
    draco::GeometryAttribute generic;
    generic.Init(draco::GeometryAttribute::GENERIC, nullptr, 1, draco::DT_FLOAT32, false, sizeof(float), 0);
    saliency_id = dm.AddAttribute(generic, true, uint32_t(nv));
    for (size_t i = 0; i < nv; ++i)
      dm.attribute(saliency_id)->SetAttributeValue(draco::AttributeValueIndex(uint32_t(i)), &saliency[i]);
    auto metadata = std::make_unique<draco::AttributeMetadata>();
    metadata->AddEntryString("name", io_detail::kSaliencyName);
    dm.AddAttributeMetadata(saliency_id, std::move(metadata));
  }
  int color_id = -1;
  if (!mesh.colors.empty()) {
    draco::GeometryAttribute color;
    if (color_encoding == DracoColors::kSrgb8) {
      color.Init(draco::GeometryAttribute::COLOR, nullptr, 3, draco::DT_UINT8, true, 3, 0);
      color_id = dm.AddAttribute(color, true, uint32_t(nv));
      for (size_t i = 0; i < nv; ++i)
        dm.attribute(color_id)->SetAttributeValue(draco::AttributeValueIndex(uint32_t(i)), &mesh.colors[3 * i]);
    } else {
      color.Init(draco::GeometryAttribute::COLOR, nullptr, 3, draco::DT_UINT16, true, 6, 0);
      color_id = dm.AddAttribute(color, true, uint32_t(nv));
      for (size_t i = 0; i < nv; ++i) {
        uint16_t linear[3];
        for (size_t c = 0; c < 3; ++c) linear[c] = linear16(mesh.colors[3 * i + c]);
        dm.attribute(color_id)->SetAttributeValue(draco::AttributeValueIndex(uint32_t(i)), linear);
      }
    }
  }
  if (ids) {
    auto unique = [&dm](int id) { return id < 0 ? -1 : int(dm.attribute(id)->unique_id()); };
    *ids = {unique(position_id), unique(saliency_id), unique(color_id)};
  }
  dm.SetNumFaces(nf);
  for (size_t f = 0; f < nf; ++f) {
    draco::Mesh::Face face;
    for (int k = 0; k < 3; ++k) face[k] = draco::PointIndex(mesh.indices[3 * f + k]);
    dm.SetFace(draco::FaceIndex(uint32_t(f)), face);
  }

  draco::ExpertEncoder encoder(dm);
  if (options.position_bits > 0 && as_float) encoder.SetAttributeQuantization(position_id, options.position_bits);
  if (saliency_id >= 0) encoder.SetAttributeQuantization(saliency_id, options.saliency_bits);
  encoder.SetSpeedOptions(options.speed, options.speed);
  draco::EncoderBuffer out;
  try {
    const draco::Status status = encoder.EncodeToBuffer(&out);
    if (!status.ok()) return invalid_argument("Draco encoder: " + status.error_msg_string());
  } catch (const std::bad_alloc&) {
    return resource_exhausted("Draco encoder: out of memory for " + std::to_string(nf) + " faces");
  }
  const uint8_t* bytes = reinterpret_cast<const uint8_t*>(out.data());
  return std::vector<uint8_t>(bytes, bytes + out.size());
}

}  // namespace io_detail

}  // namespace vpr
