// RedisQueue against a real redis-server, one call at a time: the state
// changes of server/redis_scripts.h (submit, claim, publish, finish, cancel,
// reclaim, dead letter), priorities, limits, Watch's event reads and a Redis
// restart. tests/redis/ runs the same queue across processes.
#include <gtest/gtest.h>

#include <condition_variable>
#include <future>
#include <thread>
#include <functional>
#include <set>

#include "redis/redis_harness.h"
#include "server/redis_queue.h"
#include "server/service_metrics.h"
#include "server/status_mapping.h"
#include "server/test_submission.h"

namespace vpr::service {
namespace {

using testing::RedisProcess;
using namespace std::chrono_literals;

class RedisQueueTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string executable = testing::find_redis_server();
    ASSERT_FALSE(executable.empty()) << testing::kNoRedisServer;
    const std::string address = testing::closed_loopback_address();
    const int port = std::stoi(address.substr(address.rfind(':') + 1));
    dir_ = std::filesystem::temp_directory_path() /
           ("vpr-redis-unit-" + std::to_string(::getpid()) + "-" + std::to_string(port));
    redis_ = std::make_unique<RedisProcess>(executable, dir_, port);
    ASSERT_TRUE(redis_->start()) << redis_->log();
  }
  void TearDown() override {
    if (redis_) redis_->kill();
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  RedisQueueOptions options() const {
    RedisQueueOptions o;
    o.endpoint = parse_redis_url(redis_->url()).value();
    o.visibility_timeout = 60s;
    o.heartbeat = 10s;
    return o;
  }

  static JobSubmission job(int priority = 0, const std::string& peer = "client-a", const std::string& label = "") {
    return test_submission(priority, peer, label);
  }

  static v1::JobEvent completed() {
    v1::JobEvent e;
    e.mutable_completed()->set_output_vertices(1000);
    return e;
  }

  // Every event of a job, from sequence 0.
  static std::vector<v1::JobEvent> history(RedisQueue& q, const std::string& id) {
    auto batch = q.events(id, 0, 1000);
    EXPECT_TRUE(batch.ok()) << batch.status().to_string();
    return batch.ok() ? batch->events : std::vector<v1::JobEvent>{};
  }

  // claim() blocks while nothing is claimable: give up after `wait`.
  static std::optional<ClaimedJob> claim_within(RedisQueue& q, const std::string& worker,
                                                std::chrono::milliseconds wait) {
    auto f = std::async(std::launch::async, [&] { return q.claim(worker); });
    if (f.wait_for(wait) == std::future_status::timeout) q.close();
    return f.get();
  }

  std::filesystem::path dir_;
  std::unique_ptr<RedisProcess> redis_;
};

TEST(RedisUrl, ParsesHostPortDatabaseAndPassword) {
  auto e = parse_redis_url("redis://:s3cret@cache.internal:6380/2");
  ASSERT_TRUE(e.ok()) << e.status().to_string();
  EXPECT_EQ(e->host, "cache.internal");
  EXPECT_EQ(e->port, 6380);
  EXPECT_EQ(e->db, 2);
  EXPECT_EQ(e->password, "s3cret");
  EXPECT_EQ(e->url(), "redis://cache.internal:6380/2");  // never prints the password
  auto plain = parse_redis_url("redis://10.0.0.5");
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->port, 6379);
  auto acl = parse_redis_url("redis://vpremesh:pa:ss@cache:6380");  // a Redis 6 ACL user
  ASSERT_TRUE(acl.ok()) << acl.status().to_string();
  EXPECT_EQ(acl->user, "vpremesh");
  EXPECT_EQ(acl->password, "pa:ss");
  EXPECT_EQ(acl->url(), "redis://vpremesh@cache:6380");
  auto v6 = parse_redis_url("redis://[::1]:7000");
  ASSERT_TRUE(v6.ok());
  EXPECT_EQ(v6->host, "::1");
  EXPECT_EQ(v6->port, 7000);
}

TEST(RedisUrl, RefusesWhatItCannotUse) {
  for (const char* bad : {"http://h:1", "redis://", "redis://h:0", "redis://h:70000", "redis://h:x",
                          "redis://h:1/db", "redis://user@h:1", "rediss://h:1"}) {
    auto e = parse_redis_url(bad);
    ASSERT_FALSE(e.ok()) << bad;
    EXPECT_NE(e.status().message().find(bad), std::string::npos) << e.status().message();
  }
  auto hidden = parse_redis_url("redis://u:s3cret@h:x");
  ASSERT_FALSE(hidden.ok());
  EXPECT_EQ(hidden.status().message().find("s3cret"), std::string::npos) << hidden.status().message();
}

