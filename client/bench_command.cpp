// `vpremesh bench --server ADDR --input FILE --target-vertices N`: load and
// latency of a vpremesh-server, through the Remesh RPC that `vpremesh submit`
// uses (the same Draco bytes for every request, return_mesh on unless
// --no-result, so the result's transfer counts).
//
// Closed loop (--concurrency C --requests R): C clients, each on its own
// connection, each sending its next request when its previous one ends.
// Open loop (--rate R --duration D): R x D requests on a fixed schedule, one
// every 1/R s, each on a thread of its own (a pool that grows when every
// thread is busy), so a slow server never slows the schedule. Latency counts
// from the INTENDED send time: a stalled server cannot hide its queueing by
// holding the client back (no coordinated omission).
//
// Connections: the server caps unfinished jobs per connection
// (--max-jobs-per-client, default 4); the open loop opens another connection
// whenever each open one carries --per-connection calls, as many clients
// would.
#include <grpcpp/grpcpp.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "channel.h"
#include "commands.h"
#include "exit_codes.h"
#include "grpc_errors.h"
#include "job_events.h"
#include "load_stats.h"
#include "server/job_spec.h"
#include "server_list.h"
#include "upload.h"
#include "vpremesh/v1/remesh.grpc.pb.h"

namespace vpr::cli {

namespace v1 = vpremesh::v1;

namespace {

using Clock = std::chrono::steady_clock;

struct BenchArgs {
  std::string input, server, device = "any", label;
  uint32_t target_vertices = 0;
  uint32_t resolution = 0;  // 0: the pipeline's default
  int concurrency = 1, requests = 10;
  double rate = 0, duration_s = 0;
  int warmup = 0;
  double deadline_s = 0;
  int per_connection = 4;
  bool no_result = false, json = false;
};

double ms_between(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

// One client: a channel with a connection of its own (gRPC would otherwise
// share one connection between channels with equal arguments) and its stub.
struct Client {
  explicit Client(const std::string& server)
      : channel(make_channel(server, Connection::kOwn)), stub(v1::RemeshService::NewStub(channel)) {}
  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<v1::RemeshService::Stub> stub;
};

// One Remesh call, upload to last event. `intended`: when the schedule
// wanted it sent (the latency's origin); a default time_point: now.
// Each call waits for its connection (wait_for_server): a connection attempt
// that fails once costs a reconnect, not the request.
RequestSample remesh_once(Client& client, const v1::JobSpec& spec, const std::vector<uint8_t>& bytes,
                          double deadline_s, Clock::time_point intended = {}) {
  RequestSample s;
  const Clock::time_point sent = Clock::now();
  if (intended == Clock::time_point{}) intended = sent;
  s.lag_ms = std::max(0.0, ms_between(intended, sent));
  grpc::ClientContext context;
  set_deadline(context, deadline_s);
  wait_for_server(*client.channel, context);
  auto stream = client.stub->Remesh(&context);
  upload(*stream, spec, bytes);
  s.upload_ms = ms_between(sent, Clock::now());
  v1::JobEvent event;
  v1::Failure failure;
  bool ended = false, answered = false;
  while (stream->Read(&event)) {
    answered = true;
    switch (event.event_case()) {
      case v1::JobEvent::kStarted:
        s.queue_ms = event.started().queue_ms();
        break;
      case v1::JobEvent::kStage:
        s.stages.emplace_back(event.stage().name(), event.stage().ms());
        break;
      case v1::JobEvent::kResult:
        s.result_bytes += event.result().data().size();
        break;
      case v1::JobEvent::kCompleted:
        s.completed = true;
        s.run_ms = event.completed().run_ms();
        s.queue_ms = event.completed().queue_ms();
        ended = true;
        break;
      case v1::JobEvent::kFailed:
      case v1::JobEvent::kCancelled:
        failure = event.has_failed() ? event.failed() : event.cancelled();
        if (failure.code() == 0) failure.set_code(event.has_failed() ? grpc::UNKNOWN : grpc::CANCELLED);
        ended = true;
        break;
      default:
        break;
    }
  }
  const grpc::Status status = stream->Finish();
  s.latency_ms = ms_between(intended, Clock::now());
  if (s.completed && status.ok()) return s;
  s.completed = false;
  if (!status.ok()) {
    s.error_code = grpc_code_name(status.error_code());
    s.error = status.error_message();
    s.connection_failure = !answered && is_connection_failure(status);
  } else if (ended) {
    s.error_code = grpc_code_name(grpc::StatusCode(failure.code()));
    s.error = failure.message();
  } else {
    s.error_code = grpc_code_name(grpc::StatusCode::INTERNAL);
    s.error = "the event stream ended OK before the job did";
  }
  return s;
}

struct Run {
  std::vector<RequestSample> samples;
  double wall_s = 0;
};

// C clients on their own connections, `count` requests in all.
Run closed_loop(const std::vector<Client*>& clients, int count, const v1::JobSpec& spec,
                const std::vector<uint8_t>& bytes, double deadline_s) {
  Run run;
  run.samples.resize(size_t(count));
  std::atomic<int> next{0};
  const Clock::time_point start = Clock::now();
  std::vector<std::thread> threads;
  for (Client* client : clients)
    threads.emplace_back([&, client] {
      for (int i = next++; i < count; i = next++)
        run.samples[size_t(i)] = remesh_once(*client, spec, bytes, deadline_s);
    });
  for (std::thread& t : threads) t.join();
  run.wall_s = ms_between(start, Clock::now()) / 1000;
  return run;
}

// Connections for the open loop: a call takes the first that carries fewer
// than `per_connection` calls, or a new one.
class ConnectionPool {
 public:
  ConnectionPool(std::string server, int per_connection)
      : server_(std::move(server)), per_connection_(per_connection) {}

  size_t acquire() {
    std::lock_guard<std::mutex> lock(mutex_);
    for (size_t i = 0; i < active_.size(); ++i)
      if (active_[i] < per_connection_) {
        ++active_[i];
        return i;
      }
    clients_.emplace_back(server_);
    active_.push_back(1);
    return active_.size() - 1;
  }
  Client& client(size_t i) {
    std::lock_guard<std::mutex> lock(mutex_);
    return clients_[i];  // a deque: references stay valid as it grows
  }
  void release(size_t i) {
    std::lock_guard<std::mutex> lock(mutex_);
    --active_[i];
  }
  size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return clients_.size();
  }

 private:
  const std::string server_;
  const int per_connection_;
  mutable std::mutex mutex_;
  std::deque<Client> clients_;
  std::deque<int> active_;
};

// Threads that run one task each, made when every thread is busy, so that no
// task waits for a thread.
class GrowingPool {
 public:
  ~GrowingPool() { join(); }
  void submit(std::function<void()> task) {
    std::lock_guard<std::mutex> lock(mutex_);
    tasks_.push_back(std::move(task));
    if (tasks_.size() > idle_) {
      threads_.emplace_back([this] { loop(); });
      ++made_;
    }
    ready_.notify_one();
  }
  void join() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    ready_.notify_all();
    for (std::thread& t : threads_) t.join();
    threads_.clear();
  }
  size_t threads_made() const { return made_; }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      ++idle_;
      ready_.wait(lock, [this] { return !tasks_.empty() || done_; });
      --idle_;
      if (tasks_.empty()) return;  // done
      std::function<void()> task = std::move(tasks_.front());
      tasks_.pop_front();
      lock.unlock();
      task();
      lock.lock();
    }
  }
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::function<void()>> tasks_;
  std::vector<std::thread> threads_;
  size_t idle_ = 0, made_ = 0;
  bool done_ = false;
};

