// vpremesh-server: the remeshing service. An in-process job queue feeds N
// worker threads running the pipeline, or (--queue redis://) a Redis Streams
// queue shared with other replicas feeds vpremesh-worker processes on other
// hosts; gRPC (callback API) in front, with the
// standard health service and server reflection; Prometheus metrics over
// HTTP. SIGTERM drains: new jobs are refused, waiting ones fail with
// UNAVAILABLE, running ones get --drain-grace seconds to finish.
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <tbb/task_arena.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include "server/authenticator.h"
#include "server/embedded_queue.h"
#include "server/job_process.h"
#include "server/metrics_http.h"
#include "server/process_main.h"
#include "server/redis_queue.h"
#include "server/remesh_service.h"
#include "server/server_credentials.h"
#include "server/server_options.h"
#include "server/service_metrics.h"
#include "server/worker_pool.h"
#ifdef VPR_HAVE_CUDA
#include "gpu/cuda_device.h"
#endif

namespace vpr::service {
namespace {

constexpr const char* kServiceName = "vpremesh.v1.RemeshService";

int run(const ServerOptions& o) {
  spdlog::set_level(spdlog::level::from_str(o.log_level));
  if (Status s = check_server_options(o); !s.ok()) return fail(s.message(), 2);
  Authenticator auth(o.auth_tokens);
  if (Status s = auth.reload(); !s.ok()) return fail(s.message(), 2);
  if (auth.enabled() && o.tls_cert.empty() && !is_loopback_host(host_of(o.listen)))
    spdlog::warn("--auth-tokens without --tls-cert: tokens cross the network in plaintext (fine behind a TLS proxy)");
  if (o.insecure && !auth.enabled())
    spdlog::warn("--insecure: no authentication; anyone who reaches {} may run jobs and read any result", o.listen);

  // Every thread started from here on inherits the blocked signals. SIGHUP
  // re-reads --auth-tokens.
  sigset_t signals = block_stop_signals();
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  // Only now: making credentials starts gRPC's own threads, which must
  // inherit the blocked signals (else a SIGTERM may kill instead of drain).
  auto credentials = server_credentials(o);
  if (!credentials.ok()) return fail(credentials.status().message(), 2);

  // Devices and workers.
  int gpus = 0;
  std::string no_gpu_why = "this build has no CUDA support";
#ifdef VPR_HAVE_CUDA
  if (o.device != "cpu") gpus = int(cuda_devices(&no_gpu_why).size());
#endif
  if (o.device == "cuda" && gpus == 0) return fail("--device cuda but no CUDA device is usable: " + no_gpu_why, 2);
  const DevicePolicy policy = o.device == "cpu"    ? DevicePolicy::kCpu
                              : o.device == "cuda" ? DevicePolicy::kCuda
                                                   : DevicePolicy::kAuto;
  // On the CPU one worker is enough: each stage already uses every core
  // (TBB); a GPU runs several jobs at once (default_workers). With a Redis
  // queue vpremesh-worker processes run the jobs.
  const bool redis = uses_redis(o);
  const int workers = o.workers >= 0 ? o.workers
                      : redis        ? 0
                                     : default_workers(gpus, tbb::this_task_arena::max_concurrency());
  auto renderer = parse_renderer_kind(o.renderer);
  if (!renderer.ok()) return fail(renderer.status().message(), 2);

  MetricsRegistry registry;
  ServiceMetrics metrics(registry);
  auto on_state = [&metrics](const std::string&, v1::JobState state) {
    if (state == v1::JOB_STATE_SUCCEEDED || state == v1::JOB_STATE_FAILED || state == v1::JOB_STATE_CANCELLED)
      metrics.finished(state).inc();
  };
  std::unique_ptr<JobQueue> queue;
  if (redis) {
    RedisQueueOptions ro;
    ro.endpoint = parse_redis_url(o.queue).value();
    ro.limits = o.limits;
    ro.result_ttl = seconds(o.result_ttl_s);
    ro.upload_ttl = seconds(o.upload_ttl_s);
    ro.on_state = on_state;
    queue = std::make_unique<RedisQueue>(ro);
  } else {
    EmbeddedQueueOptions qo;
    qo.limits = o.limits;
    qo.result_ttl = seconds(o.result_ttl_s);
    qo.on_state = on_state;
    queue = std::make_unique<EmbeddedQueue>(qo);
  }

  WorkerPoolOptions wo;
  wo.workers = workers;
  wo.device = policy;
  wo.renderer = *renderer;
  wo.cuda_devices = policy == DevicePolicy::kCpu ? 0 : gpus;
  wo.gpu_job_bytes = o.gpu_job_mib << 20;
  wo.limits = o.limits;
  wo.process = job_process_options(o.isolation, workers);
  if (const char* label = std::getenv("VPREMESH_FAULT_CRASH_ON_LABEL"); label && *label) {
    wo.crash_on_label = label;
    spdlog::warn("fault injection: jobs labelled '{}' abort their process", label);
  }
  WorkerPool pool(*queue, wo, &metrics);
  // On every return: wake the workers so the pool's destructor can join them.
  struct CloseOnExit {
    JobQueue& queue;
    ~CloseOnExit() { queue.close(); }
  } close_on_exit{*queue};
  std::string why;
  const size_t live = pool.start(&why);
  if (redis)
    spdlog::info("job queue {} (Redis Streams); {} worker(s) in this process", parse_redis_url(o.queue)->url(), live);
  else
    spdlog::info("{} of {} workers live (device {}, {} GPU(s))", live, workers, o.device, wo.cuda_devices);
  if (!redis && live == 0) spdlog::error("no worker can run jobs: {}; serving NOT_SERVING", why);

  std::atomic<bool> draining{false};
  ServiceConfig config;
  config.limits = o.limits;
  // With a shared queue the workers are elsewhere; a DEVICE_CUDA job waits
  // for one with a GPU.
  config.has_cuda = redis || wo.cuda_devices > 0;
  config.admission = [&pool, &draining, why, redis]() -> Status {
    if (draining) return unavailable("the server is shutting down and accepts no new jobs; retry elsewhere");
    if (!redis && pool.live() == 0) return unavailable("no worker can run jobs on this server: " + why);
    return Status::Ok();
  };
  config.auth = &auth;
  RemeshServiceImpl service(*queue, config, &metrics);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(o.listen, *credentials, &port);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (!server || port == 0) return fail("cannot listen on " + o.listen + " (--listen): address in use or invalid", 2);
  // --health-listen: the health service alone, in plaintext, for probes that
  // speak neither TLS nor tokens (Kubernetes' gRPC probes).
  std::unique_ptr<grpc::Server> health_server;
  int health_port = 0;
  if (!o.health_listen.empty()) {
    grpc::ServerBuilder health_builder;
    health_builder.AddListeningPort(o.health_listen, grpc::InsecureServerCredentials(), &health_port);
    health_server = health_builder.BuildAndStart();
    if (!health_server || health_port == 0)
      return fail("cannot listen on " + o.health_listen + " (--health-listen): address in use or invalid", 2);
  }
  std::vector<grpc::Server*> servers = {server.get()};
  if (health_server) servers.push_back(health_server.get());
  // Both "" (the process) and the service. With a shared queue, a Redis
  // outage turns only the service NOT_SERVING (readiness: no new jobs here)
  // while "" stays SERVING (liveness: restarting would not bring Redis back).
  auto set_serving = [&](bool serving) {
    for (grpc::Server* s : servers) {
      s->GetHealthCheckService()->SetServingStatus(serving);
      s->GetHealthCheckService()->SetServingStatus(kServiceName, serving);
    }
  };
  auto set_queue_serving = [&](bool serving) {
    for (grpc::Server* s : servers) s->GetHealthCheckService()->SetServingStatus(kServiceName, serving);
  };
  // Serving while some worker can run jobs (embedded) or Redis answers.
  Status queue_health = queue->health();
  if (!queue_health.ok()) spdlog::error("{}; serving NOT_SERVING until it answers", queue_health.message());
  if (redis) {
    set_serving(true);
    set_queue_serving(queue_health.ok());
  } else {
    set_serving(live > 0);
  }

  // The parseable lines tests and scripts wait for (health first: a test
  // that waits for "listening on" then finds both).
  if (health_server)
    std::printf("vpremesh-server health on %s:%d\n", host_of(o.health_listen).c_str(), health_port);
  std::printf("vpremesh-server listening on %s:%d\n", host_of(o.listen).c_str(), port);
  std::fflush(stdout);
  spdlog::info("gRPC {}; {}", o.tls_cert.empty() ? "in plaintext" : o.tls_client_ca.empty() ? "over TLS" : "over mutual TLS",
               auth.enabled() ? "tenants need a bearer token (--auth-tokens)" : "no authentication");
  spdlog::info(
      "listening on {}:{} with {} worker(s); limits: upload {} MiB, {} vertices, {} faces, queue {}, "
      "{} jobs per client; results kept {} s",
      host_of(o.listen), port, workers, o.limits.max_upload_bytes >> 20, o.limits.max_vertices, o.limits.max_faces,
      o.limits.max_queue, o.limits.max_jobs_per_client, o.result_ttl_s);

  MetricsHttpServer http;
  if (!o.metrics_listen.empty()) {
    auto metrics_port = http.start(o.metrics_listen, [&] {
      metrics.set_queue(queue->stats());
      return registry.render();
    });
    if (!metrics_port.ok()) return fail(metrics_port.status().message(), 2);
    std::printf("vpremesh-server metrics on http://%s:%d/metrics\n", host_of(o.metrics_listen).c_str(), *metrics_port);
    std::fflush(stdout);
  }

  // Wait for SIGTERM / SIGINT, forgetting expired results and checking the
  // queue's store once a second; SIGHUP re-reads the tokens (running jobs and
  // open streams are untouched: a call is checked when it starts).
  auto tick = [&] {
    if (auth.changed_on_disk())
      if (Status s = auth.reload(); !s.ok()) spdlog::error("{}; the tokens read before stay in force", s.message());
    queue->expire();
    if (!redis) return;
    Status h = queue->health();
    if (h.ok() != queue_health.ok()) {
      if (h.ok())
        spdlog::info("the job queue answers again: SERVING");
      else
        spdlog::error("{}: NOT_SERVING", h.message());
      set_queue_serving(h.ok());
    }
    queue_health = h;
  };
  int signal_number = 0;
  while ((signal_number = wait_for_stop_signal(signals, tick)) == SIGHUP) {
    if (!auth.enabled()) {
      spdlog::info("SIGHUP: no --auth-tokens to re-read");
    } else if (Status s = auth.reload(); !s.ok()) {
      spdlog::error("SIGHUP: {}; the tokens read before stay in force", s.message());
    }
  }

  spdlog::info("{}: draining (grace {} s)", signal_number == SIGTERM ? "SIGTERM" : "SIGINT", o.drain_grace_s);
  draining = true;
  set_serving(false);
  if (redis) {
    // The jobs belong to the shared queue, not to this replica: hand the
    // clients over to the other replicas at once and leave the jobs running.
    service.end_streams(unavailable(
        "this vpremesh-server replica is shutting down; the job goes on: re-attach with Watch on another replica"));
  }
  const size_t failed = queue->drain(unavailable(
      "the server is shutting down: the job was still waiting in the queue and did not run; submit it again"));
  if (failed) spdlog::info("{} waiting job(s) failed with UNAVAILABLE", failed);
  if (!pool.wait_idle(seconds(o.drain_grace_s))) {
    spdlog::warn("{} job(s) still running after the drain grace period; cancelling them", pool.busy());
    pool.cancel_running(unavailable("the server shut down before the job finished (--drain-grace " +
                                    std::to_string(int(o.drain_grace_s)) + " s)"));
    // They stop at their next stage boundary.
    if (!pool.wait_idle(std::chrono::seconds(10)))
      spdlog::warn("a job did not reach a stage boundary within 10 s of cancellation");
  }
  // Let open streams send their last events, then end them.
  server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(5));
  if (health_server) health_server->Shutdown(std::chrono::system_clock::now());
  http.stop();
  queue->close();
  if (pool.busy() > 0) {
    spdlog::warn("exiting with a job still inside a pipeline stage");
    std::fflush(nullptr);
    std::_Exit(0);
  }
  pool.join();
  spdlog::info("stopped");
  return 0;
}

}  // namespace
}  // namespace vpr::service

int main(int argc, char** argv) {
  if (vpr::service::JobProcessFds fds; vpr::service::is_job_process(argc, argv, &fds))
    return vpr::service::job_process_main(fds);
  vpr::service::ServerOptions options;
  CLI::App app{"vpremesh-server: visual-perception-guided remeshing as a gRPC service"};
  vpr::service::add_server_options(app, &options);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  spdlog::set_default_logger(spdlog::stderr_color_mt("vpremesh-server"));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  return vpr::service::run(options);
}
