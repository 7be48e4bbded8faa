#include "server/server_options.h"

#include "server/process_main.h"
#include "server/redis_client.h"

#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <memory>

namespace vpr::service {

void add_isolation_options(CLI::App& app, JobIsolationOptions* o) {
  app.add_option("--isolation", o->mode,
                 "Where jobs run: process (each worker's jobs in a supervised child process, so a crash costs "
                 "one job) or thread (in this process: no isolation, for debugging)")
      ->check(CLI::IsMember({"process", "thread"}))
      ->capture_default_str();
  app.add_option("--job-memory-mib", o->memory_mib,
                 "MiB one job process may hold (0: 3/4 of this machine's or container's memory over the workers); "
                 "past it the "
                 "job fails RESOURCE_EXHAUSTED")
      ->check(CLI::Range(size_t(0), size_t(1) << 30))
      ->capture_default_str();
  app.add_option("--job-cpu-seconds", o->cpu_seconds,
                 "CPU seconds one job may use, all its threads together (0: unlimited); past it the job fails "
                 "RESOURCE_EXHAUSTED")
      ->check(CLI::Range(0.0, 1e7))
      ->capture_default_str();
}

namespace {

// The memory this process may use: the machine's, or less where a cgroup
// (a container's memory limit) says so.
size_t usable_memory() {
  size_t bytes = size_t(sysconf(_SC_PHYS_PAGES)) * size_t(sysconf(_SC_PAGESIZE));
  for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    std::ifstream f(path);
    unsigned long long limit = 0;
    if (f >> limit && limit > 0) bytes = std::min<size_t>(bytes, size_t(limit));  // "max" reads as no number
  }
  return bytes;
}

}  // namespace

int default_workers(int gpus, int cores) {
  if (gpus <= 0) return 1;
  return gpus * std::clamp(cores / 4, 1, 4);
}

JobProcessOptions job_process_options(const JobIsolationOptions& o, int workers) {
  JobProcessOptions p;
  if (o.mode == "process") p.exe = "/proc/self/exe";  // this very binary, even if replaced on disk since
  const size_t machine = usable_memory();
  p.memory_bytes = o.memory_mib > 0 ? o.memory_mib << 20 : machine / 4 * 3 / size_t(std::max(workers, 1));
  p.cpu_seconds = o.cpu_seconds;
  return p;
}

void add_server_options(CLI::App& app, ServerOptions* o) {
  app.add_option("--listen", o->listen, "gRPC address HOST:PORT (port 0 picks a free one)")->capture_default_str();
  app.add_option("--queue", o->queue,
                 "Job queue: embedded (in this process) or redis://[:PASSWORD@]HOST:PORT[/DB] (Redis Streams, "
                 "shared by server replicas and vpremesh-worker processes)")
      ->capture_default_str();
  app.add_option("--workers", o->workers,
                 "Worker threads running the pipeline in this process; default: per GPU a quarter of the cores, "
                 "1 to 4 (a GPU job keeps about 4 cores busy), or 1 on CPU (the pipeline itself uses every core "
                 "through TBB); 0 with --queue redis://, where vpremesh-worker runs the jobs")
      ->check(CLI::Range(0, 256));
  app.add_option("--upload-ttl", o->upload_ttl_s,
                 "With --queue redis://: seconds an upload waits in Redis for a worker before the job fails")
      ->check(CLI::Range(1.0, 30 * 86400.0))
      ->capture_default_str();
  app.add_option("--device", o->device, "Where stages run: auto (GPU when present), cpu or cuda")
      ->check(CLI::IsMember({"auto", "cpu", "cuda"}))
      ->capture_default_str();
  app.add_option("--renderer", o->renderer, "Snapshot renderer: auto, egl or osmesa")
      ->check(CLI::IsMember({"auto", "egl", "osmesa"}))
      ->capture_default_str();
  app.add_option("--metrics-listen", o->metrics_listen, "Serve Prometheus metrics at http://HOST:PORT/metrics");
  app.add_option("--result-ttl", o->result_ttl_s, "Seconds finished jobs stay available to Watch and GetJob")
      ->check(CLI::Range(0.0, 7 * 86400.0))
      ->capture_default_str();
  app.add_option("--drain-grace", o->drain_grace_s, "Seconds SIGTERM waits for running jobs before cancelling them")
      ->check(CLI::Range(0.0, 86400.0))
      ->capture_default_str();
  app.add_option("--gpu-memory-per-job", o->gpu_job_mib,
                 "MiB of GPU memory one job may hold (0: the GPU's memory / the workers sharing it); "
                 "a stage that would need more reruns on the CPU")
      ->check(CLI::Range(size_t(0), size_t(1) << 30))
      ->capture_default_str();
  app.add_option("--log-level", o->log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();

  // Limits: MiB on the command line, bytes inside. CLI11 writes the parsed value through the
  // reference it holds, at parse time: the lambda owns `upload_mib` so it lives as long as `app`.
  auto upload_mib = std::make_shared<uint64_t>(o->limits.max_upload_bytes >> 20);
  app.add_option("--max-upload-mib", *upload_mib, "Largest Draco upload in MiB")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 20))
      ->capture_default_str()
      ->each([o, upload_mib](const std::string& mib) { o->limits.max_upload_bytes = std::stoull(mib) << 20; });
  app.add_option("--max-vertices", o->limits.max_vertices, "Most input vertices per job")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-faces", o->limits.max_faces, "Most input faces per job")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-target-vertices", o->limits.max_target_vertices, "Largest target_vertices accepted")
      ->check(CLI::Range(kMinTargetVertices, kMaxTargetVertices))
      ->capture_default_str();
  app.add_option("--max-queue", o->limits.max_queue, "Most jobs waiting; more are RESOURCE_EXHAUSTED")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-jobs-per-client", o->limits.max_jobs_per_client,
                 "Most unfinished jobs per tenant (with --auth-tokens; a tenant's max_jobs= overrides it) or per "
                 "source address, counted across connections and replicas")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  add_isolation_options(app, &o->isolation);

  app.add_option("--auth-tokens", o->auth_tokens,
                 "Tenants and their tokens: lines 'TENANT SHA256_HEX_OF_TOKEN [max_jobs=N]'; RemeshService calls "
                 "then need 'authorization: Bearer TOKEN'. Re-read on SIGHUP")
      ->check(CLI::ExistingFile);
  app.add_flag("--insecure", o->insecure,
               "Listen on a non-loopback address without --auth-tokens: anyone who reaches the port may run jobs "
               "and read any result");
  app.add_option("--tls-cert", o->tls_cert, "PEM certificate chain: serve gRPC over TLS (with --tls-key)")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-key", o->tls_key, "PEM private key of --tls-cert")->check(CLI::ExistingFile);
  app.add_option("--health-listen", o->health_listen,
                 "Also serve grpc.health.v1 alone, in plaintext and without tokens, at HOST:PORT (for probes that "
                 "cannot speak TLS, such as Kubernetes' gRPC probes)");
  app.add_option("--tls-client-ca", o->tls_client_ca,
                 "PEM CA certificates: require a client certificate signed by one of them (mutual TLS)")
      ->check(CLI::ExistingFile);
}

