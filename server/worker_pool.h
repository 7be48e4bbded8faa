// Worker threads: each owns a renderer (a GL context, created once) and, with
// a GPU, one CUDA device (worker index modulo the GPU count); each claims a
// job, runs the pipeline and publishes the job's events to the queue.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/thread_share.h"
#include "pipeline/pipeline.h"
#include "server/host_job_count.h"
#include "server/job_queue.h"
#include "server/limits.h"
#include "server/service_metrics.h"

namespace vpr::service {

// Values per chunk of a FloatChunk event: 1 MiB of floats.
inline constexpr size_t kFloatsPerChunk = kMaxChunkBytes / sizeof(float);

// How a worker isolates its jobs (server/job_process.h).
struct JobProcessOptions {
  // The binary started with --job-process to run jobs (the server's or the
  // worker's own: /proc/self/exe). Empty: jobs run in the worker thread
  // itself, in this process (tests of the pool; --isolation thread).
  std::string exe;
  // Memory of one job process (--job-memory-mib; 0: unlimited). The largest
  // job the default limits accept (--max-vertices 10M) peaks well below it.
  size_t memory_bytes = size_t(32) << 30;
  // CPU time of one job, all threads together (--job-cpu-seconds; 0: unlimited).
  double cpu_seconds = 3600;
  // The server's count of busy job processes (HostJobCount::fd), handed to
  // each job process as descriptor kHostJobsFd; -1: none. Set by WorkerPool.
  int host_jobs_fd = -1;
};

// What one worker runs a job with.
struct WorkerContext {
  std::string name;            // "host:pid/worker-0"
  std::string device = "cpu";  // "cpu" or "cuda:0 <name>", for `started` events
  RendererKind renderer_kind = RendererKind::kAuto;
  Renderer* renderer = nullptr;
  DevicePolicy device_policy = DevicePolicy::kCpu;
  int cuda_device = 0;
  // Device memory one job may hold (bytes; 0 = no limit). Several workers share
  // a GPU, each job on its own stream; the budget keeps them inside its memory,
  // and a stage that would pass it reruns on the CPU.
  size_t gpu_job_bytes = 0;
  ServerLimits limits;
  ServiceMetrics* metrics = nullptr;  // may be null
  std::string crash_on_label;         // fault injection for tests (WorkerPoolOptions)
  size_t memory_limit_bytes = 0;      // the job process's memory limit, named when a job runs out
  // Called as each step of a job starts: "decode", the pipeline's stages,
  // "encode", "results" (a job process reports them to its supervisor).
  std::function<void(const std::string&)> on_step;
};

// Runs one claimed job to its end: started, then decode, the pipeline with a
// `stage` event as each stage ends (PipelineOptions::on_stage), the requested
// payloads in chunks, and completed / failed / cancelled. Never throws; every
// failure becomes the job's `failed` event.
void run_job(JobQueue& queue, ClaimedJob job, const WorkerContext& ctx);

// Makes ctx's CUDA device current in this process (when ctx names one).
void init_cuda(const WorkerContext& ctx);
// The CUDA device ctx's renderer should draw on (create_renderer), -1 for none.
int renderer_gpu(const WorkerContext& ctx);

struct WorkerPoolOptions {
  int workers = 1;
  DevicePolicy device = DevicePolicy::kAuto;
  RendererKind renderer = RendererKind::kAuto;
  int cuda_devices = 0;  // GPUs to spread workers over (0: none)
  // Which CUDA devices, by index (vpremesh-worker --gpus); empty: 0 .. cuda_devices-1.
  // Worker i runs on gpu_ids[i % size].
  std::vector<int> gpu_ids;
  size_t gpu_job_bytes = 0;  // per-job device memory budget (0: device memory / workers sharing it)
  ServerLimits limits;
  // Test-only fault injection (vpremesh-worker, env VPREMESH_FAULT_CRASH_ON_LABEL):
  // abort() right after publishing `started` for a job with this label, as a
  // worker that crashes on some input would.
  std::string crash_on_label;
  JobProcessOptions process;  // exe empty: jobs run in the worker threads
};

class WorkerPool {
 public:
  WorkerPool(JobQueue& queue, WorkerPoolOptions options, ServiceMetrics* metrics);
  ~WorkerPool();

  // Starts the threads and waits until each has created its renderer (or
  // failed to). Returns how many are live; *why says why others are not.
  size_t start(std::string* why);
  size_t live() const { return live_; }
  size_t busy() const { return busy_; }
  // Waits until no worker runs a job, up to `timeout`; true when idle.
  bool wait_idle(std::chrono::milliseconds timeout);
  // Asks every running job to stop at its next stage boundary.
  void cancel_running(const Status& reason);
  // Joins the threads (call JobQueue::close first).
  void join();

 private:
  void worker_main(int index);
  // Jobs in threads: TBB's threads for the busy_ jobs, mu_ held.
  void share_threads();
  // The worker's context, without its renderer and CUDA set-up (the job
  // process, or worker_main itself without one, does those).
  WorkerContext make_context(int index);

  JobQueue& queue_;
  WorkerPoolOptions options_;
  ServiceMetrics* metrics_;
  std::vector<std::thread> threads_;
  std::atomic<size_t> live_{0}, busy_{0};
  std::mutex mu_;
  std::condition_variable changed_;
  size_t ready_ = 0;
  std::vector<std::string> failures_;
  std::vector<std::string> running_;  // job id per worker ("" when idle)
  std::unique_ptr<HostJobCount> host_jobs_;  // busy_, for the job processes (null: jobs in threads)
  // Jobs in threads: TBB's threads while busy_ jobs run (core/thread_share.h).
  std::optional<ThreadCap> thread_cap_;
};

}  // namespace vpr::service
