// The upload half of the Remesh and Submit calls, shared by `vpremesh submit`
// and `vpremesh bench`: the input as the Draco file the service takes, and
// the stream that carries it (the spec first, then chunks of at most 1 MiB).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"
#include "vpremesh/v1/remesh.pb.h"

namespace vpr::cli {

// The API's chunk limit (remesh.proto: "at most 1 MiB each").
inline constexpr size_t kChunkBytes = size_t(1) << 20;

// The bytes to upload for `path` (defined in submit_command.cpp): a .drc file
// as it is (the server validates it); any other format parsed here and encoded
// with sequential connectivity, which keeps every vertex and face in its
// order. quantization_bits: Draco position bits, 0 = lossless. parsed (when
// not null) receives the mesh as read here, the same read as `vpremesh local`'s.
// glb (when not null): set when the upload is a .glb with base-color textures,
// sent as it is (Draco carries no textures) for INPUT_FORMAT_GLTF_BINARY.
StatusOr<std::vector<uint8_t>> draco_upload(const std::string& path, int quantization_bits, Mesh* parsed = nullptr,
                                            bool* glb = nullptr);

// Writes the spec and then the file in chunks, waits for the server's
// response headers, and half-closes. False when the server closed the stream
// early (a refusal) or the connection failed: the status then comes from
// Finish().
//
// The server sends its headers when the stream opens and accepts an upload
// only at the half-close; gRPC retries a call only until headers arrive. So
// until the headers come, gRPC may send the upload again on a new connection
// (the server has not accepted it); after, it never does (channel.h).
template <class Writer>
bool upload(Writer& writer, const vpremesh::v1::JobSpec& spec, const std::vector<uint8_t>& bytes) {
  vpremesh::v1::RemeshRequest request;
  *request.mutable_spec() = spec;
  if (!writer.Write(request)) return false;
  for (size_t offset = 0; offset < bytes.size(); offset += kChunkBytes) {
    const size_t n = std::min(kChunkBytes, bytes.size() - offset);
    request.set_mesh_chunk(bytes.data() + offset, n);
    if (!writer.Write(request)) return false;
  }
  writer.WaitForInitialMetadata();
  return writer.WritesDone();
}

}  // namespace vpr::cli
