// vpremesh-server's command line.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "server/limits.h"
#include "server/worker_pool.h"

namespace vpr::service {

// How jobs are kept apart (server/job_process.h); vpremesh-server and
// vpremesh-worker take the same flags.
struct JobIsolationOptions {
  std::string mode = "process";  // --isolation process|thread
  size_t memory_mib = 0;         // --job-memory-mib; 0: 3/4 of the machine's memory over the workers
  double cpu_seconds = 7200;     // --job-cpu-seconds per job, all threads together; 0: unlimited
};

void add_isolation_options(CLI::App& app, JobIsolationOptions* options);

// Workers (jobs at once) on `gpus` GPUs and `cores` cores when --workers or
// --concurrency is not given: on the CPU (gpus 0) one, whose stages use every
// core; else per GPU a quarter of the cores, between 1 and 4. A GPU job's
// host steps keep about 4 cores busy (0.7 processor seconds in a horse job of
// 0.17 s on 16 cores), so one job at a time leaves most of a GPU host idle:
// on an H200 with 16 cores, 4 at once gave 2.2-2.5 times the jobs per second
// of one at a time, and a lone job ran as fast (docs/scaling.md).
int default_workers(int gpus, int cores);

// The WorkerPool settings for `workers` workers on this machine: the binary
// to start job processes from (this one) and their limits; exe empty with
// --isolation thread.
JobProcessOptions job_process_options(const JobIsolationOptions& options, int workers);

struct ServerOptions {
  std::string listen = "0.0.0.0:50051";  // --listen; PORT 0 picks a free port (printed at startup)
  std::string queue = "embedded";        // --queue embedded | redis://[:PASSWORD@]HOST:PORT[/DB]
  int workers = -1;                      // --workers; -1: default_workers, or 0 with a Redis queue
  double upload_ttl_s = 86400;           // --upload-ttl: Redis queue only, how long an upload waits
  std::string device = "auto";           // --device auto|cpu|cuda
  std::string renderer = "auto";         // --renderer auto|egl|osmesa
  std::string metrics_listen;            // --metrics-listen HOST:PORT; empty: no metrics endpoint
  double result_ttl_s = 600;             // --result-ttl: how long finished jobs stay watchable
  double drain_grace_s = 30;             // --drain-grace: SIGTERM waits this long for running jobs
  size_t gpu_job_mib = 0;                // --gpu-memory-per-job: device memory budget of one job (0: GPU / workers on it)
  std::string log_level = "info";        // --log-level
  // Who may connect (docs/security.md).
  std::string auth_tokens;    // --auth-tokens FILE: tenants and their token hashes; empty: no authentication
  bool insecure = false;      // --insecure: allow a non-loopback --listen without --auth-tokens
  std::string tls_cert;       // --tls-cert FILE (PEM): TLS on the gRPC port, with --tls-key
  std::string tls_key;        // --tls-key FILE (PEM)
  std::string tls_client_ca;  // --tls-client-ca FILE (PEM): also require client certificates signed by it
  std::string health_listen;  // --health-listen HOST:PORT: grpc.health.v1 alone, plaintext (probes); empty: none
  ServerLimits limits;
  JobIsolationOptions isolation;  // --isolation, --job-memory-mib, --job-cpu-seconds
};

// Registers every flag on `app`, writing into *options. The limit flags take
// MiB and counts; their defaults are ServerLimits'.
void add_server_options(CLI::App& app, ServerOptions* options);

bool uses_redis(const ServerOptions& options);

// 127.0.0.0/8, ::1 or localhost: only this machine can connect.
bool is_loopback_host(const std::string& host);

// Cross-field checks after parsing (e.g. --max-target-vertices within the
// pipeline's range); INVALID_ARGUMENT names the flag.
Status check_server_options(const ServerOptions& options);

}  // namespace vpr::service
