#include "stage_table.h"

#include <cstdio>

namespace vpr::cli {
namespace {

std::string row(const std::string& name, const std::string& device, double ms) {
  char line[160];
  std::snprintf(line, sizeof line, "%-16s %-52.52s %10.1f\n", name.c_str(), device.c_str(), ms);
  return line;
}

double deviation_percent(const RunSummary& s) {
  return s.target_vertices ? 100.0 * (double(s.output_vertices) - s.target_vertices) / s.target_vertices : 0.0;
}

}  // namespace

std::string format_stage_table(const PipelineResult& result, const RunSummary& s) {
  std::string out;
  char header[160];
  std::snprintf(header, sizeof header, "%-16s %-52s %10s\n", "stage", "device", "ms");
  out += header;
  out += row("read", "cpu", s.read_ms);
  double total = s.read_ms + s.write_ms;
  if (s.upload_ms >= 0) {
    out += row("upload", "network", s.upload_ms);
    total += s.upload_ms;
  }
  if (s.queue_ms >= 0) {
    out += row("queue", "server", s.queue_ms);
    total += s.queue_ms;
  }
  for (const StageTiming& t : result.stages) {
    out += row(t.name, t.device, t.ms);
    if (!t.note.empty()) out += "                 note: " + t.note + "\n";
    total += t.ms;
  }
  out += row("write", "cpu", s.write_ms);
  out += row("total", "", total);
  // `watch` follows a job it did not submit: it knows no target.
  char target[64] = "";
  if (s.target_vertices > 0)
    std::snprintf(target, sizeof target, " (target %u, %+.2f%%)", s.target_vertices, deviation_percent(s));
  char footer[320];
  std::snprintf(footer, sizeof footer,
                "input %zu vertices, %zu faces -> output %zu vertices, %zu faces%s; %zu saliency points\n",
                s.input_vertices, s.input_faces, s.output_vertices, s.output_faces, target, result.saliency_points);
  out += footer;
  if (result.ignored_vertices > 0)
    out += std::to_string(result.ignored_vertices) + " input vertices no face uses were ignored\n";
  if (result.dropped_parts > 0)
    out += std::to_string(result.dropped_parts) + " parts smaller than --drop-parts-smaller-than were left out\n";
  if (result.cvt.parts_below_minimum > 0)
    out += std::to_string(result.cvt.parts_below_minimum) +
           " parts got fewer vertices than a part needs to stay closed: the target is too small for every part\n";
  return out;
}

nlohmann::json report_json(const PipelineResult& result, const RunSummary& s) {
  nlohmann::json stages = nlohmann::json::array();
  stages.push_back({{"name", "read"}, {"ms", s.read_ms}, {"device", "cpu"}});
  double total = s.read_ms + s.write_ms;
  if (s.upload_ms >= 0) {
    stages.push_back({{"name", "upload"}, {"ms", s.upload_ms}, {"device", "network"}});
    total += s.upload_ms;
  }
  if (s.queue_ms >= 0) {
    stages.push_back({{"name", "queue"}, {"ms", s.queue_ms}, {"device", "server"}});
    total += s.queue_ms;
  }
  for (const StageTiming& t : result.stages) {
    nlohmann::json j = {{"name", t.name}, {"ms", t.ms}, {"device", t.device}};
    if (!t.note.empty()) j["note"] = t.note;
    stages.push_back(j);
    total += t.ms;
  }
  stages.push_back({{"name", "write"}, {"ms", s.write_ms}, {"device", "cpu"}});
  return {
      {"input", {{"vertices", s.input_vertices}, {"faces", s.input_faces}}},
      {"output", {{"vertices", s.output_vertices}, {"faces", s.output_faces}}},
      {"target_vertices", s.target_vertices},
      {"target_deviation_percent", deviation_percent(s)},
      {"renderer", result.renderer},
      {"saliency_points", result.saliency_points},
      {"ignored_vertices", result.ignored_vertices},
      {"dropped_parts", result.dropped_parts},
      {"stages", stages},
      {"total_ms", total},
      {"back_half", result.back_half},
      {"cvt",
       {{"sweeps", result.cvt.sweeps},
        {"converged", result.cvt.converged},
        {"energy", result.cvt.energy},
        {"parts", result.cvt.parts},
        {"parts_below_minimum", result.cvt.parts_below_minimum}}},
      {"awlop",
       {{"h", result.awlop.h},
        {"iterations", result.awlop.iterations},
        {"nn_cv_before", result.awlop.nn_cv_before},
        {"nn_cv_after", result.awlop.nn_cv_after}}},
      {"meshing",
       {{"points_in", result.meshing.points_in},
        {"points_dropped", result.meshing.points_dropped},
        {"holes_filled", result.meshing.holes_filled},
        {"holes_left", result.meshing.holes_left},
        {"bridges_removed", result.meshing.bridges_removed},
        {"vertices_split", result.meshing.vertices_split},
        {"slabs", result.meshing.slabs},
        {"seam_defects", result.meshing.seam_defects}}},
  };
}

}  // namespace vpr::cli
