// The real `vpremesh` client's connection set-up and retries against scripted
// replicas (fake_replica.h) behind a relay that can drop connections
// (tcp_relay.h): a command started before its server listens waits for it
// within its deadline, and an upload the server may have accepted is never
// sent again, whatever happens to the connection afterwards.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <string>
#include <thread>

#include "cli_runner.h"
#include "client/fake_replica.h"
#include "client/tcp_relay.h"

namespace fs = std::filesystem;

namespace vpr {
namespace {

using testing::CliRun;
using testing::FakeReplica;
using testing::holds_at;
using testing::run_cli;

class ConnectionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vpremesh_connection_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    std::ofstream(path("tet.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string read(const std::string& name) const {
    std::ifstream f(path(name), std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  }
  std::string submit(const std::string& server, const std::string& extra = "") const {
    return "submit " + path("tet.obj") + " -o " + path("out.drc") + " --target-vertices 100 --server " + server + " " +
           extra;
  }
  fs::path dir_;
};

// The address is free while the client starts; the server takes it 1.5 s
// later, which is inside the deadline: the upload waits for it, goes once,
// and the job completes.
TEST_F(ConnectionTest, SubmitStartedBeforeTheServerSucceedsWhenItComesUp) {
  const std::string address = testing::closed_loopback_address();
  auto run = std::async(std::launch::async, [&] { return run_cli(submit(address, "--deadline 30")); });
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  FakeReplica a({}, address);
  ASSERT_EQ(a.address(), address);
  CliRun r = run.get();
  ASSERT_EQ(r.code, 0) << r.all();
  EXPECT_EQ(a.remesh_calls(), 1);
  EXPECT_EQ(read("out.drc"), a.job().result);
}

// Without --deadline the first call still waits for the server (up to
// kConnectWaitWithoutDeadline, 30 s), for status as for submit.
TEST_F(ConnectionTest, StatusStartedBeforeTheServerSucceedsWhenItComesUp) {
  const std::string address = testing::closed_loopback_address();
  auto run = std::async(std::launch::async, [&] { return run_cli("status job-1 --server " + address); });
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  FakeReplica a({}, address);
  CliRun r = run.get();
  ASSERT_EQ(r.code, 0) << r.all();
  EXPECT_EQ(r.out.rfind("job job-1: SUCCEEDED on fake-worker", 0), 0u) << r.out;
  EXPECT_EQ(a.unary_calls(), 1);
}

// Nothing comes up within the deadline: the deadline ends the wait, no hang.
TEST_F(ConnectionTest, NoServerWithinTheDeadlineFails) {
  const std::string address = testing::closed_loopback_address();
  const auto start = std::chrono::steady_clock::now();
  CliRun r = run_cli(submit(address, "--deadline 2"));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(r.code, 8) << r.all();  // DEADLINE_EXCEEDED (exit_codes.h)
  EXPECT_GE(s, 1.9);
  EXPECT_LT(s, 15);
}

// The server has read the whole upload (it holds the job, as one that was
// accepted and queued) when the connection is reset under the call; the relay
// lets a new connection through at once, so a replay would reach the server.
// The client fails UNAVAILABLE and the server saw one upload.
TEST_F(ConnectionTest, AcceptedUploadIsNotSentAgainWhenTheConnectionDrops) {
  FakeReplica a;
  testing::TcpRelay relay(a.port());
  a.plan({holds_at(0)});
  auto run = std::async(std::launch::async, [&] { return run_cli(submit(relay.address())); });
  ASSERT_TRUE(a.wait_holding(std::chrono::seconds(60)));
  relay.reset_connections();
  CliRun r = run.get();
  EXPECT_EQ(r.code, 5) << r.all();
  EXPECT_NE(r.err.find("Connection reset"), std::string::npos) << r.err;
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // a replay would have arrived by now
  EXPECT_EQ(a.remesh_calls(), 1);
  EXPECT_GT(a.uploaded_bytes(), 0u);
}

// The same with Submit (--no-wait): its reply is the job id, and the server
// had accepted the upload before the connection went.
TEST_F(ConnectionTest, AcceptedSubmitIsNotSentAgainWhenTheConnectionDrops) {
  FakeReplica a;
  testing::TcpRelay relay(a.port());
  a.hold_submit();
  auto run = std::async(std::launch::async, [&] { return run_cli(submit(relay.address(), "--no-wait")); });
  ASSERT_TRUE(a.wait_holding(std::chrono::seconds(60)));
  relay.reset_connections();
  CliRun r = run.get();
  EXPECT_EQ(r.code, 5) << r.all();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(a.submit_calls(), 1);
}

}  // namespace
}  // namespace vpr
