#include "job_events.h"

#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "channel_security.h"
#include "exit_codes.h"
#include "grpc_errors.h"
#include "io/mesh_io.h"
#include "pipeline_flags.h"
#include "stage_table.h"

namespace vpr::cli {

namespace v1 = vpremesh::v1;

namespace {

// Chunks arrive in order: each starts where the previous ended.
template <class Vec, class Chunk>
Status append_chunk(const char* what, const Chunk& chunk, const std::string& payload, Vec* into, uint64_t* total) {
  if (chunk.offset() != into->size())
    return internal_error(std::string(what) + " chunk at offset " + std::to_string(chunk.offset()) + ", expected " +
                          std::to_string(into->size()));
  if (chunk.total() < chunk.offset() + payload.size() || (*total != 0 && chunk.total() != *total))
    return internal_error(std::string(what) + " chunk passes its total of " + std::to_string(chunk.total()));
  *total = chunk.total();
  into->insert(into->end(), payload.begin(), payload.end());
  return {};
}

Status append_floats(const char* what, const v1::FloatChunk& chunk, std::vector<float>* into, uint64_t* total) {
  if (chunk.offset() != into->size())
    return internal_error(std::string(what) + " chunk at offset " + std::to_string(chunk.offset()) + ", expected " +
                          std::to_string(into->size()));
  if (chunk.total() < chunk.offset() + uint64_t(chunk.values_size()) || (*total != 0 && chunk.total() != *total))
    return internal_error(std::string(what) + " chunk passes its total of " + std::to_string(chunk.total()));
  *total = chunk.total();
  into->insert(into->end(), chunk.values().begin(), chunk.values().end());
  return {};
}

int fail(const Status& s) {
  std::fprintf(stderr, "vpremesh: error: %s\n", s.to_string().c_str());
  return exit_code_for(s);
}

Status write_bytes(const std::string& path, const void* data, size_t size) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) return not_found(path + ": cannot open for writing");
  f.write(static_cast<const char*>(data), std::streamsize(size));
  if (!f) return internal_error(path + ": write failed");
  return {};
}

double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

// A result to `path`: the server's Draco file as it is (its quantization,
// its saliency attribute), or decoded and written with its field.
Status write_result(const std::string& path, const std::vector<uint8_t>& result, uint64_t total,
                    const std::vector<float>& saliency, const std::string& server) {
  if (total == 0 || result.size() != total)
    return internal_error("the server sent " + std::to_string(result.size()) + " of " + std::to_string(total) +
                          " bytes of " + path);
  VPR_ASSIGN_OR_RETURN(const MeshFormat format, format_from_path(path));
  if (format == MeshFormat::kDraco) return write_bytes(path, result.data(), result.size());
  auto mesh = parse_mesh(result.data(), result.size(), MeshFormat::kDraco);
  if (!mesh.ok()) return Status(mesh.status().code(), "the result from " + server + ": " + mesh.status().message());
  const bool field = !saliency.empty() && saliency.size() == mesh->vertex_count();
  return write_mesh(path, *mesh, field ? saliency.data() : nullptr);
}

}  // namespace