// round(rate x duration) requests, request i intended at start + i / rate.
Run open_loop(ConnectionPool& pool, double rate, double duration_s, const v1::JobSpec& spec,
              const std::vector<uint8_t>& bytes, double deadline_s, size_t* threads_used) {
  Run run;
  const size_t count = size_t(std::llround(rate * duration_s));
  run.samples.resize(count);
  std::vector<Clock::time_point> ends(count);
  GrowingPool threads;
  const Clock::time_point start = Clock::now();
  for (size_t i = 0; i < count; ++i) {
    const Clock::time_point intended =
        start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(double(i) / rate));
    std::this_thread::sleep_until(intended);
    threads.submit([&, i, intended] {
      const size_t c = pool.acquire();
      run.samples[i] = remesh_once(pool.client(c), spec, bytes, deadline_s, intended);
      pool.release(c);
      ends[i] = Clock::now();
    });
  }
  threads.join();
  *threads_used = threads.threads_made();
  Clock::time_point last = start;
  for (const Clock::time_point& t : ends) last = std::max(last, t);
  run.wall_s = ms_between(start, last) / 1000;
  return run;
}

// A cheap call that fails fast when nothing answers at the address; any
// answer from a server (NOT_FOUND for the made-up job) will do.
grpc::Status probe(Client& client) {
  grpc::ClientContext context;
  set_deadline(context, 10);
  v1::JobRef ref;
  ref.set_job_id("vpremesh-bench-probe");
  v1::JobStatus status;
  const grpc::Status s = client.stub->GetJob(&context, ref, &status);
  if (s.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED)
    return grpc::Status(grpc::StatusCode::UNAVAILABLE, "the server did not answer within 10 s");
  return s;
}

