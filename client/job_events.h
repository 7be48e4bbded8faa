// A job's events (from Remesh or Watch) put together, and the job's end
// turned into files, the stage table and an exit code; shared by `vpremesh
// submit` and `vpremesh watch` (job_follower.h reads the streams).
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "pipeline/pipeline.h"
#include "vpremesh/v1/remesh.pb.h"

namespace vpr::cli {

// Everything a job's events carry, put together.
struct JobOutcome {
  std::string job_id;
  std::vector<StageTiming> stages;  // in the order the server ran them
  std::string worker, device;       // from `started`
  double queue_ms = -1;             // from `started` (or `completed`); -1 until known
  std::vector<uint8_t> result;      // the output Draco file
  uint64_t result_total = 0;
  std::vector<float> saliency;  // one value per output vertex
  uint64_t saliency_total = 0;
  // A chain's levels after the first (JobSpec.levels): their meshes and
  // fields by level; level 0's are `result` and `saliency` above.
  struct LevelPayload {
    std::vector<uint8_t> result;
    uint64_t result_total = 0;
    std::vector<float> saliency;
    uint64_t saliency_total = 0;
  };
  std::map<uint32_t, LevelPayload> levels;
  std::vector<float> input_saliency;  // one value per input vertex (when asked for)
  uint64_t input_saliency_total = 0;
  enum class End { kNone, kCompleted, kFailed, kCancelled } end = End::kNone;
  vpremesh::v1::Completed summary;  // when completed
  vpremesh::v1::Failure failure;    // when failed or cancelled

  // Adds one event. A chunk out of order or past its total is INTERNAL (the
  // server broke the protocol).
  Status add(const vpremesh::v1::JobEvent& event);
};

// Where a finished job's payloads go; empty paths are skipped.
struct JobOutputs {
  std::string output;  // .drc (the server's bytes as they are), .ply or .obj; a chain: OUT.lodN.EXT per level
  // The saliency field: with input_mesh (the input as parsed locally) that
  // mesh colored by the job's input_saliency, as `vpremesh local --field-out`
  // writes it; without (watch: no input there) the result colored by its field.
  std::string field_out;
  const Mesh* input_mesh = nullptr;
  bool json = false;
  uint32_t target_vertices = 0;  // for the table's deviation column (0: unknown)
  double read_ms = -1;           // client side: reading and encoding the input
  double upload_ms = -1;         // client side: sending it
};

// Writes the outputs of a completed job and prints the stage table (or JSON)
// on stdout; for a failed or cancelled job prints one line on stderr. Returns
// the exit code.
int finish_job(const JobOutcome& outcome, const JobOutputs& outputs, const std::string& server);

// Sets the call's deadline `seconds` from now (0 or less: none).
void set_deadline(grpc::ClientContext& context, double seconds);

}  // namespace vpr::cli
