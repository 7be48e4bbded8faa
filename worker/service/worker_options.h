// vpremesh-worker's command line.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "server/limits.h"
#include "server/server_options.h"

namespace vpr::service {

struct WorkerOptions {
  std::string queue;               // --queue redis://[:PASSWORD@]HOST:PORT[/DB] (required)
  std::string device = "auto";     // --device auto|cpu|cuda
  std::string gpus;                // --gpus 0,1: CUDA devices to use, each with default_workers' share (default: all)
  int concurrency = 0;             // --concurrency N: worker threads (0: default_workers, server_options.h)
  std::string renderer = "auto";   // --renderer auto|egl|osmesa
  double visibility_timeout_s = 60;  // --visibility-timeout: silent this long, a job is reclaimed
  double heartbeat_s = 10;           // --heartbeat: keep-alive period of a running job
  int max_deliveries = 3;            // --max-deliveries: then the dead-letter stream
  uint64_t max_result_mib = 256;     // --max-result-mib: payloads of one job
  double drain_grace_s = 600;        // --drain-grace: SIGTERM waits this long for running jobs
  std::string metrics_listen;        // --metrics-listen HOST:PORT
  size_t gpu_job_mib = 0;            // --gpu-memory-per-job
  std::string log_level = "info";    // --log-level
  ServerLimits limits;               // --max-vertices, --max-faces (decode limits)
  JobIsolationOptions isolation;     // --isolation, --job-memory-mib, --job-cpu-seconds
};

void add_worker_options(CLI::App& app, WorkerOptions* options);

// Cross-field checks; INVALID_ARGUMENT names the flag.
Status check_worker_options(const WorkerOptions& options);

// "0,2" -> {0, 2}; INVALID_ARGUMENT for anything else.
StatusOr<std::vector<int>> parse_gpu_list(const std::string& list);

}  // namespace vpr::service