int fail(const Status& s) {
  std::fprintf(stderr, "vpremesh: error: %s\n", s.to_string().c_str());
  return exit_code_for(s);
}

int run_bench(const BenchArgs& a, bool open) {
  if (open && (a.rate <= 0 || a.duration_s <= 0)) {
    std::fprintf(stderr, "vpremesh: bench: the open loop needs --rate > 0 and --duration > 0\n");
    return kExitUsage;
  }
  if (open && std::llround(a.rate * a.duration_s) < 1) {
    std::fprintf(stderr, "vpremesh: bench: --rate x --duration is %g, less than one request\n", a.rate * a.duration_s);
    return kExitUsage;
  }

  auto bytes = draco_upload(a.input, 0);
  if (!bytes.ok()) return fail(bytes.status());
  PipelineOptions options;
  options.target_vertices = a.target_vertices;
  if (a.resolution > 0) options.views.resolution = a.resolution;
  if (Status s = validate_options(options); !s.ok()) return fail(s);
  auto made = service::make_job_spec(options);
  if (!made.ok()) return fail(made.status());
  v1::JobSpec spec = *made;
  spec.set_mesh_size_bytes(bytes->size());
  spec.set_label(a.label.empty() ? "bench:" + std::filesystem::path(a.input).filename().string() : a.label);
  spec.set_return_mesh(!a.no_result);
  spec.set_device(a.device == "cpu" ? v1::DEVICE_CPU : a.device == "cuda" ? v1::DEVICE_CUDA : v1::DEVICE_ANY);

  // Closed loop: one connection per client. Open loop: the pool, whose first
  // connection carries the probe and the warmup (so it is open when the
  // schedule starts).
  std::deque<Client> owned;
  std::vector<Client*> clients;
  ConnectionPool pool(a.server, a.per_connection);
  if (open) {
    const size_t first = pool.acquire();
    pool.release(first);
    clients.push_back(&pool.client(first));
  } else {
    for (int i = 0; i < a.concurrency; ++i) clients.push_back(&owned.emplace_back(a.server));
  }
  if (const grpc::Status s = probe(*clients.front()); s.error_code() == grpc::StatusCode::UNAVAILABLE)
    return report_call_error(s, a.server);

  // Uncounted: the closed loop's clients each get one while there are enough;
  // the open loop's go one after another.
  if (a.warmup > 0) closed_loop(clients, a.warmup, spec, *bytes, a.deadline_s);

  size_t threads_used = 0;
  const Run run = open ? open_loop(pool, a.rate, a.duration_s, spec, *bytes, a.deadline_s, &threads_used)
                       : closed_loop(clients, a.requests, spec, *bytes, a.deadline_s);
  const LoadReport report = summarize_load(run.samples, run.wall_s);

  const std::string input_name = std::filesystem::path(a.input).filename().string();
  if (a.json) {
    nlohmann::json j = load_report_json(report);
    j["mode"] = open ? "open" : "closed";
    j["server"] = a.server;
    j["input"] = a.input;
    j["upload_bytes"] = bytes->size();
    j["target_vertices"] = a.target_vertices;
    j["return_mesh"] = !a.no_result;
    j["warmup"] = a.warmup;
    j["deadline_s"] = a.deadline_s;
    if (open) {
      j["rate_per_s"] = a.rate;
      j["duration_s"] = a.duration_s;
      j["connections"] = pool.size();
      j["threads"] = threads_used;
    } else {
      j["concurrency"] = a.concurrency;
      j["connections"] = clients.size();
    }
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    if (open)
      std::printf("open loop: %.3g requests/s for %.3g s (%zu requests on %zu connections) to %s\n", a.rate,
                  a.duration_s, run.samples.size(), pool.size(), a.server.c_str());
    else
      std::printf("closed loop: %d clients, %d requests to %s\n", a.concurrency, a.requests, a.server.c_str());
    std::printf("%s (%zu bytes of Draco) -> %u vertices, %s; %d warmup request(s) not counted\n\n", input_name.c_str(),
                bytes->size(), a.target_vertices, a.no_result ? "no result returned" : "result returned", a.warmup);
    std::printf("%s", format_load_report(report).c_str());
  }
  if (report.completed == 0 && report.errors == 0 && report.connection_errors > 0) {
    std::fprintf(stderr, "vpremesh: UNAVAILABLE: none of %zu requests reached %s (%zu connection errors: %s)\n",
                 report.requests, a.server.c_str(), report.connection_errors,
                 one_line(report.connection_error_example).c_str());
    return exit_code_for(grpc::StatusCode::UNAVAILABLE);
  }
  if (report.completed == 0 && report.errors > 0) {
    // Nothing completed: say why in one line and exit with the commonest code.
    auto worst = report.errors_by_code.begin();
    for (auto it = report.errors_by_code.begin(); it != report.errors_by_code.end(); ++it)
      if (it->second > worst->second) worst = it;
    const std::string& code = worst->first;
    std::fprintf(stderr, "vpremesh: %s: none of %zu requests completed (%zu x %s: %s)\n", code.c_str(), report.requests,
                 worst->second, code.c_str(), report.error_examples.at(code).c_str());
    for (int c = 0; c <= 16; ++c)
      if (grpc_code_name(grpc::StatusCode(c)) == code) return exit_code_for(grpc::StatusCode(c));
    return kExitInternal;
  }
  return kExitOk;
}

}  // namespace

