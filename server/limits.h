// What one server accepts. Each limit is a vpremesh-server flag, and each
// check's error names the limit, its flag and the value that hit it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/mesh.h"
#include "pipeline/pipeline.h"
#include "core/status.h"

namespace vpr::service {

// Uploads and results travel in chunks of at most this many bytes.
inline constexpr size_t kMaxChunkBytes = size_t(1) << 20;

struct ServerLimits {
  uint64_t max_upload_bytes = uint64_t(512) << 20;    // --max-upload-mib 512
  size_t max_vertices = MeshLimits{}.max_vertices;    // --max-vertices: input vertices
  size_t max_faces = MeshLimits{}.max_faces;          // --max-faces: input faces
  uint32_t max_target_vertices = kMaxTargetVertices;  // --max-target-vertices, at most the pipeline's
  size_t max_queue = 64;                              // --max-queue: jobs waiting (not running)
  size_t max_jobs_per_client = 4;                     // --max-jobs-per-client: unfinished jobs per tenant or address

  MeshLimits mesh_limits() const { return {max_vertices, max_faces}; }
};

// INVALID_ARGUMENT for a chunk over kMaxChunkBytes.
Status check_chunk(size_t chunk_bytes);
// RESOURCE_EXHAUSTED once the bytes received (or declared) pass the upload limit.
Status check_upload_size(const ServerLimits& limits, uint64_t bytes, bool declared);
// INVALID_ARGUMENT for an empty upload, a size that does not match the
// declared one, or bytes that are not a Draco file (glb: not a glTF binary).
Status check_upload_complete(uint64_t received, uint64_t declared, const uint8_t* head, size_t head_size,
                             bool glb = false);
// INVALID_ARGUMENT outside [kMinTargetVertices, max_target_vertices].
Status check_target(const ServerLimits& limits, uint32_t target_vertices);
// RESOURCE_EXHAUSTED when `waiting` jobs already fill the queue.
Status check_queue_length(const ServerLimits& limits, size_t waiting);
// The unfinished jobs one client may have: its own limit (a tenant's
// max_jobs= in --auth-tokens) or --max-jobs-per-client.
inline size_t client_job_limit(const ServerLimits& limits, size_t own_limit) {
  return own_limit > 0 ? own_limit : limits.max_jobs_per_client;
}
// RESOURCE_EXHAUSTED when the client already has `limit` unfinished jobs.
Status check_client_jobs(size_t limit, const std::string& client, size_t unfinished);
// Names the --max-vertices / --max-faces flags in a mesh parser's limit error.
Status explain_mesh_limit(const Status& parse_status, const ServerLimits& limits);

}  // namespace vpr::service
