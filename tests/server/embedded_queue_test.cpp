// EmbeddedQueue: ordering, cancellation, event replay, result retention and
// the limits it enforces. No timing: the clock is a variable.
#include "server/embedded_queue.h"
#include "server/test_submission.h"

#include <grpcpp/support/status.h>
#include <gtest/gtest.h>

#include <thread>

namespace vpr::service {
namespace {

struct Fixture {
  Clock::time_point t = Clock::time_point() + std::chrono::hours(1);
  std::vector<std::pair<std::string, v1::JobState>> states;
  EmbeddedQueue queue;

  explicit Fixture(ServerLimits limits = {}, std::chrono::milliseconds ttl = std::chrono::seconds(60))
      : queue(make_options(limits, ttl)) {}

  EmbeddedQueueOptions make_options(ServerLimits limits, std::chrono::milliseconds ttl) {
    EmbeddedQueueOptions o;
    o.limits = limits;
    o.result_ttl = ttl;
    o.now = [this] { return t; };
    o.on_state = [this](const std::string& id, v1::JobState s) { states.emplace_back(id, s); };
    return o;
  }

  std::string submit(int priority, const std::string& peer = "client-a", const std::string& label = "") {
    auto id = queue.submit(test_submission(priority, peer, label));
    EXPECT_TRUE(id.ok()) << id.status().to_string();
    return id.ok() ? *id : "";
  }