namespace {

// HOST:PORT with PORT in [0, 65535] (gRPC would quietly wrap a larger one).
Status check_address(const std::string& flag, const std::string& address) {
  const size_t colon = address.rfind(':');
  const std::string port = colon == std::string::npos ? "" : address.substr(colon + 1);
  const bool digits = !port.empty() && port.size() <= 5 && port.find_first_not_of("0123456789") == std::string::npos;
  if (colon == 0 || !digits || std::stoi(port) > 65535)
    return invalid_argument(flag + " '" + address + "' must be HOST:PORT with PORT in [0, 65535]");
  return Status::Ok();
}

}  // namespace

bool uses_redis(const ServerOptions& o) {
  return o.queue != "embedded";
}

bool is_loopback_host(const std::string& host) {
  return host == "localhost" || host == "[::1]" || host == "::1" || host.rfind("127.", 0) == 0;
}

Status check_server_options(const ServerOptions& o) {
  VPR_RETURN_IF_ERROR(check_address("--listen", o.listen));
  if (o.auth_tokens.empty() && !o.insecure && !is_loopback_host(host_of(o.listen)))
    return invalid_argument("refusing to listen on " + o.listen +
                            " without --auth-tokens: anyone who reaches it could run jobs and read every result; "
                            "give --auth-tokens FILE (docs/security.md), listen on 127.0.0.1, or pass --insecure");
  if (o.tls_cert.empty() != o.tls_key.empty()) return invalid_argument("--tls-cert and --tls-key go together");
  if (!o.tls_client_ca.empty() && o.tls_cert.empty())
    return invalid_argument("--tls-client-ca needs --tls-cert and --tls-key (mutual TLS is TLS first)");
  if (uses_redis(o)) {
    auto endpoint = parse_redis_url(o.queue);
    if (!endpoint.ok()) return invalid_argument("--queue: " + endpoint.status().message());
  }
  if (!o.metrics_listen.empty()) VPR_RETURN_IF_ERROR(check_address("--metrics-listen", o.metrics_listen));
  if (!o.health_listen.empty()) VPR_RETURN_IF_ERROR(check_address("--health-listen", o.health_listen));
  if (o.limits.max_target_vertices < kMinTargetVertices || o.limits.max_target_vertices > kMaxTargetVertices)
    return invalid_argument("--max-target-vertices must be in [" + std::to_string(kMinTargetVertices) + ", " +
                            std::to_string(kMaxTargetVertices) + "]");
  return Status::Ok();
}

}  // namespace vpr::service
