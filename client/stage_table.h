// The stage-timing table and JSON report printed by `vpremesh local` (and, in
// the service issue, by `vpremesh submit`).
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pipeline/pipeline.h"

namespace vpr::cli {

struct RunSummary {
  size_t input_vertices = 0;
  size_t input_faces = 0;
  size_t output_vertices = 0;
  size_t output_faces = 0;
  uint32_t target_vertices = 0;
  double read_ms = 0;   // input decode
  double write_ms = 0;  // output encode
  // Service runs only (negative: not shown): the client sending the upload,
  // and the job waiting in the server's queue.
  double upload_ms = -1;
  double queue_ms = -1;
};

std::string format_stage_table(const PipelineResult& result, const RunSummary& summary);
nlohmann::json report_json(const PipelineResult& result, const RunSummary& summary);

}  // namespace vpr::cli
