// vpremesh-worker: runs remeshing jobs from a Redis Streams queue
// (docs/scaling.md). Any number of these, on any number of GPU hosts, share
// the queue with any number of vpremesh-server replicas. Each process runs
// --concurrency worker threads (one per GPU by default), each with its own
// renderer and CUDA device.
//
// SIGTERM stops claiming, lets running jobs finish for --drain-grace seconds
// and exits 0. A job still running then is left pending: another worker
// reclaims it after the visibility timeout, so nothing is lost.
#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <tbb/task_arena.h>

#include <cstdio>
#include <cstdlib>

#include "server/job_process.h"
#include "server/metrics_http.h"
#include "server/process_main.h"
#include "server/redis_queue.h"
#include "server/service_metrics.h"
#include "server/worker_pool.h"
#include "service/worker_options.h"
#ifdef VPR_HAVE_CUDA
#include "gpu/cuda_device.h"
#endif

namespace vpr::service {
namespace {

int run(const WorkerOptions& o) {
  spdlog::set_level(spdlog::level::from_str(o.log_level));
  if (Status s = check_worker_options(o); !s.ok()) return fail(s.message(), 2);
  const RedisEndpoint endpoint = parse_redis_url(o.queue).value();

  const sigset_t signals = block_stop_signals();

  int gpus = 0;
  std::string no_gpu_why = "this build has no CUDA support";
#ifdef VPR_HAVE_CUDA
  if (o.device != "cpu") gpus = int(cuda_devices(&no_gpu_why).size());
#endif
  std::vector<int> gpu_ids;
  if (!o.gpus.empty()) {
    gpu_ids = parse_gpu_list(o.gpus).value();
    for (int id : gpu_ids)
      if (id >= gpus)
        return fail("--gpus " + o.gpus + ": device " + std::to_string(id) + " does not exist (" +
                        std::to_string(gpus) + " usable: " + (gpus ? "0.." + std::to_string(gpus - 1) : no_gpu_why) +
                        ")",
                    2);
  }
  if (o.device == "cuda" && gpus == 0) return fail("--device cuda but no CUDA device is usable: " + no_gpu_why, 2);
  const DevicePolicy policy = o.device == "cpu"    ? DevicePolicy::kCpu
                              : o.device == "cuda" ? DevicePolicy::kCuda
                                                   : DevicePolicy::kAuto;
  const int used_gpus = policy == DevicePolicy::kCpu ? 0 : gpu_ids.empty() ? gpus : int(gpu_ids.size());
  const int workers =
      o.concurrency > 0 ? o.concurrency : default_workers(used_gpus, tbb::this_task_arena::max_concurrency());
  auto renderer = parse_renderer_kind(o.renderer);
  if (!renderer.ok()) return fail(renderer.status().message(), 2);

  MetricsRegistry registry;
  ServiceMetrics metrics(registry);
  RedisQueueOptions ro;
  ro.endpoint = endpoint;
  ro.limits = o.limits;
  ro.visibility_timeout = seconds(o.visibility_timeout_s);
  ro.heartbeat = seconds(o.heartbeat_s);
  ro.max_deliveries = o.max_deliveries;
  ro.max_result_bytes = o.max_result_mib << 20;
  ro.on_state = [&metrics](const std::string&, v1::JobState state) {
    if (state == v1::JOB_STATE_SUCCEEDED || state == v1::JOB_STATE_FAILED || state == v1::JOB_STATE_CANCELLED)
      metrics.finished(state).inc();
  };
  RedisQueue queue(ro);
  if (Status h = queue.health(); !h.ok()) spdlog::warn("{}; workers will retry with backoff", h.message());

  WorkerPoolOptions wo;
  wo.workers = workers;
  wo.device = policy;
  wo.renderer = *renderer;
  wo.cuda_devices = used_gpus > 0 ? gpus : 0;
  wo.gpu_ids = gpu_ids;
  wo.gpu_job_bytes = o.gpu_job_mib << 20;
  wo.limits = o.limits;
  wo.process = job_process_options(o.isolation, workers);
  if (const char* label = std::getenv("VPREMESH_FAULT_CRASH_ON_LABEL"); label && *label) {
    wo.crash_on_label = label;
    spdlog::warn("fault injection: jobs labelled '{}' abort this process", label);
  }
  WorkerPool pool(queue, wo, &metrics);
  struct CloseOnExit {
    RedisQueue& queue;
    ~CloseOnExit() { queue.close(); }
  } close_on_exit{queue};
  std::string why;
  const size_t live = pool.start(&why);
  if (live == 0) return fail("no worker can run jobs: " + why, 1);

  MetricsHttpServer http;
  if (!o.metrics_listen.empty()) {
    auto port = http.start(o.metrics_listen, [&] {
      metrics.set_queue(queue.stats());
      return registry.render();
    });
    if (!port.ok()) return fail(port.status().message(), 2);
    std::printf("vpremesh-worker metrics on http://%s:%d/metrics\n", host_of(o.metrics_listen).c_str(), *port);
  }
  // The parseable line tests and scripts wait for.
  std::printf("vpremesh-worker ready: %zu worker(s) on %s\n", live, endpoint.url().c_str());
  std::fflush(stdout);
  spdlog::info("{} of {} worker(s) live (device {}, {} GPU(s)); visibility timeout {} s, heartbeat {} s, "
               "max deliveries {}",
               live, workers, o.device, used_gpus, o.visibility_timeout_s, o.heartbeat_s, o.max_deliveries);

  const int signal_number = wait_for_stop_signal(signals, [] {});
  spdlog::info("{}: no new jobs; waiting up to {} s for {} running job(s)",
               signal_number == SIGTERM ? "SIGTERM" : "SIGINT", o.drain_grace_s, pool.busy());
  queue.close();
  if (!pool.wait_idle(seconds(o.drain_grace_s))) {
    // Not cancelled: a cancelled job would end for good. Left pending, it is
    // reclaimed by another worker after the visibility timeout.
    spdlog::warn("{} job(s) still running after --drain-grace; leaving them to be redelivered", pool.busy());
    http.stop();
    std::fflush(nullptr);
    std::_Exit(0);
  }
  http.stop();
  pool.join();
  spdlog::info("stopped");
  return 0;
}

}  // namespace
}  // namespace vpr::service

int main(int argc, char** argv) {
  if (vpr::service::JobProcessFds fds; vpr::service::is_job_process(argc, argv, &fds))
    return vpr::service::job_process_main(fds);
  vpr::service::WorkerOptions options;
  CLI::App app{"vpremesh-worker: runs remeshing jobs from a Redis Streams queue shared with vpremesh-server"};
  vpr::service::add_worker_options(app, &options);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  spdlog::set_default_logger(spdlog::stderr_color_mt("vpremesh-worker"));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  return vpr::service::run(options);
}
