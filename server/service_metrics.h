// The metrics vpremesh-server exports at --metrics-listen /metrics.
#pragma once

#include <string>

#include "server/job.h"
#include "server/metrics.h"

namespace vpr::service {

struct ServiceMetrics {
  explicit ServiceMetrics(MetricsRegistry& r) : registry(r) {}

  MetricsRegistry& registry;
  Gauge& queue_length = registry.gauge("vpremesh_queue_length", "Jobs waiting for a worker");
  Gauge& busy_workers = registry.gauge("vpremesh_busy_workers", "Workers running a job");
  Gauge& live_workers = registry.gauge("vpremesh_workers", "Workers able to run jobs (renderer created)");
  Counter& submitted = registry.counter("vpremesh_jobs_submitted_total", "Jobs accepted into the queue");
  Counter& unauthenticated =
      registry.counter("vpremesh_unauthenticated_calls_total", "RemeshService calls refused for a missing or unknown token");
  Counter& bytes_in = registry.counter("vpremesh_received_bytes_total", "Mesh bytes uploaded by clients");
  Counter& bytes_out =
      registry.counter("vpremesh_sent_bytes_total", "Result bytes produced for clients (mesh and float arrays)");

  // Named by the tenant, never by its token.
  Counter& tenant_submitted(const std::string& tenant) {
    return registry.counter("vpremesh_tenant_jobs_submitted_total", "Jobs accepted into the queue, by tenant",
                            {{"tenant", tenant}});
  }
  // Jobs held now (queued, running, and finished ones kept for --result-ttl).
  Gauge& jobs(v1::JobState s) {
    return registry.gauge("vpremesh_jobs", "Jobs held by the server, by state", {{"state", state_name(s)}});
  }
  Counter& finished(v1::JobState s) {
    return registry.counter("vpremesh_jobs_finished_total", "Jobs that ended, by final state",
                            {{"state", state_name(s)}});
  }
  Histogram& stage_seconds(const std::string& stage) {
    return registry.histogram("vpremesh_stage_duration_seconds", "Wall time of one pipeline stage of one job", kBuckets,
                              {{"stage", stage}});
  }
  Histogram& job_seconds() {
    return registry.histogram("vpremesh_job_duration_seconds", "Submission to completion of successful jobs", kBuckets);
  }
  void set_queue(const QueueStats& s) {
    queue_length.set(double(s.queued));
    jobs(v1::JOB_STATE_QUEUED).set(double(s.queued));
    jobs(v1::JOB_STATE_RUNNING).set(double(s.running));
    jobs(v1::JOB_STATE_SUCCEEDED).set(double(s.succeeded));
    jobs(v1::JOB_STATE_FAILED).set(double(s.failed));
    jobs(v1::JOB_STATE_CANCELLED).set(double(s.cancelled));
    // Only a shared queue (Redis) knows every host's worker threads; with the
    // embedded one the families are absent rather than a misleading 0.
    if (s.fleet_workers)
      registry.gauge("vpremesh_queue_workers", "Worker threads on any host taking jobs from the shared queue")
          .set(double(*s.fleet_workers));
    if (s.fleet_busy)
      registry.gauge("vpremesh_queue_busy_workers", "Worker threads on any host running a job from the shared queue")
          .set(double(*s.fleet_busy));
  }

  inline static const std::vector<double> kBuckets = {0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1,
                                                      2.5,   5,    10,    30,   60,  120,  300, 900};
};

}  // namespace vpr::service