  std::vector<v1::JobEvent> all_events(const std::string& id) {
    auto batch = queue.events(id, 0, 1000);
    EXPECT_TRUE(batch.ok());
    return batch.ok() ? batch->events : std::vector<v1::JobEvent>{};
  }
};

v1::JobEvent completed() {
  v1::JobEvent e;
  e.mutable_completed()->set_output_vertices(1000);
  return e;
}

TEST(EmbeddedQueue, ClaimsByPriorityThenSubmissionOrder) {
  Fixture f;
  const std::string low = f.submit(-1), first = f.submit(5), normal = f.submit(0), second = f.submit(5);
  EXPECT_EQ(f.queue.status(second)->queue_position(), 1u);  // behind `first`, ahead of the others
  EXPECT_EQ(f.queue.status(low)->queue_position(), 3u);
  std::vector<std::string> order;
  for (int i = 0; i < 4; ++i) order.push_back(f.queue.claim("w")->id);
  EXPECT_EQ(order, (std::vector<std::string>{first, second, normal, low}));
  EXPECT_EQ(f.queue.status(low)->state(), v1::JOB_STATE_RUNNING);
}

TEST(EmbeddedQueue, QueuedEventCarriesPositionAndClaimHandsOverTheMesh) {
  Fixture f;
  f.submit(0);
  const std::string id = f.submit(0);
  const auto events = f.all_events(id);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_TRUE(events[0].has_queued());
  EXPECT_EQ(events[0].queued().position(), 1u);
  EXPECT_EQ(events[0].job_id(), id);
  f.queue.claim("w");
  auto job = f.queue.claim("w");
  ASSERT_TRUE(job);
  EXPECT_EQ(job->id, id);
  EXPECT_EQ(job->mesh.size(), 8u);
  EXPECT_EQ(job->spec.target_vertices(), 1000u);
}

TEST(EmbeddedQueue, CancelQueuedJobEndsItAndFreesItsPlace) {
  Fixture f;
  const std::string a = f.submit(0), b = f.submit(0);
  auto st = f.queue.cancel(a, Status(StatusCode::kCancelled, "cancelled by test"));
  ASSERT_TRUE(st.ok());
  EXPECT_EQ(st->state(), v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(st->failure().code(), int(grpc::StatusCode::CANCELLED));
  EXPECT_EQ(st->failure().message(), "cancelled by test");
  EXPECT_EQ(f.queue.status(b)->queue_position(), 0u);
  const auto events = f.all_events(a);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_TRUE(events[1].has_cancelled());
  EXPECT_EQ(f.queue.claim("w")->id, b);  // a never runs
  EXPECT_EQ(f.queue.stats().cancelled, 1u);
  EXPECT_EQ(f.states.back(), std::make_pair(b, v1::JOB_STATE_RUNNING));
}

TEST(EmbeddedQueue, CancelRunningJobAsksTheWorkerAndKeepsTheFirstReason) {
  Fixture f;
  const std::string id = f.submit(0);
  f.queue.claim("w");
  EXPECT_FALSE(f.queue.cancellation(id));
  auto st = f.queue.cancel(id, Status(StatusCode::kDeadlineExceeded, "deadline"));
  ASSERT_TRUE(st.ok());
  EXPECT_EQ(st->state(), v1::JOB_STATE_RUNNING);  // until the worker stops
  (void)f.queue.cancel(id, Status(StatusCode::kCancelled, "later"));
  ASSERT_TRUE(f.queue.cancellation(id));
  EXPECT_EQ(f.queue.cancellation(id)->code(), StatusCode::kDeadlineExceeded);
  v1::JobEvent e;
  e.mutable_cancelled()->set_message("deadline");
  f.queue.publish(id, e);
  EXPECT_EQ(f.queue.status(id)->state(), v1::JOB_STATE_CANCELLED);
}

TEST(EmbeddedQueue, CancelFinishedJobChangesNothing) {
  Fixture f;
  const std::string id = f.submit(0);
  f.queue.claim("w");
  f.queue.publish(id, completed());
  auto st = f.queue.cancel(id, Status(StatusCode::kCancelled, "too late"));
  ASSERT_TRUE(st.ok());
  EXPECT_EQ(st->state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(st->summary().output_vertices(), 1000u);
  EXPECT_EQ(f.all_events(id).size(), 2u);
}

TEST(EmbeddedQueue, EventsReplayFromAnySequenceAndEndAtTheTerminalEvent) {
  Fixture f;
  const std::string id = f.submit(0);
  f.queue.claim("w");
  v1::JobEvent started;
  started.mutable_started()->set_worker("w");
  f.queue.publish(id, started);
  for (const char* name : {"views", "render", "meshing"}) {
    v1::JobEvent e;
    e.mutable_stage()->set_name(name);
    f.queue.publish(id, e);
  }
  auto live = f.queue.events(id, 0, 100);
  EXPECT_FALSE(live->ended);
  f.queue.publish(id, completed());
  f.queue.publish(id, completed());  // after the end: dropped

  const auto events = f.all_events(id);
  ASSERT_EQ(events.size(), 6u);
  for (size_t i = 0; i < events.size(); ++i) EXPECT_EQ(events[i].sequence(), i);
  EXPECT_EQ(events[3].stage().name(), "render");
  auto tail = f.queue.events(id, 4, 1);
  ASSERT_EQ(tail->events.size(), 1u);
  EXPECT_EQ(tail->events[0].stage().name(), "meshing");
  EXPECT_FALSE(tail->ended);  // the completed event is still to come
  auto last = f.queue.events(id, 5, 10);
  EXPECT_TRUE(last->ended);
  EXPECT_TRUE(last->events[0].has_completed());
  EXPECT_EQ(f.queue.status(id)->worker(), "w");
}

TEST(EmbeddedQueue, SubscribersHearEveryEventUntilUnsubscribed) {
  Fixture f;
  const std::string id = f.submit(0);
  int calls = 0;
  auto token = f.queue.subscribe(id, [&] { ++calls; });
  ASSERT_TRUE(token.ok());
  f.queue.claim("w");
  v1::JobEvent e;
  e.mutable_stage()->set_name("views");
  f.queue.publish(id, e);
  f.queue.publish(id, e);
  EXPECT_EQ(calls, 2);
  f.queue.unsubscribe(id, *token);
  f.queue.publish(id, completed());
  EXPECT_EQ(calls, 2);
}

TEST(EmbeddedQueue, FinishedJobsExpireAfterTheResultTtl) {
  Fixture f(ServerLimits{}, std::chrono::seconds(60));
  const std::string done = f.submit(0), waiting = f.submit(0);
  f.queue.claim("w");
  f.queue.publish(done, completed());
  f.t += std::chrono::seconds(59);
  EXPECT_EQ(f.queue.expire(), 0u);
  EXPECT_TRUE(f.queue.status(done).ok());
  f.t += std::chrono::seconds(1);
  EXPECT_EQ(f.queue.expire(), 1u);
  auto gone = f.queue.status(done);
  ASSERT_FALSE(gone.ok());
  EXPECT_EQ(gone.status().code(), StatusCode::kNotFound);
  EXPECT_NE(gone.status().message().find("--result-ttl 60"), std::string::npos) << gone.status().message();
  EXPECT_EQ(f.queue.events(done, 0, 1).status().code(), StatusCode::kNotFound);
  EXPECT_TRUE(f.queue.status(waiting).ok());  // unfinished jobs never expire
}

TEST(EmbeddedQueue, FullQueueIsResourceExhaustedNamingTheLimit) {
  ServerLimits limits;
  limits.max_queue = 2;
  limits.max_jobs_per_client = 100;
  Fixture f(limits);
  f.submit(0);
  f.submit(0);
  JobSubmission s;
  s.client = "client-a";
  auto third = f.queue.submit(std::move(s));
  ASSERT_FALSE(third.ok());
  EXPECT_EQ(third.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(third.status().message().find("--max-queue"), std::string::npos) << third.status().message();
  f.queue.claim("w");  // running jobs do not count against the queue
  f.submit(0);
}

TEST(EmbeddedQueue, PerClientLimitCountsUnfinishedJobsOfThatClient) {
  ServerLimits limits;
  limits.max_jobs_per_client = 2;
  Fixture f(limits);
  const std::string a = f.submit(0, "peer-1");
  f.submit(0, "peer-1");
  JobSubmission s;
  s.client = "peer-1";
  auto refused = f.queue.submit(s);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(refused.status().message().find("--max-jobs-per-client"), std::string::npos);
  EXPECT_NE(refused.status().message().find("peer-1"), std::string::npos);
  f.submit(0, "peer-2");  // another connection is not affected
  (void)f.queue.cancel(a, Status(StatusCode::kCancelled, "x"));
  f.submit(0, "peer-1");  // a finished job frees its place
}

TEST(EmbeddedQueue, DrainFailsWaitingJobsAndRefusesNewOnes) {
  Fixture f;
  const std::string running = f.submit(0), waiting = f.submit(0);
  f.queue.claim("w");
  EXPECT_EQ(f.queue.drain(unavailable("shutting down")), 1u);
  auto st = f.queue.status(waiting);
  EXPECT_EQ(st->state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(st->failure().code(), int(grpc::StatusCode::UNAVAILABLE));
  EXPECT_EQ(f.queue.status(running)->state(), v1::JOB_STATE_RUNNING);
  JobSubmission s;
  auto refused = f.queue.submit(s);
  EXPECT_EQ(refused.status().code(), StatusCode::kUnavailable);
}

TEST(EmbeddedQueue, CloseWakesABlockedClaim) {
  Fixture f;
  std::optional<ClaimedJob> got = ClaimedJob{};
  std::thread worker([&] { got = f.queue.claim("w"); });
  f.queue.close();
  worker.join();
  EXPECT_FALSE(got);
}

TEST(EmbeddedQueue, UnknownJobIsNotFound) {
  Fixture f;
  EXPECT_EQ(f.queue.status("nope").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(f.queue.cancel("nope", Status()).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(f.queue.subscribe("nope", [] {}).status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace vpr::service
