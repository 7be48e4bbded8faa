#include "load_stats.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>

namespace vpr::cli {

double nearest_rank(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0;
  // The rank ceil(q n), 1-based; the small slack keeps q n = 990.0000001 at 990.
  const double rank = std::ceil(q * double(sorted.size()) - 1e-9);
  const size_t index = size_t(std::clamp(rank, 1.0, double(sorted.size()))) - 1;
  return sorted[index];
}

Percentiles percentiles(std::vector<double> values) {
  Percentiles p;
  p.count = values.size();
  if (values.empty()) return p;
  std::sort(values.begin(), values.end());
  double sum = 0;
  for (double v : values) sum += v;
  p.min = values.front();
  p.max = values.back();
  p.mean = sum / double(values.size());
  p.p50 = nearest_rank(values, 0.50);
  p.p90 = nearest_rank(values, 0.90);
  p.p99 = nearest_rank(values, 0.99);
  p.p999 = nearest_rank(values, 0.999);
  return p;
}

LoadReport summarize_load(const std::vector<RequestSample>& samples, double wall_s) {
  LoadReport r;
  r.requests = samples.size();
  r.wall_s = wall_s;
  std::vector<double> latencies, queues;
  std::map<std::string, double> stage_sums;
  double lag = 0, upload = 0, queue = 0, stages = 0, run = 0, bytes = 0;
  for (const RequestSample& s : samples) {
    if (!s.completed && s.connection_failure) {
      if (r.connection_errors++ == 0) r.connection_error_example = s.error;
      continue;
    }
    if (!s.completed) {
      ++r.errors;
      ++r.errors_by_code[s.error_code];
      r.error_examples.emplace(s.error_code, s.error);  // keeps the first
      continue;
    }
    ++r.completed;
    latencies.push_back(s.latency_ms);
    queues.push_back(s.queue_ms);
    lag += s.lag_ms;
    upload += s.upload_ms;
    queue += s.queue_ms;
    run += s.run_ms;
    bytes += double(s.result_bytes);
    for (const auto& [name, ms] : s.stages) {
      stages += ms;
      if (!stage_sums.count(name)) r.stage_means.emplace_back(name, 0);
      stage_sums[name] += ms;
    }
  }
  r.latency = percentiles(latencies);
  r.queue = percentiles(queues);
  r.throughput_per_s = wall_s > 0 ? double(r.completed) / wall_s : 0;
  if (r.completed == 0) return r;
  const double n = double(r.completed);
  r.lag_ms = lag / n;
  r.upload_ms = upload / n;
  r.queue_ms = queue / n;
  r.stages_ms = stages / n;
  r.server_other_ms = (run - stages) / n;
  r.transfer_other_ms = r.latency.mean - r.lag_ms - r.upload_ms - r.queue_ms - run / n;
  r.result_bytes_mean = bytes / n;
  for (auto& [name, mean] : r.stage_means) mean = stage_sums[name] / n;
  return r;
}

namespace {

nlohmann::json percentiles_json(const Percentiles& p) {
  return {{"count", p.count}, {"min", p.min}, {"mean", p.mean},  {"p50", p.p50},
          {"p90", p.p90},     {"p99", p.p99}, {"p99.9", p.p999}, {"max", p.max}};
}

std::string printf_string(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string printf_string(const char* format, ...) {
  char buf[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buf, sizeof buf, format, args);
  va_end(args);
  return buf;
}

}  // namespace

nlohmann::json load_report_json(const LoadReport& r) {
  nlohmann::json stages = nlohmann::json::object(), order = nlohmann::json::array();
  for (const auto& [name, mean] : r.stage_means) {
    stages[name] = mean;
    order.push_back(name);
  }
  return {{"requests", r.requests},
          {"completed", r.completed},
          {"errors", r.errors},
          {"errors_by_code", r.errors_by_code},
          {"error_examples", r.error_examples},
          {"connection_errors", r.connection_errors},
          {"connection_error_example", r.connection_error_example},
          {"wall_s", r.wall_s},
          {"throughput_per_s", r.throughput_per_s},
          {"latency_ms", percentiles_json(r.latency)},
          {"queue_ms", percentiles_json(r.queue)},
          {"split_ms",
           {{"lag", r.lag_ms},
            {"upload", r.upload_ms},
            {"queue", r.queue_ms},
            {"stages", r.stages_ms},
            {"server_other", r.server_other_ms},
            {"transfer_other", r.transfer_other_ms},
            {"total", r.latency.mean}}},
          {"stages_ms", stages},
          {"stage_order", order},
          {"result_bytes_mean", r.result_bytes_mean}};
}

std::string format_load_report(const LoadReport& r) {
  std::string out =
      printf_string("requests %zu, completed %zu, errors %zu, connection errors %zu in %.2f s: %.3f completed/s\n",
                    r.requests, r.completed, r.errors, r.connection_errors, r.wall_s, r.throughput_per_s);
  out +=
      printf_string("\n%-10s %9s %9s %9s %9s %9s %9s %9s\n", "ms", "min", "p50", "p90", "p99", "p99.9", "max", "mean");
  for (const auto& [name, p] : {std::pair{"latency", r.latency}, std::pair{"queue", r.queue}})
    out += printf_string("%-10s %9.1f %9.1f %9.1f %9.1f %9.1f %9.1f %9.1f\n", name, p.min, p.p50, p.p90, p.p99, p.p999,
                         p.max, p.mean);
  if (r.completed > 0) {
    const double total = r.latency.mean > 0 ? r.latency.mean : 1;
    out += printf_string("\n%-34s %9s %7s\n", "mean latency split", "ms", "share");
    const std::pair<const char*, double> parts[] = {{"client lag (behind schedule)", r.lag_ms},
                                                    {"upload", r.upload_ms},
                                                    {"queue (server)", r.queue_ms},
                                                    {"pipeline stages (server)", r.stages_ms},
                                                    {"decode, encode (server)", r.server_other_ms},
                                                    {"result transfer, other", r.transfer_other_ms}};
    for (const auto& [name, ms] : parts) out += printf_string("%-34s %9.1f %6.1f%%\n", name, ms, 100 * ms / total);
    out += printf_string("%-34s %9.1f\n", "total", r.latency.mean);
    out += printf_string("\n%-34s %9s\n", "stage", "mean ms");
    for (const auto& [name, ms] : r.stage_means) out += printf_string("%-34s %9.1f\n", name.c_str(), ms);
  }
  if (r.errors > 0) {
    out += printf_string("\n%-20s %7s  %s\n", "error", "count", "first message");
    for (const auto& [code, n] : r.errors_by_code)
      out += printf_string("%-20s %7zu  %.200s\n", code.c_str(), n, r.error_examples.at(code).c_str());
  }
  if (r.connection_errors > 0)
    out += printf_string("\n%-20s %7zu  %.200s\n", "connection", r.connection_errors,
                         r.connection_error_example.c_str());
  return out;
}

}  // namespace vpr::cli
