#include "server/limits.h"

#include <cstring>

namespace vpr::service {
namespace {

std::string mib(uint64_t bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f MiB", double(bytes) / double(1 << 20));
  return buf;
}

}  // namespace

Status check_chunk(size_t chunk_bytes) {
  if (chunk_bytes > kMaxChunkBytes)
    return invalid_argument("mesh_chunk of " + std::to_string(chunk_bytes) + " bytes is over the chunk limit of " +
                            std::to_string(kMaxChunkBytes) + " bytes (1 MiB); split the upload");
  return Status::Ok();
}

Status check_upload_size(const ServerLimits& limits, uint64_t bytes, bool declared) {
  if (bytes > limits.max_upload_bytes)
    return resource_exhausted(std::string(declared ? "declared upload size " : "upload of at least ") + mib(bytes) +
                              " is over the upload limit of " + mib(limits.max_upload_bytes) + " (--max-upload-mib " +
                              std::to_string(limits.max_upload_bytes >> 20) + ")");
  return Status::Ok();
}

Status check_upload_complete(uint64_t received, uint64_t declared, const uint8_t* head, size_t head_size,
                             bool glb) {
  if (received == 0)
    return invalid_argument(std::string("the upload is empty: no mesh_chunk carried any bytes of a ") +
                            (glb ? "glTF binary" : "Draco file"));
  if (declared != 0 && received != declared)
    return invalid_argument("received " + std::to_string(received) + " bytes but mesh_size_bytes declared " +
                            std::to_string(declared) + " (truncated or overlong upload)");
  if (glb) {
    if (head_size < 4 || std::memcmp(head, "glTF", 4) != 0)
      return invalid_argument(
          "the upload is not a glTF binary (it does not start with 'glTF') but input_format is "
          "INPUT_FORMAT_GLTF_BINARY; send a .glb file");
    return Status::Ok();
  }
  if (head_size < 5 || std::memcmp(head, "DRACO", 5) != 0)
    return invalid_argument(
        "the upload is not a Draco file (it does not start with 'DRACO'); encode the mesh with "
        "Draco first");
  return Status::Ok();
}

Status check_target(const ServerLimits& limits, uint32_t target_vertices) {
  if (target_vertices < kMinTargetVertices || target_vertices > limits.max_target_vertices)
    return invalid_argument("target_vertices is " + std::to_string(target_vertices) + "; this server accepts [" +
                            std::to_string(kMinTargetVertices) + ", " + std::to_string(limits.max_target_vertices) +
                            "] (--max-target-vertices " + std::to_string(limits.max_target_vertices) + ")");
  return Status::Ok();
}

Status check_queue_length(const ServerLimits& limits, size_t waiting) {
  if (waiting >= limits.max_queue)
    return resource_exhausted("the job queue is full: " + std::to_string(waiting) +
                              " jobs waiting, the queue limit is " + std::to_string(limits.max_queue) +
                              " (--max-queue); retry later");
  return Status::Ok();
}

Status check_client_jobs(size_t limit, const std::string& client, size_t unfinished) {
  if (unfinished >= limit)
    return resource_exhausted("client " + client + " already has " + std::to_string(unfinished) +
                              " unfinished jobs; its limit is " + std::to_string(limit) +
                              " (--max-jobs-per-client, or the tenant's max_jobs= in --auth-tokens); retry when one "
                              "ends");
  return Status::Ok();
}

Status explain_mesh_limit(const Status& s, const ServerLimits& limits) {
  if (s.code() != StatusCode::kResourceExhausted) return s;
  return Status(s.code(), s.message() + " (server limits: --max-vertices " + std::to_string(limits.max_vertices) +
                              ", --max-faces " + std::to_string(limits.max_faces) + ")");
}

}  // namespace vpr::service