Status JobOutcome::add(const v1::JobEvent& e) {
  if (job_id.empty()) job_id = e.job_id();
  switch (e.event_case()) {
    case v1::JobEvent::kQueued:
      break;
    case v1::JobEvent::kStarted:
      worker = e.started().worker();
      device = e.started().device();
      queue_ms = e.started().queue_ms();
      break;
    case v1::JobEvent::kStage:
      stages.push_back({e.stage().name(), e.stage().ms(), e.stage().device(), e.stage().note(),
                        e.stage().front_half() ? kFrontHalf : int(e.stage().level())});
      break;
    case v1::JobEvent::kResult:
      if (e.result().level() != 0) {
        LevelPayload& l = levels[e.result().level()];
        return append_chunk("result", e.result(), e.result().data(), &l.result, &l.result_total);
      }
      return append_chunk("result", e.result(), e.result().data(), &result, &result_total);
    case v1::JobEvent::kSaliency:
      if (e.saliency().level() != 0) {
        LevelPayload& l = levels[e.saliency().level()];
        return append_floats("saliency", e.saliency(), &l.saliency, &l.saliency_total);
      }
      return append_floats("saliency", e.saliency(), &saliency, &saliency_total);
    case v1::JobEvent::kInputSaliency:
      return append_floats("input_saliency", e.input_saliency(), &input_saliency, &input_saliency_total);
    case v1::JobEvent::kSaliencyPoints:
    case v1::JobEvent::kDebugImage:
      break;  // not requested by the CLI
    case v1::JobEvent::kCompleted:
      end = End::kCompleted;
      summary = e.completed();
      if (queue_ms < 0) queue_ms = summary.queue_ms();
      break;
    case v1::JobEvent::kFailed:
      end = End::kFailed;
      failure = e.failed();
      break;
    case v1::JobEvent::kCancelled:
      end = End::kCancelled;
      failure = e.cancelled();
      break;
    case v1::JobEvent::EVENT_NOT_SET:
      break;  // a newer server's event: ignore it
  }
  return {};
}

