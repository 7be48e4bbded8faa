// The Redis Streams queue end to end: every test starts its own redis-server
// on a free loopback port (AOF on, data in a fresh temp dir), vpremesh-server
// replicas with --queue redis://... and vpremesh-worker processes, and drives
// them with the C++ stubs and the real client. Every result is checked byte
// for byte against `vpremesh local` with the same flags (the oracle), and the
// tests print the numbers docs/scaling.md quotes.
#include <gtest/gtest.h>

#include <future>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "grpc/health/v1/health.grpc.pb.h"
#include "http_get.h"
#include "auth_harness.h"
#include "redis_harness.h"
#include "test_meshes.h"

namespace fs = std::filesystem;

namespace vpr::testing {
namespace {

using Clock = std::chrono::steady_clock;
using grpc::health::v1::HealthCheckResponse;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::string read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// One input and the flags of its job: what `vpremesh local` and the service
// both get, so their results must be the same bytes.
struct Input {
  std::string name;  // file name in the test's dir, e.g. "sphere.drc"
  std::vector<uint8_t> draco;
  uint32_t target = 0;
  uint64_t seed = 1;
  uint32_t awlop_iterations = 0;  // 0: the default
  std::string expected;           // the local run's .drc file

  std::vector<std::string> flags() const {
    std::vector<std::string> f = {"-n", std::to_string(target), "--seed", std::to_string(seed)};
    if (awlop_iterations) f.insert(f.end(), {"--awlop-iterations", std::to_string(awlop_iterations)});
    return f;
  }
  v1::JobSpec spec(const std::string& label = "") const {
    v1::JobSpec s = make_spec(target, draco.size());
    s.set_return_saliency(false);
    s.set_label(label.empty() ? name : label);
    s.mutable_options()->set_seed(seed);
    s.mutable_options()->set_awlop_iterations(awlop_iterations);
    return s;
  }
};

// The shapes: an icosphere (2,562 vertices), an ellipsoid of the same
// connectivity, and a polygon soup (3,840 vertices, every other face flipped).
Mesh ellipsoid() {
  Mesh m = icosphere(4);
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    m.positions[3 * v] *= 1.6f;
    m.positions[3 * v + 2] *= 0.7f;
  }
  return m;
}

// Workers render with OSMesa, and so does the oracle: the same pixels on any
// machine, GPU or not.
const std::vector<std::string> kWorkerFlags = {"--device", "cpu", "--concurrency", "1", "--renderer", "osmesa"};

class RedisEndToEndTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vpremesh_redis_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const std::string redis_server = find_redis_server();
    ASSERT_FALSE(redis_server.empty()) << kNoRedisServer;
    const std::string address = closed_loopback_address();
    ASSERT_FALSE(address.empty());
    redis_ =
        std::make_unique<RedisProcess>(redis_server, dir_ / "redis", std::stoi(address.substr(address.rfind(':') + 1)));
    ASSERT_TRUE(redis_->start()) << redis_->log();
  }
  // Children first (in reverse order of creation), then Redis, then the files.
  void TearDown() override {
    clients_.clear();
    workers_.clear();
    servers_.clear();
    redis_.reset();
    fs::remove_all(dir_);
  }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  ServerProcess* start_server(const std::vector<std::string>& flags = {}) {
    std::vector<std::string> all = {"--queue", redis_->url(), "--max-jobs-per-client", "64"};
    all.insert(all.end(), flags.begin(), flags.end());
    servers_.push_back(std::make_unique<ServerProcess>(all));
    return servers_.back().get();
  }
  // Replicas A and B on the test's Redis: a fatal failure (with every log)
  // when one does not start. Call through ASSERT_NO_FATAL_FAILURE.
  void start_replicas(ServerProcess** a, ServerProcess** b, const std::vector<std::string>& a_flags = {}) {
    *a = start_server(a_flags);
    ASSERT_TRUE((*a)->started()) << "server A\n" << all_logs();
    *b = start_server();
    ASSERT_TRUE((*b)->started()) << "server B\n" << all_logs();
  }
  WorkerProcess* start_worker(const std::vector<std::string>& flags = {}, const std::vector<std::string>& env = {}) {
    std::vector<std::string> all = kWorkerFlags;
    all.insert(all.end(), flags.begin(), flags.end());
    workers_.push_back(std::make_unique<WorkerProcess>(redis_->url(), all, env));
    return workers_.back().get();
  }
  // `vpremesh ARGS...` as a process, e.g. a client that must outlive a server.
  ChildProcess* start_client(std::vector<std::string> args) {
    args.insert(args.begin(), VPR_CLI_PATH);
    clients_.push_back(std::make_unique<ChildProcess>(std::move(args)));
    return clients_.back().get();
  }
  WorkerProcess* worker_with_pid(pid_t pid) {
    for (auto& w : workers_)
      if (w->pid() == pid) return w.get();
    return nullptr;
  }

  // Writes the input file and runs the oracle: `vpremesh local` with the flags.
  void prepare(Input& input) {
    ASSERT_FALSE(input.draco.empty());
    write_file(path(input.name), input.draco);
    const std::string out = path(input.name + ".local.drc");
    std::string flags;
    for (const std::string& f : input.flags()) flags += " " + f;
    CliRun local = run_cli("local " + path(input.name) + " -o " + out + flags + " --renderer osmesa --json");
    ASSERT_EQ(local.code, 0) << local.err;
    input.expected = read_file(out);
    ASSERT_FALSE(input.expected.empty());
  }

  // The small inputs: about 0.4 s each on two cores.
  std::vector<Input> small_inputs() {
    std::vector<Input> inputs(3);
    inputs[0] = {"sphere.drc", lossless_draco(icosphere(4)), 400, 1};
    inputs[1] = {"ellipsoid.drc", lossless_draco(ellipsoid()), 600, 2};
    inputs[2] = {"soup.drc", lossless_draco(flipped_soup(icosphere(3))), 300, 3};
    for (Input& i : inputs) {
      prepare(i);
      if (::testing::Test::HasFatalFailure()) return {};
    }
    return inputs;
  }
  // A job of about 2.5 s on two idle cores, almost all of it after
  // `started` (200 AWLOP iterations over 4,000 samples): long enough to be
  // caught running, and a kill lands in the middle.
  Input long_input() {
    Input input{"long.drc", lossless_draco(icosphere(4)), 4000, 5, 200};
    prepare(input);
    return input;
  }

  std::string all_logs() const {
    std::string s = "--- redis\n" + redis_->log();
    for (const auto& server : servers_) s += "--- server " + server->address() + "\n" + server->log();
    for (const auto& worker : workers_) s += "--- worker " + std::to_string(worker->pid()) + "\n" + worker->log();
    for (const auto& client : clients_) s += "--- client " + std::to_string(client->pid()) + "\n" + client->output();
    return s;
  }

  fs::path dir_;
  std::unique_ptr<RedisProcess> redis_;
  std::vector<std::unique_ptr<ServerProcess>> servers_;
  std::vector<std::unique_ptr<WorkerProcess>> workers_;
  std::vector<std::unique_ptr<ChildProcess>> clients_;
};

