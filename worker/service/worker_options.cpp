#include "service/worker_options.h"

#include <set>

#include "server/redis_client.h"

namespace vpr::service {

void add_worker_options(CLI::App& app, WorkerOptions* o) {
  app.add_option("--queue", o->queue, "The job queue: redis://[:PASSWORD@]HOST:PORT[/DB]")->required();
  app.add_option("--device", o->device, "Where stages run: auto (GPU when present), cpu or cuda")
      ->check(CLI::IsMember({"auto", "cpu", "cuda"}))
      ->capture_default_str();
  auto* gpus = app.add_option("--gpus", o->gpus,
                              "CUDA devices to use, e.g. 0,1 (each runs the default jobs per GPU; default: all)");
  app.add_option("--concurrency", o->concurrency,
                 "Jobs run at once (worker threads); default: per GPU a quarter of the cores, 1 to 4 (a GPU job "
                 "keeps about 4 cores busy), or 1 on CPU, where each stage already uses every core")
      ->check(CLI::Range(1, 256))
      ->excludes(gpus);
  app.add_option("--renderer", o->renderer, "Snapshot renderer: auto, egl or osmesa")
      ->check(CLI::IsMember({"auto", "egl", "osmesa"}))
      ->capture_default_str();
  app.add_option("--visibility-timeout", o->visibility_timeout_s,
                 "Seconds without a heartbeat after which another worker takes a running job over")
      ->check(CLI::Range(0.5, 86400.0))
      ->capture_default_str();
  app.add_option("--heartbeat", o->heartbeat_s, "Seconds between keep-alives of a running job")
      ->check(CLI::Range(0.05, 3600.0))
      ->capture_default_str();
  app.add_option("--max-deliveries", o->max_deliveries,
                 "Runs of one job before it fails to the dead-letter stream vpremesh:dead")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  app.add_option("--max-result-mib", o->max_result_mib, "Largest results of one job (mesh, fields, images) in MiB")
      ->check(CLI::Range(uint64_t(1), uint64_t(4096)))
      ->capture_default_str();
  app.add_option("--drain-grace", o->drain_grace_s,
                 "Seconds SIGTERM waits for running jobs; an unfinished one is redelivered to another worker")
      ->check(CLI::Range(0.0, 86400.0))
      ->capture_default_str();
  app.add_option("--metrics-listen", o->metrics_listen, "Serve Prometheus metrics at http://HOST:PORT/metrics");
  app.add_option("--gpu-memory-per-job", o->gpu_job_mib,
                 "MiB of GPU memory one job may hold (0: the GPU's memory / the workers sharing it)")
      ->check(CLI::Range(size_t(0), size_t(1) << 30))
      ->capture_default_str();
  app.add_option("--max-vertices", o->limits.max_vertices, "Most input vertices a job's mesh may have")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-faces", o->limits.max_faces, "Most input faces a job's mesh may have")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--log-level", o->log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();  add_isolation_options(app, &o->isolation);
}

StatusOr<std::vector<int>> parse_gpu_list(const std::string& list) {
  std::vector<int> ids;
  std::set<int> seen;
  size_t start = 0;
  while (start <= list.size()) {
    const size_t comma = std::min(list.find(',', start), list.size());
    const std::string item = list.substr(start, comma - start);
    if (item.empty() || item.size() > 3 || item.find_first_not_of("0123456789") != std::string::npos)
      return invalid_argument("--gpus '" + list + "': '" + item + "' is not a device index (e.g. --gpus 0,1)");
    const int id = std::stoi(item);
    if (!seen.insert(id).second) return invalid_argument("--gpus '" + list + "': device " + item + " appears twice");
    ids.push_back(id);
    start = comma + 1;
  }
  return ids;
}

Status check_worker_options(const WorkerOptions& o) {
  if (auto e = parse_redis_url(o.queue); !e.ok()) return invalid_argument("--queue: " + e.status().message());
  if (!o.gpus.empty()) {
    VPR_RETURN_IF_ERROR(parse_gpu_list(o.gpus).status());
    if (o.device == "cpu") return invalid_argument("--gpus cannot be combined with --device cpu");
  }
  // Two missed heartbeats must not lose a job to another worker.
  if (o.heartbeat_s * 2 > o.visibility_timeout_s)
    return invalid_argument("--heartbeat (" + std::to_string(o.heartbeat_s) +
                            " s) must be at most half of --visibility-timeout (" +
                            std::to_string(o.visibility_timeout_s) + " s)");
  return Status::Ok();
}

}  // namespace vpr::service
