// The statistics of `vpremesh bench`: every request's latency and where it
// went, summed up into throughput, exact percentiles (all latencies kept and
// sorted: a run has at most tens of thousands of requests) and the split of
// the mean latency into client, queue and pipeline time. Free of gRPC, so it
// can be tested on made-up samples.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace vpr::cli {

// One request as the client saw it. Times in milliseconds.
struct RequestSample {
  bool completed = false;  // the job's `completed` event arrived and the call ended OK
  std::string error_code;  // otherwise the gRPC status code's name ("RESOURCE_EXHAUSTED")
  std::string error;       // and its message
  double latency_ms = 0;   // from the INTENDED send time to the end of the call
  double lag_ms = 0;       // intended to actual send (open loop: the client's own delay; closed loop 0)
  double upload_ms = 0;    // first write of the upload to WritesDone
  double queue_ms = 0;     // server: submission to start (Started.queue_ms)
  double run_ms = 0;       // server: the job's run (Completed.run_ms: pipeline, decode and encode)
  std::vector<std::pair<std::string, double>> stages;  // Stage events, in order
  uint64_t result_bytes = 0;                           // bytes of `result` events received
  // The request failed in the transport before any event came: no
  // connection could be made, or it broke before the server answered
  // (grpc_errors.h). Counted apart from the server's refusals and failed jobs.
  bool connection_failure = false;
};

// Nearest-rank percentiles of a set of values: pq is the smallest value with
// at least q of all values at or below it, so p50 <= p90 <= p99 <= p99.9 <= max
// always, and each is a value that was measured.
struct Percentiles {
  size_t count = 0;
  double min = 0, mean = 0, p50 = 0, p90 = 0, p99 = 0, p999 = 0, max = 0;
};
// sorted: ascending; q in (0, 1]. 0 for an empty set.
double nearest_rank(const std::vector<double>& sorted, double q);
Percentiles percentiles(std::vector<double> values);

struct LoadReport {
  // requests = completed + errors + connection_errors
  size_t requests = 0, completed = 0, errors = 0;
  std::map<std::string, size_t> errors_by_code;       // code name -> count (the server's answers)
  std::map<std::string, std::string> error_examples;  // code name -> the first message seen
  size_t connection_errors = 0;                       // requests that never reached the server
  std::string connection_error_example;               // the first one's message
  double wall_s = 0;                                  // first intended send to the last call's end
  double throughput_per_s = 0;                        // completed / wall_s
  Percentiles latency;                                // completed requests only
  Percentiles queue;                                  // Started.queue_ms of completed requests
  // The mean latency of completed requests, split; the parts add up to
  // latency.mean. server_other: run_ms less the stages (decode, encode);
  // transfer_other: what is left (result transfer, gRPC, the client); it
  // may dip a few ms below zero, as the client's and the server's clocks
  // overlap (the last upload write can return after the server queued the job).
  double lag_ms = 0, upload_ms = 0, queue_ms = 0, stages_ms = 0, server_other_ms = 0, transfer_other_ms = 0;
  std::vector<std::pair<std::string, double>> stage_means;  // per stage, in the order the server runs them
  double result_bytes_mean = 0;
};

// wall_s: the run's duration as the caller measured it.
LoadReport summarize_load(const std::vector<RequestSample>& samples, double wall_s);

// {"requests", "completed", "errors", "errors_by_code": {CODE: n}, "error_examples": {CODE: message},
//  "connection_errors", "connection_error_example",
//  "wall_s", "throughput_per_s", "latency_ms": {count, min, mean, p50, p90, p99, p99.9, max},
//  "queue_ms": {... the same}, "split_ms": {lag, upload, queue, stages, server_other, transfer_other, total},
//  "stages_ms": {name: mean}, "stage_order": [names], "result_bytes_mean"}
nlohmann::json load_report_json(const LoadReport& report);

// The report as tables (throughput line, latency percentiles, the split of
// the mean, per-stage means, errors by code).
std::string format_load_report(const LoadReport& report);

}  // namespace vpr::cli