#define ASSERT_STARTED(process, what) ASSERT_TRUE((process)->started()) << what << "\n" << all_logs()
#define ASSERT_READY(worker) ASSERT_TRUE((worker)->ready()) << all_logs()

// What a job's events say, from a Remesh or Watch stream.
struct History {
  grpc::Status status;
  std::vector<v1::JobEvent> events;
  std::string result;

  int count(v1::JobEvent::EventCase c) const {
    return int(std::count_if(events.begin(), events.end(), [c](const v1::JobEvent& e) { return e.event_case() == c; }));
  }
  int started() const { return count(v1::JobEvent::kStarted); }
  int completed() const { return count(v1::JobEvent::kCompleted); }
  std::vector<pid_t> worker_pids() const {
    std::vector<pid_t> pids;
    for (const auto& e : events)
      if (e.has_started()) pids.push_back(worker_pid(e.started().worker()));
    return pids;
  }
  const v1::JobEvent* last() const { return events.empty() ? nullptr : &events.back(); }
  // Every result chunk once: the chunks tile [0, total) in order.
  bool result_chunks_once() const {
    uint64_t next = 0, total = 0;
    for (const auto& e : events)
      if (e.has_result()) {
        if (e.result().offset() != next) return false;
        next += e.result().data().size();
        total = e.result().total();
      }
    return next == total && total == result.size();
  }
  // Sequence numbers 0, 1, 2, ... from `first`, none missing or repeated.
  bool sequences_from(uint64_t first) const {
    for (size_t i = 0; i < events.size(); ++i)
      if (events[i].sequence() != first + i) return false;
    return true;
  }
  std::string describe() const {
    std::string s = "status " + std::to_string(status.error_code()) + " " + status.error_message() + "; events:";
    for (const auto& e : events) {
      s += " " + std::to_string(e.sequence()) + ":" + std::to_string(e.event_case());
      if (e.has_started()) s += "(" + e.started().worker() + ")";
      if (e.has_failed()) s += "(" + e.failed().message() + ")";
    }
    return s;
  }
};

template <class Reader>
History read_history(Reader& reader, const std::function<void(const v1::JobEvent&)>& on_event) {
  History h;
  v1::JobEvent event;
  while (reader.Read(&event)) {
    if (event.has_result()) h.result += event.result().data();
    h.events.push_back(event);
    if (on_event) on_event(event);
  }
  h.status = reader.Finish();
  return h;
}

// Remesh: upload, then follow the job to its end on the same stream.
// `context` (optional) lets the test cancel the call.
History remesh_job(v1::RemeshService::Stub& stub, const Input& input,
                   const std::function<void(const v1::JobEvent&)>& on_event = {},
                   grpc::ClientContext* context = nullptr) {
  grpc::ClientContext local;
  if (!context) context = &local;
  context->set_deadline(std::chrono::system_clock::now() + kJobLimit);
  auto stream = stub.Remesh(context);
  upload(*stream, input.spec(), input.draco);
  return read_history(*stream, on_event);
}

// Submit: the job's id, or the call's error.
grpc::Status submit_job(v1::RemeshService::Stub& stub, const v1::JobSpec& spec, const std::vector<uint8_t>& bytes,
                        std::string* job_id) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  v1::JobRef ref;
  auto writer = stub.Submit(&context, &ref);
  upload(*writer, spec, bytes);
  grpc::Status status = writer->Finish();
  *job_id = ref.job_id();
  return status;
}

// Watch from event `from_sequence` to the job's end.
History watch_job(v1::RemeshService::Stub& stub, const std::string& job_id, grpc::ClientContext* context = nullptr,
                  uint64_t from_sequence = 0) {
  grpc::ClientContext local;
  if (!context) context = &local;
  context->set_deadline(std::chrono::system_clock::now() + kJobLimit);
  v1::JobRef ref;
  ref.set_job_id(job_id);
  ref.set_from_sequence(from_sequence);
  auto reader = stub.Watch(context, ref);
  return read_history(*reader, {});
}

// Cancels calls still running when a test stops early (a failed ASSERT), so
// that the futures waiting on them do not hold the test until the deadline.
// Declare it after the futures: it is destroyed first.
class CancelOnExit {
 public:
  explicit CancelOnExit(std::vector<grpc::ClientContext*> contexts) : contexts_(std::move(contexts)) {}
  ~CancelOnExit() {
    for (grpc::ClientContext* c : contexts_) c->TryCancel();
  }

 private:
  std::vector<grpc::ClientContext*> contexts_;
};