// An ACL user with a password, as deploy/ runs Redis: AUTH USER PASSWORD.
TEST_F(RedisQueueTest, ConnectsAsARedis6AclUser) {
  RedisClient admin(parse_redis_url(redis_->url()).value());
  ASSERT_TRUE(admin.command({"ACL", "SETUSER", "vpremesh", "on", ">pw-42", "~*", "&*", "+@all"}).ok());
  RedisQueueOptions o = options();
  o.endpoint = parse_redis_url("redis://vpremesh:pw-42@127.0.0.1:" + std::to_string(redis_->port())).value();
  RedisQueue q(o);
  EXPECT_TRUE(q.health().ok()) << q.health().message();
  auto id = q.submit(job());
  EXPECT_TRUE(id.ok()) << id.status().to_string();
  o.endpoint.password = "wrong";
  RedisQueue refused(o);
  EXPECT_FALSE(refused.health().ok());
}

TEST_F(RedisQueueTest, AJobRunsToItsEndWithOrderedEventsAndExpiringKeys) {
  RedisQueue server(options());
  RedisQueue worker(options());
  auto id = server.submit(job());
  ASSERT_TRUE(id.ok()) << id.status().to_string();

  auto claimed = worker.claim("host:1/worker-0");
  ASSERT_TRUE(claimed);
  EXPECT_EQ(claimed->id, *id);
  EXPECT_EQ(claimed->spec.target_vertices(), 1000u);
  EXPECT_EQ(claimed->mesh, job().mesh);
  EXPECT_EQ(server.status(*id)->state(), v1::JOB_STATE_RUNNING);
  EXPECT_EQ(server.status(*id)->worker(), "host:1/worker-0");

  v1::JobEvent started;
  started.mutable_started()->set_worker("host:1/worker-0");
  worker.publish(*id, started);
  v1::JobEvent result;
  result.mutable_result()->set_data("mesh bytes");
  worker.publish(*id, result);  // held until `completed`
  EXPECT_EQ(history(server, *id).size(), 2u);
  worker.publish(*id, completed());

  const auto events = history(server, *id);
  ASSERT_EQ(events.size(), 4u);
  EXPECT_TRUE(events[0].has_queued());
  EXPECT_TRUE(events[1].has_started());
  EXPECT_EQ(events[2].result().data(), "mesh bytes");
  EXPECT_TRUE(events[3].has_completed());
  for (size_t i = 0; i < events.size(); ++i) {
    EXPECT_EQ(events[i].sequence(), i);
    EXPECT_EQ(events[i].job_id(), *id);
  }
  auto tail = server.events(*id, 2, 10);
  ASSERT_TRUE(tail.ok());
  ASSERT_EQ(tail->events.size(), 2u);
  EXPECT_EQ(tail->events[0].sequence(), 2u);
  EXPECT_TRUE(tail->ended);

  auto status = server.status(*id);
  EXPECT_EQ(status->state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(status->summary().output_vertices(), 1000u);
  // Finished: the upload is gone, the job and its events expire with --result-ttl.
  testing::RedisClient redis(redis_->port());
  EXPECT_EQ(redis.command({"EXISTS", "vpremesh:upload:" + *id})->integer, 0);
  const long long ttl = redis.command({"PTTL", "vpremesh:events:" + *id})->integer;
  EXPECT_GT(ttl, 0);
  EXPECT_LE(ttl, 600'000);
  EXPECT_EQ(server.stats().succeeded, 1u);
  EXPECT_EQ(server.stats().queued + server.stats().running, 0u);
}

TEST_F(RedisQueueTest, HigherPriorityRunsFirstThenOldestFirst) {
  RedisQueue q(options());
  const std::string low = q.submit(job(-3)).value();
  const std::string normal_1 = q.submit(job(0, "b")).value();
  const std::string high = q.submit(job(5, "c")).value();
  const std::string normal_2 = q.submit(job(0, "d")).value();
  EXPECT_EQ(q.status(low)->queue_position(), 3u);
  EXPECT_EQ(q.status(normal_2)->queue_position(), 2u);
  EXPECT_EQ(q.status(high)->queue_position(), 0u);
  std::vector<std::string> order;
  for (int i = 0; i < 4; ++i) order.push_back(q.claim("w")->id);
  EXPECT_EQ(order, (std::vector<std::string>{high, normal_1, normal_2, low}));
}

TEST_F(RedisQueueTest, LimitsNameTheirFlags) {
  RedisQueueOptions o = options();
  o.limits.max_queue = 2;
  o.limits.max_jobs_per_client = 1;
  RedisQueue q(o);
  ASSERT_TRUE(q.submit(job(0, "a")).ok());
  auto same_client = q.submit(job(0, "a"));
  ASSERT_FALSE(same_client.ok());
  EXPECT_EQ(same_client.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(same_client.status().message().find("--max-jobs-per-client"), std::string::npos);
  ASSERT_TRUE(q.submit(job(0, "b")).ok());
  auto full = q.submit(job(0, "c"));
  ASSERT_FALSE(full.ok());
  EXPECT_NE(full.status().message().find("--max-queue"), std::string::npos) << full.status().message();
  // A running job no longer counts against the queue.
  ASSERT_TRUE(q.claim("w"));
  EXPECT_TRUE(q.submit(job(0, "c")).ok());
}

TEST_F(RedisQueueTest, CancelEndsAQueuedJobAndAsksARunningOneToStop) {
  RedisQueue server(options());
  RedisQueue worker(options());
  const std::string running = server.submit(job(1)).value();
  const std::string queued = server.submit(job(0, "b")).value();
  ASSERT_EQ(worker.claim("w")->id, running);

  auto c = server.cancel(queued, Status(StatusCode::kCancelled, "not needed"));
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->state(), v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(c->failure().message(), "not needed");
  EXPECT_TRUE(history(server, queued).back().has_cancelled());
  EXPECT_FALSE(claim_within(worker, "w", 1500ms)) << "a cancelled job was delivered";

  EXPECT_FALSE(worker.cancellation(running));
  ASSERT_TRUE(server.cancel(running, Status(StatusCode::kCancelled, "stop it")).ok());
  auto why = worker.cancellation(running);
  ASSERT_TRUE(why);
  EXPECT_EQ(why->code(), StatusCode::kCancelled);
  EXPECT_EQ(why->message(), "stop it");
  EXPECT_EQ(server.cancel("j-unknown", Status(StatusCode::kCancelled, "x")).status().code(), StatusCode::kNotFound);
}

TEST_F(RedisQueueTest, AnAbandonedJobIsReclaimedAndOnlyTheNewOwnerAnswers) {
  RedisQueueOptions o = options();
  o.visibility_timeout = 300ms;
  RedisQueue server(o), first(o), second(o);
  const std::string id = server.submit(job()).value();
  ASSERT_EQ(first.claim("first")->id, id);
  // `first` sends no heartbeat (10 s period): after 300 ms the entry is stale.
  auto again = second.claim("second");
  ASSERT_TRUE(again);
  EXPECT_EQ(again->id, id);
  EXPECT_EQ(again->mesh, job().mesh);

  v1::JobEvent late;
  late.mutable_result()->set_data("stale answer");
  first.publish(id, late);
  // At its next stage boundary the old owner learns it lost the job...
  EXPECT_TRUE(first.cancellation(id)) << "the old owner must learn it lost the job";
  first.publish(id, completed());  // ...and its answer, if it sends one, is refused
  EXPECT_EQ(server.status(id)->state(), v1::JOB_STATE_RUNNING);

  v1::JobEvent fresh;
  fresh.mutable_result()->set_data("answer");
  second.publish(id, fresh);
  second.publish(id, completed());
  const auto events = history(server, id);
  int results = 0, completions = 0;
  for (const auto& e : events) {
    results += e.has_result();
    completions += e.has_completed();
    if (e.has_result()) EXPECT_EQ(e.result().data(), "answer");
  }
  EXPECT_EQ(results, 1);
  EXPECT_EQ(completions, 1);
}

TEST_F(RedisQueueTest, HeartbeatsKeepARunningJobFromBeingReclaimed) {
  RedisQueueOptions o = options();
  o.visibility_timeout = 1000ms;
  o.heartbeat = 100ms;
  RedisQueue server(o), owner(o), other(o);
  const std::string id = server.submit(job()).value();
  ASSERT_TRUE(owner.claim("owner"));
  EXPECT_FALSE(claim_within(other, "other", 2500ms)) << "a job with live heartbeats was taken over";
  EXPECT_FALSE(owner.cancellation(id));
  EXPECT_EQ(server.status(id)->worker(), "owner");
}

// The names in the consumer group of one job stream.
std::set<std::string> group_consumers(RedisClient& redis, const std::string& stream) {
  std::set<std::string> names;
  auto r = redis.command({"XINFO", "CONSUMERS", stream, "workers"});
  EXPECT_TRUE(r.ok()) << r.status().to_string();
  if (!r.ok()) return names;
  for (size_t i = 0; i < array_size(r->get()); ++i) {
    const redisReply* c = element(r->get(), i);
    for (size_t j = 0; j + 1 < array_size(c); j += 2)
      if (as_string(element(c, j)) == "name") names.insert(as_string(element(c, j + 1)));
  }
  return names;
}

bool eventually(const std::function<bool()>& done, std::chrono::milliseconds limit = 5000ms) {
  for (auto until = std::chrono::steady_clock::now() + limit; !done();) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(20ms);
  }
  return true;
}

// Worker threads register when they first claim and with every heartbeat,
// so a server replica that runs no worker still counts the fleet
// (vpremesh_queue_workers) and the busy ones. Starting and ending a job
// changes the busy count at once, not at the next heartbeat (10 s here); a
// worker that exits cleanly leaves the count at once.
TEST_F(RedisQueueTest, ServersCountEveryHostsWorkersAndTheBusyOnes) {
  RedisQueueOptions o = options();
  RedisQueue server(o);
  EXPECT_EQ(server.stats().fleet_workers, std::optional<size_t>(0));
  auto worker = std::make_unique<RedisQueue>(o);
  const std::string id = server.submit(job()).value();
  auto fleet = [&](size_t live, size_t busy) {
    const QueueStats s = server.stats();
    return s.fleet_workers == live && s.fleet_busy == busy;
  };
  ASSERT_TRUE(worker->claim("host-a/worker-0"));
  EXPECT_TRUE(fleet(1, 1)) << server.stats().fleet_workers.value_or(99) << " " << server.stats().fleet_busy.value_or(99);
  auto idle = std::async(std::launch::async, [&] { return worker->claim("host-a/worker-1"); });
  EXPECT_TRUE(eventually([&] { return fleet(2, 1); })) << server.stats().fleet_workers.value_or(99);

  MetricsRegistry registry;
  ServiceMetrics metrics(registry);
  metrics.set_queue(server.stats());
  const std::string text = registry.render();
  EXPECT_NE(text.find("\nvpremesh_queue_workers 2\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\nvpremesh_queue_busy_workers 1\n"), std::string::npos) << text;

  worker->publish(id, completed());
  EXPECT_TRUE(fleet(2, 0));
  worker->close();
  EXPECT_FALSE(idle.get());
  worker.reset();
  EXPECT_TRUE(fleet(0, 0)) << "a clean exit must leave the count at once";
  RedisClient redis(o.endpoint);
  EXPECT_TRUE(group_consumers(redis, "vpremesh:jobs:0").empty());
}

// A killed worker leaves its consumers in the group; a live worker removes
// them once their registration expired, but only once they own no entry
// (deleting a consumer would drop its pending jobs).
TEST_F(RedisQueueTest, KilledWorkersLeaveTheGroupOnceTheirJobsWereReclaimed) {
  RedisQueueOptions o = options();
  o.heartbeat = 100ms;  // visibility stays 60 s: nothing is reclaimed by itself here
  RedisQueue server(o);
  const std::string id = server.submit(job()).value();
  RedisClient redis(o.endpoint);
  const std::string stream = "vpremesh:jobs:0";
  // Two workers that were kill -9'd: one idle, one holding the job.
  ASSERT_TRUE(redis.command({"XGROUP", "CREATECONSUMER", stream, "workers", "ghost-idle"}).ok());
  ASSERT_TRUE(redis.command({"XREADGROUP", "GROUP", "workers", "ghost-busy", "COUNT", "1", "STREAMS", stream, ">"}).ok());
  for (const char* ghost : {"ghost-idle", "ghost-busy"})
    ASSERT_TRUE(redis.command({"ZADD", "vpremesh:workers", "1", ghost}).ok());  // expired long ago

  RedisQueue live(o);
  EXPECT_FALSE(claim_within(live, "live-0", 500ms)) << "the ghost's job is not stale yet";
  EXPECT_TRUE(eventually([&] { return !group_consumers(redis, stream).count("ghost-idle"); }));
  EXPECT_TRUE(group_consumers(redis, stream).count("ghost-busy")) << "removed while it held job " << id;

  // Another worker reclaims the ghost's job: now the ghost goes too.
  auto pending = redis.command({"XPENDING", stream, "workers", "-", "+", "1", "ghost-busy"});
  ASSERT_TRUE(pending.ok() && array_size(pending->get()) == 1);
  const std::string entry = as_string(element(element(pending->get(), 0), 0));
  ASSERT_TRUE(redis.command({"XCLAIM", stream, "workers", "rescuer", "0", entry, "JUSTID"}).ok());
  EXPECT_TRUE(eventually([&] { return !group_consumers(redis, stream).count("ghost-busy"); }));
  EXPECT_TRUE(group_consumers(redis, stream).count("rescuer"));
  auto score = redis.command({"ZSCORE", "vpremesh:workers", "ghost-busy"});
  ASSERT_TRUE(score.ok());
  EXPECT_TRUE(is_nil(score->get()));
  EXPECT_EQ(server.stats().fleet_workers, std::optional<size_t>(1));  // live-0
}

TEST_F(RedisQueueTest, AJobThatKeepsLosingItsWorkerEndsInTheDeadLetterStream) {
  RedisQueueOptions o = options();
  o.visibility_timeout = 100ms;
  o.max_deliveries = 2;
  RedisQueue server(o), a(o), b(o), c(o);
  const std::string id = server.submit(job()).value();
  ASSERT_TRUE(a.claim("a"));
  ASSERT_TRUE(b.claim("b"));  // after 100 ms idle: delivery 2
  EXPECT_FALSE(claim_within(c, "c", 1500ms));  // delivery 3 would pass --max-deliveries: dead instead

  auto status = server.status(id);
  EXPECT_EQ(status->state(), v1::JOB_STATE_FAILED);
  EXPECT_NE(status->failure().message().find("delivered 2 times"), std::string::npos) << status->failure().message();
  EXPECT_NE(status->failure().message().find("dead-letter"), std::string::npos);
  testing::RedisClient redis(redis_->port());
  auto dead = redis.command({"XRANGE", "vpremesh:dead", "-", "+"});
  ASSERT_EQ(dead->elements.size(), 1u);
  EXPECT_EQ(dead->elements[0].elements[1].field("job"), id);
  EXPECT_EQ(dead->elements[0].elements[1].field("deliveries"), "2");
}

TEST_F(RedisQueueTest, ResultsOverTheLimitFailTheJob) {
  RedisQueueOptions o = options();
  o.max_result_bytes = 1000;
  RedisQueue q(o);
  const std::string id = q.submit(job()).value();
  ASSERT_TRUE(q.claim("w"));
  v1::JobEvent big;
  big.mutable_result()->set_data(std::string(2000, 'x'));
  q.publish(id, big);
  q.publish(id, completed());
  auto s = q.status(id);
  EXPECT_EQ(s->state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(s->failure().code(), int(grpc::StatusCode::RESOURCE_EXHAUSTED));
  EXPECT_NE(s->failure().message().find("--max-result-mib"), std::string::npos);
}

TEST_F(RedisQueueTest, SubscribersAreWokenByEventsFromAnotherProcess) {
  RedisQueue server(options()), worker(options());
  const std::string id = server.submit(job()).value();
  std::mutex mu;
  std::condition_variable cv;
  size_t wakes = 0;
  auto token = server.subscribe(id, [&] {
    std::lock_guard<std::mutex> lock(mu);
    ++wakes;
    cv.notify_all();
  });
  ASSERT_TRUE(token.ok());
  ASSERT_TRUE(worker.claim("w"));
  worker.publish(id, completed());
  std::unique_lock<std::mutex> lock(mu);
  EXPECT_TRUE(cv.wait_for(lock, 10s, [&] { return wakes >= 1; }));
  lock.unlock();
  server.unsubscribe(id, *token);
  EXPECT_EQ(server.subscribe("j-nope", [] {}).status().code(), StatusCode::kNotFound);
}

// A Watch reads each event out of Redis once: the watcher's blocking read
// only learns that a stream grew, and the listener reads the events. Measured
// as Redis's own output bytes while one listener follows a 16 MiB result.
TEST_F(RedisQueueTest, AWatchReadsEachEventOutOfRedisOnce) {
  RedisQueue server(options()), worker(options());
  const std::string id = server.submit(job()).value();
  RedisClient redis(options().endpoint);
  auto output_bytes = [&] {
    auto info = redis.command({"INFO", "stats"});
    const std::string text = info.ok() ? as_string(info->get()) : "";
    const std::string key = "total_net_output_bytes:";
    const size_t at = text.find(key);
    return at == std::string::npos ? uint64_t(0) : std::stoull(text.substr(at + key.size()));
  };
  std::mutex mu;
  std::condition_variable cv;
  uint64_t next = 0, read_bytes = 0;
  bool ended = false;
  auto token = server.subscribe(id, [&] {
    std::lock_guard<std::mutex> lock(mu);
    while (!ended) {  // what the service does on a wake: read everything new
      auto batch = server.events(id, next, 64);
      if (!batch.ok() || batch->events.empty()) break;
      for (const auto& e : batch->events) read_bytes += e.result().data().size();
      next += batch->events.size();
      ended = batch->ended;
    }
    cv.notify_all();
  });
  ASSERT_TRUE(token.ok());
  ASSERT_TRUE(worker.claim("w"));
  constexpr size_t kChunk = 1 << 20, kChunks = 16;
  const uint64_t before = output_bytes();
  for (size_t i = 0; i < kChunks; ++i) {
    v1::JobEvent e;
    e.mutable_result()->set_data(std::string(kChunk, char('a' + i)));
    worker.publish(id, e);  // held until `completed`, then written at once
  }
  worker.publish(id, completed());
  {
    std::unique_lock<std::mutex> lock(mu);
    ASSERT_TRUE(cv.wait_for(lock, 30s, [&] { return ended; }));
  }
  server.unsubscribe(id, *token);
  const double ratio = double(output_bytes() - before) / double(kChunk * kChunks);
  EXPECT_EQ(read_bytes, kChunk * kChunks);
  EXPECT_LT(ratio, 1.25) << "Redis sent " << ratio << "x the result for one watcher";
  std::printf("[watch] Redis output for one watcher of a %zu MiB result: %.2fx the result\n", kChunks, ratio);
}

TEST_F(RedisQueueTest, RedisDownIsUnavailableAndQueuedJobsSurviveItsRestart) {
  RedisQueue server(options());
  const std::string id = server.submit(job()).value();
  redis_->kill();
  auto refused = server.submit(job(0, "b"));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kUnavailable);
  EXPECT_NE(refused.status().message().find("unreachable"), std::string::npos) << refused.status().message();
  EXPECT_FALSE(server.health().ok());

  ASSERT_TRUE(redis_->start()) << redis_->log();
  EXPECT_TRUE(server.health().ok());
  RedisQueue worker(options());
  auto claimed = worker.claim("w");
  ASSERT_TRUE(claimed);
  EXPECT_EQ(claimed->id, id);
  EXPECT_EQ(claimed->mesh, job().mesh);
}

// Object storage in miniature: what a BlobStore sees.
class MemoryBlobStore final : public BlobStore {
 public:
  Status put(const std::string& key, std::string_view bytes, std::chrono::milliseconds) override {
    std::lock_guard<std::mutex> lock(mu);
    blobs[key] = std::string(bytes);
    return Status::Ok();
  }
  StatusOr<std::optional<std::string>> get(const std::string& key) override {
    std::lock_guard<std::mutex> lock(mu);
    auto it = blobs.find(key);
    return it == blobs.end() ? std::optional<std::string>() : std::optional<std::string>(it->second);
  }
  Status remove(const std::string& key) override {
    std::lock_guard<std::mutex> lock(mu);
    blobs.erase(key);
    return Status::Ok();
  }
  std::mutex mu;
  std::map<std::string, std::string> blobs;
};

TEST_F(RedisQueueTest, UploadsCanLiveOutsideRedis) {
  auto store = std::make_shared<MemoryBlobStore>();
  RedisQueueOptions o = options();
  o.blobs = store;
  RedisQueue server(o), worker(o);
  const std::string id = server.submit(job()).value();
  testing::RedisClient redis(redis_->port());
  EXPECT_EQ(redis.command({"EXISTS", "vpremesh:upload:" + id})->integer, 0) << "the upload went to Redis";
  ASSERT_EQ(store->blobs.size(), 1u);
  auto claimed = worker.claim("w");
  ASSERT_TRUE(claimed);
  EXPECT_EQ(claimed->mesh, job().mesh);
  worker.publish(id, completed());
  EXPECT_TRUE(store->blobs.empty()) << "the upload outlived its job";
  // A refused submission leaves nothing behind either.
  o.limits.max_queue = 1;
  RedisQueue full(o);
  ASSERT_TRUE(full.submit(job(0, "b")).ok());
  EXPECT_FALSE(full.submit(job(0, "c")).ok());
  EXPECT_EQ(store->blobs.size(), 1u);
}

}  // namespace
}  // namespace vpr::service
