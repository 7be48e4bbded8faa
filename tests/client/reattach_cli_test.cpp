// The real `vpremesh` client against scripted replicas (fake_replica.h): a
// stream that breaks with UNAVAILABLE after the job id came is picked up with
// Watch from the next event on the next --server replica, every event is
// processed once, and the result is the same bytes as without the break.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "cli_runner.h"
#include "client/fake_replica.h"
#include "client/tcp_relay.h"

namespace fs = std::filesystem;

namespace vpr {
namespace {

using testing::breaks_at;
using testing::CliRun;
using testing::FakeReplica;
using testing::holds_at;
using testing::replays_from_zero;
using testing::run_cli;
using Froms = std::vector<uint64_t>;

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

class ReattachTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vpremesh_reattach_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    // A tetrahedron: submit only needs something to upload.
    std::ofstream(path("tet.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string read(const std::string& name) const {
    std::ifstream f(path(name), std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  }
  std::string submit(const std::string& servers, const std::string& extra = "") const {
    return "submit " + path("tet.obj") + " -o " + path("out.drc") + " --target-vertices 100 --server " + servers + " " +
           extra;
  }
  // Every event shown once, in order, off a terminal: one line each.
  // Polls a file the running client writes until it holds `line`.
  bool wait_for_line(const std::string& name, const std::string& line, std::chrono::seconds limit) const {
    const auto until = std::chrono::steady_clock::now() + limit;
    while (read(name).find(line) == std::string::npos) {
      if (std::chrono::steady_clock::now() > until) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
  }
  static void expect_each_event_once(const std::string& err) {
    for (const char* line : {"job job-1: queued", "job job-1: started on fake-worker", "stage 1 render done",
                             "stage 2 saliency_field done", "job job-1: completed, 6 vertices"})
      EXPECT_EQ(count(err, line), 1u) << line << "\n" << err;
    EXPECT_EQ(count(err, "stage 3"), 0u) << err;
  }
  fs::path dir_;
};

TEST_F(ReattachTest, WatchMovesToTheNextReplicaFromTheNextEvent) {
  FakeReplica a, b;
  a.plan({breaks_at(6)});  // breaks between the first two result chunks
  CliRun r = run_cli("watch job-1 -o " + path("out.drc") + " --server " + a.address() + "," + b.address());
  ASSERT_EQ(r.code, 0) << r.all();
  EXPECT_EQ(read("out.drc"), a.job().result);
  EXPECT_EQ(a.watch_from(), Froms{0});
  EXPECT_EQ(b.watch_from(), Froms{6});
  EXPECT_EQ(count(r.err, "vpremesh: lost " + a.address() + " (fake replica lost); re-attaching to job job-1 on " +
                             b.address() + " from event 6\n"),
            1u)
      << r.err;
  expect_each_event_once(r.err);
  EXPECT_EQ(r.out.rfind("job job-1 on fake-worker (cpu)\n", 0), 0u) << r.out;
}

TEST_F(ReattachTest, OneReplicaIsAskedAgainEachTime) {
  FakeReplica a;
  a.plan({breaks_at(3), breaks_at(5)});
  CliRun r = run_cli("watch job-1 -o " + path("out.drc") + " --server " + a.address());
  ASSERT_EQ(r.code, 0) << r.all();
  EXPECT_EQ(read("out.drc"), a.job().result);
  EXPECT_EQ(a.watch_from(), (Froms{0, 3, 5}));
  EXPECT_EQ(count(r.err, "re-attaching to job job-1 on " + a.address() + " from event 3\n"), 1u) << r.err;
  EXPECT_EQ(count(r.err, "re-attaching to job job-1 on " + a.address() + " from event 5\n"), 1u) << r.err;
  expect_each_event_once(r.err);
}

// A server that ignores from_sequence replays from 0: what came before is not
// processed again (a result chunk twice would fail the reassembly).
TEST_F(ReattachTest, ReplayedEventsAreSkipped) {
  FakeReplica a;
  a.plan({breaks_at(7), replays_from_zero()});
  CliRun r = run_cli("watch job-1 -o " + path("out.drc") + " --server " + a.address());
  ASSERT_EQ(r.code, 0) << r.all();
  EXPECT_EQ(read("out.drc"), a.job().result);
  EXPECT_EQ(a.watch_from(), (Froms{0, 7}));
  expect_each_event_once(r.err);
}

TEST_F(ReattachTest, SubmitUploadsOnceAndWatchesTheRestElsewhere) {
  FakeReplica a, b;
  a.plan({breaks_at(2)});  // the Remesh stream: queued and started, then lost
  CliRun r = run_cli(submit(a.address() + "," + b.address(), "--json"));
  ASSERT_EQ(r.code, 0) << r.all();
  EXPECT_EQ(read("out.drc"), a.job().result);
  EXPECT_EQ(a.remesh_calls(), 1);
  EXPECT_GT(a.uploaded_bytes(), 0u);
  EXPECT_EQ(b.remesh_calls(), 0);
  EXPECT_EQ(a.watch_from(), Froms{});
  EXPECT_EQ(b.watch_from(), Froms{2});
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["job_id"], "job-1");
  EXPECT_EQ(j["server"], b.address());
  std::vector<std::string> stages;
  for (const auto& s : j["stages"]) stages.push_back(s["name"]);
  EXPECT_EQ(stages, (std::vector<std::string>{"read", "upload", "queue", "render", "saliency_field", "write"}));
}

// The replica's connection is reset under the Remesh stream (no status from
// the server at all): the transport's UNAVAILABLE re-attaches as well.
TEST_F(ReattachTest, SubmitSurvivesAReplicaWhoseConnectionIsReset) {
  FakeReplica a, b;
  testing::TcpRelay relay(a.port());
  a.plan({holds_at(6)});
  auto run = std::async(std::launch::async,
                        [&] { return run_cli(submit(relay.address() + "," + b.address()), path("err.txt")); });
  ASSERT_TRUE(a.wait_holding(std::chrono::seconds(60)));
  // The replica having sent events 0..5 does not mean the client has read
  // them: on a loaded machine they can still sit in the relay. Cut only once
  // the client shows event 3 (so it has the job's id), else this would be
  // UploadLostBeforeTheJobIdIsNotRetried.
  const bool shown = wait_for_line("err.txt", "stage 2 saliency_field done", std::chrono::seconds(60));
  relay.cut();  // either way, so that the client ends
  ASSERT_TRUE(shown) << read("err.txt");
  CliRun r = run.get();
  ASSERT_EQ(r.code, 0) << r.all();
  EXPECT_EQ(read("out.drc"), a.job().result);
  ASSERT_EQ(b.watch_from().size(), 1u);
  EXPECT_GE(b.watch_from()[0], 4u);  // what the client had received when the connection went
  EXPECT_LE(b.watch_from()[0], 6u);
  EXPECT_EQ(count(r.err, "vpremesh: lost " + relay.address() + " ("), 1u) << r.err;
  EXPECT_EQ(count(r.err, "re-attaching to job job-1 on " + b.address() + " from event "), 1u) << r.err;
  expect_each_event_once(r.err);
}

// Before the job id came, nothing is retried: a second upload could run the
// job twice.
TEST_F(ReattachTest, UploadLostBeforeTheJobIdIsNotRetried) {
  FakeReplica a, b;
  a.plan({breaks_at(0)});
  CliRun r = run_cli(submit(a.address() + "," + b.address()));
  EXPECT_EQ(r.code, 5) << r.all();
  EXPECT_EQ(r.err, "vpremesh: UNAVAILABLE: fake replica lost; lost " + a.address() +
                       " before the job's id came; the upload is not sent again\n");
  EXPECT_EQ(a.remesh_calls() + b.remesh_calls(), 1);
  EXPECT_EQ(b.watch_from(), Froms{});
}

TEST_F(ReattachTest, UploadGoesToTheFirstReplicaThatConnects) {
  FakeReplica a;
  const std::string closed = testing::closed_loopback_address();
  CliRun r = run_cli(submit(closed + "," + a.address()));
  ASSERT_EQ(r.code, 0) << r.all();
  EXPECT_EQ(a.remesh_calls(), 1);
  EXPECT_EQ(r.err.rfind("vpremesh: " + closed + " does not accept connections; trying " + a.address() + "\n", 0), 0u)
      << r.err;
  EXPECT_EQ(read("out.drc"), a.job().result);
}

TEST_F(ReattachTest, ZeroReattachTimeoutFailsAsWithOneServer) {
  FakeReplica a, b;
  a.plan({breaks_at(6)});
  CliRun r = run_cli("watch job-1 -o " + path("out.drc") + " --reattach-timeout 0 --server " + a.address() + "," +
                     b.address());
  EXPECT_EQ(r.code, 5) << r.all();
  EXPECT_EQ(count(r.err, "vpremesh: UNAVAILABLE: fake replica lost\n"), 1u) << r.err;
  EXPECT_EQ(a.watch_from(), Froms{0});
  EXPECT_EQ(b.watch_from(), Froms{});
}

TEST_F(ReattachTest, OtherErrorsAreNotRetried) {
  FakeReplica a, b;
  a.plan({breaks_at(3, grpc::StatusCode::NOT_FOUND)});
  CliRun r = run_cli("watch job-1 -o " + path("out.drc") + " --server " + a.address() + "," + b.address());
  EXPECT_EQ(r.code, 7) << r.all();
  EXPECT_EQ(b.watch_from(), Froms{});
}

// Attempts back off (100 ms, doubling) until --reattach-timeout passes
// without an event; the error names the last replica and says why it stopped.
TEST_F(ReattachTest, GivesUpAfterTheReattachTimeout) {
  FakeReplica a;
  a.plan({breaks_at(4)}, breaks_at(0));  // then every call breaks at once
  const auto start = std::chrono::steady_clock::now();
  CliRun r = run_cli("watch job-1 -o " + path("out.drc") + " --reattach-timeout 1 --server " + a.address());
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(r.code, 5) << r.all();
  EXPECT_NE(r.err.find("vpremesh: UNAVAILABLE: fake replica lost; gave up re-attaching to job job-1 after 1 s "
                       "without an event (--reattach-timeout)\n"),
            std::string::npos)
      << r.err;
  const Froms froms = a.watch_from();
  EXPECT_GE(froms.size(), 4u);  // 0, then at about 0.1, 0.3, 0.7 and 1 s
  EXPECT_LE(froms.size(), 8u);
  for (size_t i = 1; i < froms.size(); ++i) EXPECT_EQ(froms[i], 4u);
  EXPECT_GE(s, 0.9);
  EXPECT_LT(s, 30.0);
}

TEST_F(ReattachTest, DeadlineCoversTheWholeCommand) {
  FakeReplica a;
  a.plan({breaks_at(4)}, breaks_at(0));
  const auto start = std::chrono::steady_clock::now();
  CliRun r = run_cli("watch job-1 -o " + path("out.drc") + " --deadline 1 --server " + a.address());
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(r.code, 8) << r.all();
  EXPECT_NE(r.err.find("vpremesh: DEADLINE_EXCEEDED: the --deadline passed before the job ended\n"), std::string::npos)
      << r.err;
  EXPECT_LT(s, 30.0);
  EXPECT_EQ(a.cancel_calls(), 0);  // watch never owned the job
}

// The Remesh call would have cancelled its job at the deadline; the Watch
// that took over does not, so submit cancels the job itself.
TEST_F(ReattachTest, SubmitCancelsItsJobWhenTheDeadlinePassesAfterReattaching) {
  FakeReplica a, b;
  a.plan({breaks_at(2)});
  b.plan({holds_at(5)});
  CliRun r = run_cli(submit(a.address() + "," + b.address(), "--deadline 2"));
  EXPECT_EQ(r.code, 8) << r.all();
  EXPECT_EQ(b.watch_from(), Froms{2});
  EXPECT_EQ(b.cancel_calls(), 1);
  EXPECT_EQ(a.cancel_calls(), 0);
}

TEST_F(ReattachTest, StatusAndCancelAskTheNextReplicaWhenOneIsUnavailable) {
  FakeReplica a, b;
  const std::string closed = testing::closed_loopback_address();
  CliRun status = run_cli("status job-1 --server " + closed + "," + a.address());
  ASSERT_EQ(status.code, 0) << status.all();
  EXPECT_EQ(status.out.rfind("job job-1: SUCCEEDED on fake-worker", 0), 0u) << status.out;
  EXPECT_EQ(status.err.rfind("vpremesh: no answer from " + closed + " (", 0), 0u) << status.err;

  a.refuse_unary();
  CliRun cancel = run_cli("cancel job-1 --server " + a.address() + "," + b.address());
  ASSERT_EQ(cancel.code, 0) << cancel.all();
  EXPECT_EQ(cancel.err,
            "vpremesh: no answer from " + a.address() + " (the server is draining); trying " + b.address() + "\n");
  EXPECT_EQ(a.unary_calls(), 2);
  EXPECT_EQ(b.unary_calls(), 1);

  CliRun refused = run_cli("status job-1 --server " + a.address());
  EXPECT_EQ(refused.code, 5) << refused.all();
  EXPECT_EQ(refused.err, "vpremesh: UNAVAILABLE: the server is draining\n");
}

TEST_F(ReattachTest, BadServerListIsAUsageError) {
  CliRun r = run_cli("watch job-1 --server 127.0.0.1:1,,127.0.0.1:2");
  EXPECT_EQ(r.code, 2) << r.all();
  EXPECT_NE(r.err.find("--server: \"127.0.0.1:1,,127.0.0.1:2\": entry 2 is empty"), std::string::npos) << r.err;
  r = run_cli("status job-1 --server 127.0.0.1:1,localhost");
  EXPECT_EQ(r.code, 2) << r.all();
  EXPECT_NE(r.err.find("--server: entry \"localhost\": it has no port"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace vpr