// grpc.health.v1 Check; UNKNOWN when the call fails. With a Redis queue the
// service's status is readiness (NOT_SERVING while Redis is unreachable) and
// the process's ("") liveness (SERVING: a restart would not bring Redis back).
constexpr const char* kService = "vpremesh.v1.RemeshService";
HealthCheckResponse::ServingStatus health(const std::string& address, const std::string& service = kService) {
  auto stub = grpc::health::v1::Health::NewStub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  grpc::health::v1::HealthCheckRequest request;
  request.set_service(service);
  HealthCheckResponse response;
  if (!stub->Check(&context, request, &response).ok()) return HealthCheckResponse::UNKNOWN;
  return response.status();
}

// Polls until `done()` holds (a state change is what the test waits for, not
// a duration); false after the safety limit.
bool wait_until(const std::function<bool()>& done, std::chrono::seconds limit = kJobLimit) {
  const auto give_up = Clock::now() + limit;
  while (!done()) {
    if (Clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  return true;
}

// The harness's premise: Redis started the way every test starts it keeps
// what it acknowledged through a SIGKILL and comes back with it on the same
// port and dir.
TEST_F(RedisEndToEndTest, RedisKeepsItsDataThroughSigkill) {
  {
    RedisClient redis(redis_->port());
    ASSERT_TRUE(redis.connected()) << redis.error();
    auto added = redis.command({"XADD", "vpremesh:test", "*", "job", "j1"});
    ASSERT_TRUE(added && !added->is_error()) << (added ? added->str : redis.error());
    ASSERT_TRUE(redis.command({"HSET", "vpremesh:job:j1", "state", "queued"}));
  }
  redis_->kill();
  EXPECT_FALSE(RedisClient(redis_->port()).connected());
  ASSERT_TRUE(redis_->start()) << redis_->log();
  RedisClient redis(redis_->port());
  auto entries = redis.command({"XRANGE", "vpremesh:test", "-", "+"});
  ASSERT_TRUE(entries && entries->elements.size() == 1) << redis_->log();
  EXPECT_EQ(entries->elements[0].elements.at(1).field("job"), "j1");
  auto state = redis.command({"HGET", "vpremesh:job:j1", "state"});
  ASSERT_TRUE(state);
  EXPECT_EQ(state->str, "queued");
}

// One sample of the /metrics page of a process that printed where it serves
// them; -1 when it cannot be read.
double scrape(const std::string& log, const std::string& name) {
  const int port = testing::metrics_port(log);
  return port ? testing::sample(testing::http_get(port, "/metrics"), name) : -1;
}

// Two server replicas, three worker processes, 30 jobs from six clients
// (four threads on the stubs, two running `vpremesh submit`) spread over both
// replicas: every job completes once, every result is the oracle's file byte
// for byte, and more than one worker process ran them.
TEST_F(RedisEndToEndTest, ThirtyJobsOverTwoReplicasAndThreeWorkers) {
  std::vector<Input> inputs = small_inputs();
  ASSERT_FALSE(HasFatalFailure());
  ServerProcess *a = nullptr, *b = nullptr;
  const std::vector<std::string> kMetricsFlags = {"--metrics-listen", "127.0.0.1:0"};
  ASSERT_NO_FATAL_FAILURE(start_replicas(&a, &b, kMetricsFlags));
  const std::vector<std::string> replicas = {a->address(), b->address()};
  for (int i = 0; i < 3; ++i) ASSERT_READY(start_worker(i == 0 ? kMetricsFlags : std::vector<std::string>{}));
  // A replica runs no worker, yet counts every worker process's thread.
  EXPECT_TRUE(wait_until([&] { return scrape(a->log(), "vpremesh_queue_workers") == 3; }, std::chrono::seconds(10)))
      << scrape(a->log(), "vpremesh_queue_workers") << "\n"
      << a->log();
  EXPECT_EQ(scrape(a->log(), "vpremesh_workers"), 0);
  EXPECT_EQ(scrape(workers_[0]->log(), "vpremesh_workers"), 1) << workers_[0]->log();  // its liveness probe
  std::set<pid_t> worker_pids;
  for (const auto& w : workers_) worker_pids.insert(w->pid());

  constexpr int kStubThreads = 4, kStubJobs = 6, kCliThreads = 2, kCliJobs = 3;
  struct Done {
    std::string job_id, server, worker, result;
    int input = 0, started = 0, completed = 0;
    std::string problem;  // empty when the job went as it should
  };
  std::mutex mutex;
  std::vector<Done> done;
  const auto start = Clock::now();
  std::vector<std::thread> clients;
  for (int t = 0; t < kStubThreads; ++t)
    clients.emplace_back([&, t] {
      for (int j = 0; j < kStubJobs; ++j) {
        const int server = (t + j) % 2, which = (t + 2 * j) % 3;
        auto stub = make_stub(replicas[server]);
        History h = remesh_job(*stub, inputs[which]);
        Done d{h.events.empty() ? "" : h.events[0].job_id(),
               replicas[server],
               "",
               h.result,
               which,
               h.started(),
               h.completed(),
               ""};
        for (const auto& e : h.events)
          if (e.has_started()) d.worker = e.started().worker();
        if (!h.status.ok() || !h.result_chunks_once()) d.problem = h.describe();
        std::lock_guard<std::mutex> lock(mutex);
        done.push_back(d);
      }
    });
  for (int t = 0; t < kCliThreads; ++t)
    clients.emplace_back([&, t] {
      for (int j = 0; j < kCliJobs; ++j) {
        const int server = (t + j) % 2, which = (t + j) % 3;
        const std::string out = path("cli_" + std::to_string(t) + "_" + std::to_string(j) + ".drc");
        std::vector<std::string> args = {VPR_CLI_PATH, "submit",   path(inputs[which].name), "-o", out,
                                         "--json",     "--server", replicas[server]};
        for (const std::string& f : inputs[which].flags()) args.push_back(f);
        ChildProcess cli(args);
        const int code = cli.wait(kJobLimit);
        // stdout and stderr together: the JSON report is the one object in it.
        const std::string output = cli.output();
        Done d{"", replicas[server], "", read_file(out), which, 1, 1, ""};
        const size_t open = output.find('{'), close = output.rfind('}');
        const nlohmann::json report = open < close
                                          ? nlohmann::json::parse(output.substr(open, close - open + 1), nullptr, false)
                                          : nlohmann::json();
        if (code != 0) {
          d.problem = "exit " + std::to_string(code) + ": " + output;
        } else if (!report.is_object()) {
          d.problem = "no JSON report: " + output;
        } else {
          d.job_id = report.value("job_id", "");
          d.worker = report.value("worker", "");
        }
        std::lock_guard<std::mutex> lock(mutex);
        done.push_back(d);
      }
    });
  for (auto& c : clients) c.join();
  const double wall = seconds_since(start);

  constexpr int kJobs = kStubThreads * kStubJobs + kCliThreads * kCliJobs;
  ASSERT_EQ(done.size(), size_t(kJobs));
  std::set<std::string> ids;
  std::map<pid_t, int> jobs_per_worker;
  std::map<std::string, int> jobs_per_server;
  for (const Done& d : done) {
    ASSERT_EQ(d.problem, "") << d.job_id << " on " << d.server << "\n" << all_logs();
    EXPECT_EQ(d.started, 1) << d.job_id << ": ran more than once with no worker lost";
    EXPECT_EQ(d.completed, 1) << d.job_id;
    EXPECT_FALSE(d.job_id.empty());
    EXPECT_TRUE(d.result == inputs[d.input].expected)
        << d.job_id << " (" << inputs[d.input].name << "): " << d.result.size() << " bytes, the oracle's "
        << inputs[d.input].expected.size();
    ids.insert(d.job_id);
    const pid_t pid = worker_pid(d.worker);
    EXPECT_TRUE(worker_pids.count(pid)) << d.job_id << " ran on " << d.worker << ", not one of our workers";
    ++jobs_per_worker[pid];
    ++jobs_per_server[d.server];
  }
  EXPECT_EQ(ids.size(), size_t(kJobs));
  EXPECT_GE(jobs_per_worker.size(), 2u) << "every job ran on one worker process";
  EXPECT_EQ(jobs_per_server.size(), 2u);

  // Idle workers stop at once on SIGTERM, with exit code 0, and leave the
  // count at once.
  // A worker marks itself idle just after its `completed` is written.
  EXPECT_TRUE(
      wait_until([&] { return scrape(a->log(), "vpremesh_queue_busy_workers") == 0; }, std::chrono::seconds(5)));
  // The first worker's own count (absent until its first job).
  const double succeeded = scrape(workers_[0]->log(), "vpremesh_jobs_finished_total{state=\"succeeded\"}");
  EXPECT_EQ(std::max(succeeded, 0.0), jobs_per_worker[workers_[0]->pid()]);
  for (auto& w : workers_) EXPECT_EQ(w->terminate(), 0) << w->log();
  EXPECT_EQ(scrape(a->log(), "vpremesh_queue_workers"), 0);

  std::string spread;
  for (const auto& [pid, n] : jobs_per_worker) spread += " " + std::to_string(n);
  std::printf(
      "[scaling] %d jobs (2 replicas, 3 workers x concurrency 1, %u cores): %.2f s wall, %.2f jobs/s; "
      "jobs per worker:%s\n",
      kJobs, std::thread::hardware_concurrency(), wall, kJobs / wall, spread.c_str());
}

// kill -9 of the worker running a job: another worker reclaims it after the
// visibility timeout and runs it again. The job completes once, with the
// oracle's result: two `started` events (different pids), one `completed`,
// the result's chunks once, in the live stream and in Watch's replay alike.
TEST_F(RedisEndToEndTest, KilledWorkersJobCompletesOnAnotherWorkerOnce) {
  const Input input = long_input();
  ASSERT_FALSE(HasFatalFailure());
  ServerProcess* server = start_server();
  ASSERT_STARTED(server, "server");
  const std::vector<std::string> flags = {"--visibility-timeout", "2", "--heartbeat", "0.5"};
  ASSERT_READY(start_worker(flags));
  ASSERT_READY(start_worker(flags));
  auto stub = make_stub(server->address());

  // The pid in the first `started` event (-1 when the stream ended without one).
  std::promise<pid_t> first_worker;
  Clock::time_point restarted_at, completed_at;
  grpc::ClientContext context;
  auto job = std::async(std::launch::async, [&] {
    int started = 0;
    History h = remesh_job(
        *stub, input,
        [&](const v1::JobEvent& e) {
          if (e.has_started() && started++ == 0) first_worker.set_value(worker_pid(e.started().worker()));
          if (e.has_started() && started == 2) restarted_at = Clock::now();
          if (e.has_completed()) completed_at = Clock::now();
        },
        &context);
    if (started == 0) first_worker.set_value(-1);
    return h;
  });
  CancelOnExit cancel({&context});
  auto first = first_worker.get_future();
  ASSERT_EQ(first.wait_for(kJobLimit), std::future_status::ready) << all_logs();
  const pid_t victim_pid = first.get();
  WorkerProcess* victim = worker_with_pid(victim_pid);
  ASSERT_NE(victim, nullptr) << "started on pid " << victim_pid << ", not one of our workers\n" << all_logs();
  victim->kill(SIGKILL);
  const auto killed_at = Clock::now();
  EXPECT_EQ(victim->wait(), -SIGKILL);

  const History live = job.get();
  ASSERT_TRUE(live.status.ok()) << live.describe() << "\n" << all_logs();
  ASSERT_TRUE(live.last() && live.last()->has_completed()) << live.describe();
  EXPECT_EQ(live.completed(), 1) << live.describe();
  ASSERT_EQ(live.started(), 2) << live.describe();
  const std::vector<pid_t> pids = live.worker_pids();
  EXPECT_EQ(pids[0], victim_pid);
  EXPECT_NE(pids[1], victim_pid);
  EXPECT_NE(worker_with_pid(pids[1]), nullptr) << live.describe();
  EXPECT_TRUE(live.result_chunks_once()) << live.describe();
  EXPECT_TRUE(live.result == input.expected) << live.result.size() << " bytes, the oracle's " << input.expected.size();
  EXPECT_TRUE(live.sequences_from(0)) << live.describe();

  // The stored history says the same.
  const History replay = watch_job(*stub, live.events[0].job_id());
  ASSERT_TRUE(replay.status.ok()) << replay.describe();
  EXPECT_EQ(replay.started(), 2) << replay.describe();
  EXPECT_EQ(replay.completed(), 1) << replay.describe();
  EXPECT_TRUE(replay.result_chunks_once()) << replay.describe();
  EXPECT_TRUE(replay.result == input.expected);
  EXPECT_TRUE(replay.sequences_from(0)) << replay.describe();
  EXPECT_EQ(get_job(*stub, live.events[0].job_id()).state(), v1::JOB_STATE_SUCCEEDED);
  // JobRef.from_sequence: the replay from the second `started` on.
  uint64_t second_start = 0;
  for (const auto& e : replay.events)
    if (e.has_started()) second_start = e.sequence();
  const History tail = watch_job(*stub, live.events[0].job_id(), nullptr, second_start);
  ASSERT_TRUE(tail.status.ok()) << tail.describe();
  EXPECT_TRUE(tail.sequences_from(second_start)) << tail.describe();
  EXPECT_EQ(tail.events.size(), replay.events.size() - second_start) << tail.describe();
  EXPECT_EQ(tail.started(), 1) << tail.describe();
  EXPECT_TRUE(tail.result == input.expected);

  auto since_kill = [&](Clock::time_point t) { return std::chrono::duration<double>(t - killed_at).count(); };
  std::printf(
      "[scaling] kill -9 of the worker running a job: started again on another worker %.2f s later, completed "
      "%.2f s later (--visibility-timeout 2 --heartbeat 0.5; the second run took %.2f s)\n",
      since_kill(restarted_at), since_kill(completed_at), live.last()->completed().run_ms() / 1000.0);
}

// SIGTERM to a worker in the middle of a job: it finishes the job (one
// `started`, the oracle's result), then exits 0.
TEST_F(RedisEndToEndTest, SigtermedWorkerFinishesItsJobThenExits) {
  const Input input = long_input();
  ASSERT_FALSE(HasFatalFailure());
  ServerProcess* server = start_server();
  ASSERT_STARTED(server, "server");
  WorkerProcess* worker = start_worker({"--visibility-timeout", "2", "--heartbeat", "0.5"});
  ASSERT_READY(worker);
  auto stub = make_stub(server->address());

  std::promise<void> started;
  grpc::ClientContext context;
  auto job = std::async(std::launch::async, [&] {
    bool signalled = false;
    History h = remesh_job(
        *stub, input,
        [&](const v1::JobEvent& e) {
          if (e.has_started() && !signalled) {
            signalled = true;
            started.set_value();
          }
        },
        &context);
    if (!signalled) started.set_value();
    return h;
  });
  CancelOnExit cancel({&context});
  ASSERT_EQ(started.get_future().wait_for(kJobLimit), std::future_status::ready);
  worker->kill(SIGTERM);
  const History h = job.get();
  EXPECT_EQ(worker->wait(), 0) << worker->log();
  ASSERT_TRUE(h.status.ok()) << h.describe() << "\n" << all_logs();
  EXPECT_EQ(h.started(), 1) << h.describe();
  EXPECT_EQ(h.completed(), 1) << h.describe();
  EXPECT_EQ(h.worker_pids(), std::vector<pid_t>{worker->pid()}) << h.describe();
  EXPECT_TRUE(h.result == input.expected);
}

// Redis dies (SIGKILL) with six jobs queued and no worker: Submit fails
// UNAVAILABLE naming Redis unreachable, the service's health turns
// NOT_SERVING (the process's stays SERVING); Redis restarts on the same port
// and dir (AOF), the replicas serve again, and a worker started then
// completes every job with the oracle's result.
TEST_F(RedisEndToEndTest, QueuedJobsSurviveARedisRestart) {
  std::vector<Input> inputs = small_inputs();
  ASSERT_FALSE(HasFatalFailure());
  ServerProcess *a = nullptr, *b = nullptr;
  ASSERT_NO_FATAL_FAILURE(start_replicas(&a, &b));
  const std::vector<std::string> replicas = {a->address(), b->address()};
  std::vector<std::unique_ptr<v1::RemeshService::Stub>> stubs;
  for (const auto& r : replicas) stubs.push_back(make_stub(r));

  constexpr int kJobs = 6;
  std::vector<std::string> jobs(kJobs);
  for (int i = 0; i < kJobs; ++i) {
    const Input& input = inputs[i % 3];
    grpc::Status s = submit_job(*stubs[i % 2], input.spec(), input.draco, &jobs[i]);
    ASSERT_TRUE(s.ok()) << s.error_message() << "\n" << all_logs();
    EXPECT_EQ(get_job(*stubs[(i + 1) % 2], jobs[i]).state(), v1::JOB_STATE_QUEUED) << jobs[i];
  }

  for (const auto& r : replicas) EXPECT_EQ(health(r), HealthCheckResponse::SERVING) << r;

  redis_->kill();
  const auto down_at = Clock::now();
  std::string ignored;
  grpc::Status refused = submit_job(*stubs[0], inputs[0].spec(), inputs[0].draco, &ignored);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAVAILABLE) << refused.error_message();
  EXPECT_NE(refused.error_message().find("unreachable"), std::string::npos) << refused.error_message();
  for (const auto& r : replicas) {
    EXPECT_TRUE(wait_until([&] { return health(r) == HealthCheckResponse::NOT_SERVING; }, std::chrono::seconds(60)))
        << r << " still answers " << health(r);
    EXPECT_EQ(health(r, ""), HealthCheckResponse::SERVING) << r << ": liveness";
  }
  const double noticed = seconds_since(down_at);

  const auto restart_at = Clock::now();
  ASSERT_TRUE(redis_->start()) << redis_->log();
  const double redis_ready = seconds_since(restart_at);
  for (const auto& r : replicas)
    EXPECT_TRUE(wait_until([&] { return health(r) == HealthCheckResponse::SERVING; }, std::chrono::seconds(60)))
        << r << " answers " << health(r) << "\n"
        << all_logs();
  const double serving = seconds_since(restart_at);
  for (int i = 0; i < kJobs; ++i)
    EXPECT_EQ(get_job(*stubs[i % 2], jobs[i]).state(), v1::JOB_STATE_QUEUED) << jobs[i] << "\n" << all_logs();

  const auto worker_at = Clock::now();
  ASSERT_READY(start_worker());
  std::vector<grpc::ClientContext> contexts(kJobs);
  std::vector<std::future<History>> watches;
  for (int i = 0; i < kJobs; ++i)
    watches.push_back(
        std::async(std::launch::async, [&, i] { return watch_job(*stubs[(i + 1) % 2], jobs[i], &contexts[i]); }));
  std::vector<grpc::ClientContext*> calls;
  for (auto& c : contexts) calls.push_back(&c);
  CancelOnExit cancel(calls);
  for (int i = 0; i < kJobs; ++i) {
    const History h = watches[i].get();
    ASSERT_TRUE(h.status.ok()) << jobs[i] << ": " << h.describe() << "\n" << all_logs();
    EXPECT_EQ(h.completed(), 1) << h.describe();
    EXPECT_EQ(h.started(), 1) << h.describe();
    EXPECT_TRUE(h.result_chunks_once()) << h.describe();
    EXPECT_TRUE(h.result == inputs[i % 3].expected)
        << jobs[i] << ": " << h.result.size() << " bytes, the oracle's " << inputs[i % 3].expected.size();
  }
  const double drained = seconds_since(worker_at);
  std::printf(
      "[scaling] Redis SIGKILL with %d jobs queued: replicas NOT_SERVING %.2f s after; restart (AOF load) "
      "%.2f s; replicas SERVING %.2f s after the restart; the %d jobs done %.2f s after a worker started\n",
      kJobs, noticed, redis_ready, serving, kJobs, drained);
}

// Redis dies (SIGKILL) while a worker runs a job and another waits for
// work, and comes back (AOF) a few seconds later. The running worker keeps
// working (its stage events are lost, its heartbeats fail) and retries its
// final write with backoff; the idle worker retries its claim with backoff.
// The job ends once, on its first delivery, with the oracle's result, and
// `vpremesh watch` (started before the outage) writes it. The idle worker
// reconnects, and a job submitted after the restart completes.
TEST_F(RedisEndToEndTest, WorkersRideOutARedisRestartMidJob) {
  const Input long_job = long_input();
  Input after{"sphere.drc", lossless_draco(icosphere(4)), 400, 1};  // one oracle, not small_inputs()'s three
  prepare(after);
  ASSERT_FALSE(HasFatalFailure());
  ServerProcess* server = start_server();
  ASSERT_STARTED(server, "server");
  ASSERT_READY(start_worker({"--heartbeat", "0.5"}));
  ASSERT_READY(start_worker({"--heartbeat", "0.5"}));
  auto stub = make_stub(server->address());

  std::string id;
  ASSERT_TRUE(submit_job(*stub, long_job.spec(), long_job.draco, &id).ok()) << all_logs();
  ChildProcess* watch = start_client({"watch", id, "-o", path("watched.drc"), "--server", server->address()});
  ASSERT_TRUE(watch->wait_for_text(": started on", kJobLimit)) << all_logs();
  const v1::JobStatus running = get_job(*stub, id);
  ASSERT_EQ(running.state(), v1::JOB_STATE_RUNNING) << "the job ended before Redis died";
  const pid_t busy_pid = worker_pid(running.worker());

  redis_->kill();
  const auto down_at = Clock::now();
  // Longer than the job's remaining run on two idle cores: its worker most
  // likely finishes while Redis is away and must retry the final write.
  std::this_thread::sleep_for(std::chrono::seconds(4));
  ASSERT_TRUE(redis_->start()) << redis_->log();
  const double outage = seconds_since(down_at);
  const auto back_at = Clock::now();

  EXPECT_EQ(watch->wait(kJobLimit), 0) << all_logs();
  const double watched = seconds_since(back_at);
  EXPECT_TRUE(read_file(path("watched.drc")) == long_job.expected) << all_logs();
  const History h = watch_job(*stub, id);
  ASSERT_TRUE(h.status.ok()) << h.describe() << "\n" << all_logs();
  EXPECT_EQ(h.started(), 1) << "delivered again after the restart: " << h.describe();
  EXPECT_EQ(h.completed(), 1) << h.describe();
  EXPECT_TRUE(h.result_chunks_once()) << h.describe();
  EXPECT_TRUE(h.result == long_job.expected);
  EXPECT_TRUE(h.sequences_from(0)) << h.describe();
  EXPECT_EQ(get_job(*stub, id).state(), v1::JOB_STATE_SUCCEEDED);

  // The idle worker backed off while Redis was away and claims again
  // (its backoff is at most 5 s).
  WorkerProcess* idle = nullptr;
  for (const auto& w : workers_)
    if (w->pid() != busy_pid) idle = w.get();
  ASSERT_NE(idle, nullptr) << "started on pid " << busy_pid << ", not one of our workers\n" << all_logs();
  EXPECT_NE(idle->log().find("retrying in"), std::string::npos) << "no backoff logged\n" << idle->log();
  EXPECT_TRUE(
      wait_until([&] { return idle->log().find("is reachable again") != std::string::npos; }, std::chrono::seconds(30)))
      << idle->log();
  for (const auto& w : workers_) EXPECT_TRUE(w->running()) << "worker " << w->pid() << " exited\n" << w->log();
  const History next = remesh_job(*stub, after);
  ASSERT_TRUE(next.status.ok()) << next.describe() << "\n" << all_logs();
  EXPECT_TRUE(next.result == after.expected);
  EXPECT_EQ(next.started(), 1) << next.describe();
  std::printf(
      "[scaling] Redis SIGKILL for %.1f s with a job running and a worker idle: the job completed once, on its "
      "first delivery, and the watching client had the result %.2f s after Redis was back\n",
      outage, watched);
}

// A replica dies (SIGKILL) while `vpremesh submit` and `vpremesh watch`,
// both given --server A,B, follow a running job through it: both re-attach
// on B, write the oracle's result and exit 0.
TEST_F(RedisEndToEndTest, ClientsReattachToTheOtherReplicaWhenOneDies) {
  const Input input = long_input();
  ASSERT_FALSE(HasFatalFailure());
  ServerProcess *a = nullptr, *b = nullptr;
  ASSERT_NO_FATAL_FAILURE(start_replicas(&a, &b));
  ASSERT_READY(start_worker());
  const std::string both = a->address() + "," + b->address();

  std::vector<std::string> submit_args = {"submit", path(input.name), "-o", path("submitted.drc"), "--server", both};
  for (const std::string& f : input.flags()) submit_args.push_back(f);
  ChildProcess* submit = start_client(submit_args);
  // "job ID: queued, N jobs ahead": the id, then the job on a worker.
  ASSERT_TRUE(submit->wait_for_text(": queued", kJobLimit)) << all_logs();
  const std::string out = submit->output();
  const size_t at = out.find("job ");
  ASSERT_NE(at, std::string::npos) << out;
  const std::string job = out.substr(at + 4, out.find(':', at) - at - 4);
  ChildProcess* watch = start_client({"watch", job, "-o", path("watched.drc"), "--server", both});
  ASSERT_TRUE(submit->wait_for_text(": started on", kJobLimit)) << all_logs();
  ASSERT_TRUE(watch->wait_for_text(": started on", kJobLimit)) << all_logs();
  auto stub_b = make_stub(b->address());
  ASSERT_EQ(get_job(*stub_b, job).state(), v1::JOB_STATE_RUNNING) << "the job ended before the replica died";
  a->kill(SIGKILL);
  EXPECT_EQ(a->wait(), -SIGKILL);

  EXPECT_EQ(submit->wait(kJobLimit), 0) << all_logs();
  EXPECT_EQ(watch->wait(kJobLimit), 0) << all_logs();
  EXPECT_NE(submit->output().find(b->address()), std::string::npos) << "no word of re-attaching on B\n"
                                                                    << submit->output();
  EXPECT_NE(watch->output().find(b->address()), std::string::npos) << "no word of re-attaching on B\n"
                                                                   << watch->output();
  EXPECT_TRUE(read_file(path("submitted.drc")) == input.expected);
  EXPECT_TRUE(read_file(path("watched.drc")) == input.expected);
  const History h = watch_job(*stub_b, job);
  EXPECT_EQ(h.started(), 1) << h.describe();
  EXPECT_EQ(h.completed(), 1) << h.describe();
}

// A job that crashes its job process (VPREMESH_FAULT_CRASH_ON_LABEL: abort()
// right after `started`) shares one worker (--concurrency 2) with a normal
// job. The crash costs the poison job alone: it fails at its first delivery,
// not retried, naming the signal and the stage, and lands in vpremesh:dead
// with them; the worker process lives on with the same pid; the normal job
// completes with the oracle's result and is never dead-lettered.
TEST_F(RedisEndToEndTest, CrashingJobIsDeadLetteredAloneAndItsWorkerLivesOn) {
  std::vector<Input> inputs = small_inputs();
  ASSERT_FALSE(HasFatalFailure());
  ServerProcess* server = start_server();
  ASSERT_STARTED(server, "server");
  const std::vector<std::string> flags = {"--device", "cpu", "--concurrency", "2", "--renderer", "osmesa"};
  workers_.push_back(
      std::make_unique<WorkerProcess>(redis_->url(), flags, std::vector<std::string>{"VPREMESH_FAULT_CRASH_ON_LABEL=poison"}));
  WorkerProcess* worker = workers_.back().get();
  ASSERT_READY(worker);
  const pid_t worker_pid_before = worker->pid();
  auto stub = make_stub(server->address());

  std::string poison, normal;
  ASSERT_TRUE(submit_job(*stub, inputs[0].spec("poison"), inputs[0].draco, &poison).ok()) << all_logs();
  ASSERT_TRUE(submit_job(*stub, inputs[1].spec("normal"), inputs[1].draco, &normal).ok()) << all_logs();
  const History p = watch_job(*stub, poison);
  const History n = watch_job(*stub, normal);

  ASSERT_TRUE(p.last() && p.last()->has_failed()) << p.describe() << "\n" << all_logs();
  const std::string message = p.last()->failed().message();
  EXPECT_NE(message.find("the remesh process died on this job: SIGABRT in stage "), std::string::npos) << message;
  EXPECT_NE(message.find("not retried"), std::string::npos) << message;
  EXPECT_EQ(p.started(), 1) << p.describe();
  EXPECT_EQ(p.completed(), 0);
  EXPECT_EQ(get_job(*stub, poison).state(), v1::JOB_STATE_FAILED);

  ASSERT_TRUE(n.status.ok()) << n.describe() << "\n" << all_logs();
  EXPECT_EQ(n.completed(), 1);
  EXPECT_EQ(n.started(), 1) << n.describe();
  EXPECT_TRUE(n.result == inputs[1].expected);
  // Both ran on this one worker process, which is still the same and alive.
  ASSERT_EQ(p.worker_pids().size(), 1u);
  EXPECT_EQ(p.worker_pids()[0], worker_pid_before);
  EXPECT_EQ(n.worker_pids()[0], worker_pid_before);
  EXPECT_FALSE(worker->exit_code().has_value()) << all_logs();

  RedisClient redis(redis_->port());
  auto dead = redis.command({"XRANGE", "vpremesh:dead", "-", "+"});
  ASSERT_TRUE(dead) << redis.error();
  int poison_entries = 0, normal_entries = 0;
  for (const RedisReply& entry : dead->elements) {
    if (entry.elements.size() != 2) continue;
    const RedisReply& fields = entry.elements[1];
    if (fields.field("job") == normal) ++normal_entries;
    if (fields.field("job") != poison) continue;
    ++poison_entries;
    const std::string reason = fields.field("reason").value_or("");
    EXPECT_NE(reason.find("SIGABRT in stage "), std::string::npos) << reason;
    EXPECT_EQ(fields.field("deliveries").value_or(""), "1");
  }
  EXPECT_EQ(poison_entries, 1) << dead->elements.size() << " entries in vpremesh:dead";
  EXPECT_EQ(normal_entries, 0);

  // The worker goes on: its next job completes.
  const History next = remesh_job(*stub, inputs[2]);
  ASSERT_TRUE(next.status.ok()) << next.describe() << "\n" << all_logs();
  EXPECT_TRUE(next.result == inputs[2].expected);
  EXPECT_EQ(worker->pid(), worker_pid_before);
}

// Cancellation crosses hosts: a job submitted through replica A and running
// on a worker process is cancelled through replica B; the worker stops at
// its next stage boundary, the job ends CANCELLED with B's reason, and the
// worker goes on to run the next job.
TEST_F(RedisEndToEndTest, CancelThroughAnotherReplicaStopsTheRunningJob) {
  const Input long_job = long_input();
  std::vector<Input> inputs = small_inputs();
  ASSERT_FALSE(HasFatalFailure());
  ServerProcess *a = nullptr, *b = nullptr;
  ASSERT_NO_FATAL_FAILURE(start_replicas(&a, &b));
  ASSERT_READY(start_worker());
  auto stub_a = make_stub(a->address());
  auto stub_b = make_stub(b->address());

  std::string id;
  ASSERT_TRUE(submit_job(*stub_a, long_job.spec(), long_job.draco, &id).ok()) << all_logs();
  ASSERT_TRUE(wait_until([&] { return get_job(*stub_a, id).state() == v1::JOB_STATE_RUNNING; })) << all_logs();
  grpc::ClientContext context;
  v1::JobRef ref;
  ref.set_job_id(id);
  v1::JobStatus after;
  ASSERT_TRUE(stub_b->CancelJob(&context, ref, &after).ok());
  // Asked: the worker stops at its next check, which may come before
  // CancelJob reads the state back.
  EXPECT_TRUE(after.state() == v1::JOB_STATE_RUNNING || after.state() == v1::JOB_STATE_CANCELLED)
      << v1::JobState_Name(after.state());

  const History h = watch_job(*stub_a, id);
  ASSERT_TRUE(h.last() && h.last()->has_cancelled()) << h.describe() << "\n" << all_logs();
  EXPECT_EQ(h.status.error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_NE(h.last()->cancelled().message().find("CancelJob"), std::string::npos) << h.last()->cancelled().message();
  EXPECT_EQ(h.completed(), 0);
  EXPECT_EQ(get_job(*stub_b, id).state(), v1::JOB_STATE_CANCELLED);

  const History next = remesh_job(*stub_b, inputs[0]);
  ASSERT_TRUE(next.status.ok()) << next.describe() << "\n" << all_logs();
  EXPECT_TRUE(next.result == inputs[0].expected);
}

// Tenants across replicas: the owner is stored with the job in Redis, so
// tenant beta cannot get, watch or cancel alpha's job through the other
// replica either (NOT_FOUND), while alpha follows it there to its result;
// and alpha's quota (max_jobs=1) counts its jobs on every replica.
TEST_F(RedisEndToEndTest, TenantsSeeOnlyTheirOwnJobsOnEveryReplica) {
  const Input long_job = long_input();
  ASSERT_FALSE(HasFatalFailure());
  const std::string a_token = "alpha-token-9c2e", b_token = "beta-token-5d1f";
  write_tokens(path("tokens"), {{"alpha", a_token + " max_jobs=1"}, {"beta", b_token}});
  ServerProcess *a = nullptr, *b = nullptr;
  ASSERT_NO_FATAL_FAILURE(start_replicas(&a, &b, {"--auth-tokens", path("tokens")}));
  ServerProcess* c = start_server({"--auth-tokens", path("tokens")});
  ASSERT_STARTED(c, "server C");
  auto stub_a = make_stub(a->address());
  auto stub_c = make_stub(c->address());

  std::string id;
  ASSERT_TRUE(submit_as(*stub_a, a_token, long_job.spec(), long_job.draco, &id).ok()) << all_logs();
  EXPECT_EQ(get_job_as(*stub_c, b_token, id).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(watch_as(*stub_c, b_token, id).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(cancel_as(*stub_c, b_token, id).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(get_job_as(*stub_c, "", id).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  v1::JobStatus status;
  ASSERT_TRUE(get_job_as(*stub_c, a_token, id, &status).ok());
  EXPECT_EQ(status.state(), v1::JOB_STATE_QUEUED);  // no worker yet

  // The quota is the tenant's on every replica.
  std::string refused;
  const grpc::Status again = submit_as(*stub_c, a_token, long_job.spec(), long_job.draco, &refused);
  EXPECT_EQ(again.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << again.error_message();
  EXPECT_NE(again.error_message().find("client alpha"), std::string::npos) << again.error_message();

  ASSERT_READY(start_worker());
  std::string result;
  EXPECT_TRUE(watch_as(*stub_c, a_token, id, &result).ok()) << all_logs();
  EXPECT_TRUE(result == long_job.expected);
  for (const auto& server : servers_) {
    EXPECT_EQ(server->log().find(a_token), std::string::npos);
    EXPECT_EQ(server->log().find(b_token), std::string::npos);
  }
}

}  // namespace
}  // namespace vpr::testing