Command add_bench_command(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand("bench", "Load and latency of a vpremesh-server (closed or open loop)");
  add_server_flags(cmd, args->server, args->deadline_s);  // --deadline: per request
  cmd->add_option("-i,--input", args->input, "Mesh uploaded by every request (.drc .glb .gltf .obj .ply .off .stl)")->required();
  cmd->add_option("-n,--target-vertices", args->target_vertices, "Output vertex count")->required();
  CLI::Option* concurrency =
      cmd->add_option("-c,--concurrency", args->concurrency, "Closed loop: clients, each with one request in flight")
          ->check(CLI::Range(1, 1024))
          ->capture_default_str();
  CLI::Option* requests = cmd->add_option("-r,--requests", args->requests, "Closed loop: requests in all")
                              ->check(CLI::Range(1, 1000000))
                              ->capture_default_str();
  CLI::Option* rate = cmd->add_option("--rate", args->rate, "Open loop: requests per second on a fixed schedule")
                          ->check(CLI::PositiveNumber);
  cmd->add_option("--duration", args->duration_s, "Open loop: seconds of schedule (rate x duration requests)")
      ->check(CLI::PositiveNumber)
      ->needs(rate);
  rate->excludes(concurrency)->excludes(requests);
  cmd->add_option("--warmup", args->warmup, "Requests sent first and not counted")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd->add_flag("--no-result", args->no_result, "Do not ask for the result mesh (return_mesh off)");
  cmd->add_option("--device", args->device, "any, cpu or cuda (the job's device preference)")
      ->check(CLI::IsMember({"any", "cpu", "cuda"}))
      ->capture_default_str();
  cmd->add_option("--resolution", args->resolution, "Snapshot resolution in pixels (0: the pipeline's default)")
      ->capture_default_str();
  cmd->add_option("--per-connection", args->per_connection,
                  "Open loop: calls per connection before another opens (the server's --max-jobs-per-client)")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  cmd->add_option("--label", args->label, "Job label for the server's logs (default: bench:FILE)");
  cmd->add_flag("--json", args->json, "Print a JSON report instead of the tables");
  return [args, rate]() { return run_bench(*args, rate->count() > 0); };
}

}  // namespace vpr::cli