int finish_job(const JobOutcome& o, const JobOutputs& out, const std::string& server) {
  switch (o.end) {
    case JobOutcome::End::kFailed:
      return report_job_failure(o.failure, false);
    case JobOutcome::End::kCancelled:
      return report_job_failure(o.failure, true);
    case JobOutcome::End::kNone:
      std::fprintf(stderr, "vpremesh: INTERNAL: the event stream from %s ended before the job did\n", server.c_str());
      return kExitInternal;
    case JobOutcome::End::kCompleted:
      break;
  }

  const auto start = std::chrono::steady_clock::now();
  const bool need_mesh = !out.output.empty() || (!out.field_out.empty() && !out.input_mesh);
  if (need_mesh && o.result_total == 0)
    return fail(not_found("job " + o.job_id + " was submitted without return_mesh: there is no result to write"));
  if (need_mesh && o.result.size() != o.result_total)
    return fail(internal_error("the server sent " + std::to_string(o.result.size()) + " of " +
                               std::to_string(o.result_total) + " bytes of the result mesh"));
  // A chain: every level to its own file (level 0's payload is o.result).
  const bool chain = o.summary.levels_size() > 1;
  if (chain && !out.output.empty()) {
    for (const auto& level : o.summary.levels()) {
      const std::string path = level_path(out.output, level.level());
      Status s;
      if (level.level() == 0) {
        s = write_result(path, o.result, o.result_total, o.saliency, server);
      } else if (const auto it = o.levels.find(level.level()); it != o.levels.end()) {
        s = write_result(path, it->second.result, it->second.result_total, it->second.saliency, server);
      } else {
        s = internal_error("the server sent no mesh for level " + std::to_string(level.level()));
      }
      if (!s.ok()) return fail(s);
    }
  } else if (!out.output.empty()) {
    if (Status s = write_result(out.output, o.result, o.result_total, o.saliency, server); !s.ok()) return fail(s);
  }
  if (!out.field_out.empty() && out.input_mesh) {
    // The input as uploaded, colored by its field: `vpremesh local --field-out`.
    const Mesh& input = *out.input_mesh;
    if (o.input_saliency.size() != input.vertex_count() || o.input_saliency.size() != o.input_saliency_total)
      return fail(internal_error("the server sent " + std::to_string(o.input_saliency.size()) +
                                 " input saliency values for an input of " + std::to_string(input.vertex_count()) +
                                 " vertices"));
    if (Status s = write_mesh(out.field_out, input, o.input_saliency.data()); !s.ok()) return fail(s);
  } else if (!out.field_out.empty()) {
    // No input here (watch): the result colored by its field.
    auto mesh = parse_mesh(o.result.data(), o.result.size(), MeshFormat::kDraco);
    if (!mesh.ok())
      return fail(Status(mesh.status().code(), "the result from " + server + ": " + mesh.status().message()));
    if (o.saliency.empty() || o.saliency.size() != mesh->vertex_count())
      return fail(internal_error("the server sent " + std::to_string(o.saliency.size()) +
                                 " saliency values for a result of " + std::to_string(mesh->vertex_count()) +
                                 " vertices"));
    mesh->colors.clear();  // the field shows as the saliency ramp (-o was written before)
    if (Status s = write_mesh(out.field_out, *mesh, o.saliency.data()); !s.ok()) return fail(s);
  }
  PipelineResult result;
  result.stages = o.stages;
  result.renderer = o.summary.renderer();
  result.saliency_points = o.summary.saliency_points();
  result.ignored_vertices = o.summary.ignored_vertices();
  result.dropped_parts = o.summary.dropped_parts();
  result.cvt.parts_below_minimum = o.summary.parts_below_minimum();
  RunSummary summary;
  summary.input_vertices = o.summary.input_vertices();
  summary.input_faces = o.summary.input_faces();
  summary.output_vertices = o.summary.output_vertices();
  summary.output_faces = o.summary.output_faces();
  summary.target_vertices = out.target_vertices;
  summary.read_ms = out.read_ms > 0 ? out.read_ms : 0;
  summary.upload_ms = out.upload_ms;
  summary.queue_ms = o.queue_ms;
  summary.write_ms = ms_since(start);
  if (out.json) {
    nlohmann::json j = report_json(result, summary);
    // The service does not report AWLOP and meshing statistics: leave them out, not zero.
    j.erase("awlop");
    j.erase("meshing");
    j.erase("back_half");
    j.erase("cvt");
    j["job_id"] = o.job_id;
    j["server"] = server;
    j["worker"] = o.worker;
    j["device"] = o.device;
    j["queue_ms"] = o.summary.queue_ms();
    j["run_ms"] = o.summary.run_ms();
    j["server_total_ms"] = o.summary.total_ms();
    j["result_bytes"] = o.summary.result_bytes();
    if (chain) {
      nlohmann::json levels = nlohmann::json::array();
      for (const auto& l : o.summary.levels()) {
        nlohmann::json level = {{"level", l.level()},
                                {"target_vertices", l.target_vertices()},
                                {"output", {{"vertices", l.output_vertices()}, {"faces", l.output_faces()}}},
                                {"result_bytes", l.result_bytes()},
                                {"ms", l.ms()}};
        if (!out.output.empty()) level["output_file"] = level_path(out.output, l.level());
        if (l.min_ssim() > 0)
          level["visual_target"] = {{"min_ssim", l.min_ssim()}, {"ssim", l.ssim()}, {"tries", l.tries()}};
        levels.push_back(level);
      }
      j["levels"] = levels;
    }
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("job %s on %s (%s)\n", o.job_id.c_str(), o.worker.c_str(), o.device.c_str());
    std::printf("%s", format_stage_table(result, summary).c_str());
    for (const auto& l : o.summary.levels()) {
      std::printf("level %u: %u vertices, %u faces (target %u", l.level(), l.output_vertices(), l.output_faces(),
                  l.target_vertices());
      if (l.min_ssim() > 0)
        std::printf(", SSIM %.4f for a bound of %.4f after %u tries", l.ssim(), l.min_ssim(), l.tries());
      std::printf(") after %.0f ms", l.ms());
      if (chain && !out.output.empty()) std::printf(" -> %s", level_path(out.output, l.level()).c_str());
      std::printf("\n");
    }
  }
  return kExitOk;
}

void set_deadline(grpc::ClientContext& context, double seconds) {
  if (seconds <= 0) return;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::microseconds(int64_t(seconds * 1e6)));
}

}  // namespace vpr::cli
