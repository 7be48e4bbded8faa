// `vpremesh bench` against the real vpremesh-server on a free loopback port
// (one CPU worker), and its statistics (client/load_stats.h) on made-up
// samples. Nothing here is timed: the assertions are on counts, on order and
// on what one worker must do to a queue.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <nlohmann/json.hpp>
#include <numeric>
#include <random>

#include "load_stats.h"
#include "service_harness.h"

namespace vpr::testing {
namespace {

using nlohmann::json;

const std::string kModel = "../shared/models/suzanne.obj";
// Small and quick on two cores: 256 px snapshots, 200 output vertices.
const std::string kJob = " --input " + kModel + " -n 200 --resolution 256 --device cpu --json";

// Nearest rank on 1..1000: pq is the value at rank ceil(q n).
TEST(LoadStats, NearestRankPercentilesAreMeasuredValuesInOrder) {
  std::vector<double> v(1000);
  std::iota(v.begin(), v.end(), 1.0);
  std::shuffle(v.begin(), v.end(), std::mt19937(7));
  const cli::Percentiles p = cli::percentiles(v);
  EXPECT_EQ(p.count, 1000u);
  EXPECT_EQ(p.min, 1);
  EXPECT_EQ(p.p50, 500);
  EXPECT_EQ(p.p90, 900);
  EXPECT_EQ(p.p99, 990);
  EXPECT_EQ(p.p999, 999);
  EXPECT_EQ(p.max, 1000);
  EXPECT_DOUBLE_EQ(p.mean, 500.5);
  // Few values: every percentile is one of them, never an interpolation.
  const cli::Percentiles q = cli::percentiles({30, 10, 20});
  EXPECT_EQ(q.p50, 20);
  EXPECT_EQ(q.p90, 30);
  EXPECT_EQ(q.p999, 30);
  EXPECT_EQ(cli::percentiles({}).count, 0u);
}

// A request that never reached the server is a connection error: out of
// errors and errors_by_code, which are the server's answers.
TEST(LoadStats, ConnectionErrorsAreCountedApart) {
  std::vector<cli::RequestSample> samples(4);
  samples[0] = {true, "", "", 100, 0, 5, 20, 60, {{"render", 30}}, 1000};
  samples[1].error_code = "UNAVAILABLE";
  samples[1].error = "failed to connect to all addresses";
  samples[1].connection_failure = true;
  samples[2] = samples[1];
  samples[2].error = "second";
  samples[3].error_code = "RESOURCE_EXHAUSTED";
  samples[3].error = "queue full";
  const cli::LoadReport r = cli::summarize_load(samples, 1.0);
  EXPECT_EQ(r.requests, 4u);
  EXPECT_EQ(r.completed, 1u);
  EXPECT_EQ(r.errors, 1u);
  EXPECT_EQ(r.connection_errors, 2u);
  EXPECT_EQ(r.connection_error_example, "failed to connect to all addresses");
  EXPECT_EQ(r.errors_by_code.count("UNAVAILABLE"), 0u);
  const nlohmann::json j = cli::load_report_json(r);
  EXPECT_EQ(j["connection_errors"], 2);
  EXPECT_EQ(j["errors"], 1);
  EXPECT_NE(cli::format_load_report(r).find("errors 1, connection errors 2"), std::string::npos);
}

// The split of the mean adds up to the mean latency; errors count by code and
// stay out of the latencies.
TEST(LoadStats, SplitAddsUpAndErrorsAreCountedByCode) {
  std::vector<cli::RequestSample> samples(4);
  samples[0] = {true, "", "", 100, 0, 5, 20, 60, {{"render", 30}, {"awlop", 20}}, 1000};
  samples[1] = {true, "", "", 300, 10, 5, 200, 70, {{"render", 40}, {"awlop", 20}}, 3000};
  samples[2].error_code = "RESOURCE_EXHAUSTED";
  samples[2].error = "queue full";
  samples[2].latency_ms = 1;
  samples[3] = samples[2];
  samples[3].error = "second message";
  const cli::LoadReport r = cli::summarize_load(samples, 2.0);
  EXPECT_EQ(r.requests, 4u);
  EXPECT_EQ(r.completed, 2u);
  EXPECT_EQ(r.errors, 2u);
  EXPECT_EQ(r.errors_by_code.at("RESOURCE_EXHAUSTED"), 2u);
  EXPECT_EQ(r.error_examples.at("RESOURCE_EXHAUSTED"), "queue full");
  EXPECT_DOUBLE_EQ(r.throughput_per_s, 1.0);
  EXPECT_DOUBLE_EQ(r.latency.mean, 200);
  EXPECT_DOUBLE_EQ(r.latency.min, 100);
  EXPECT_DOUBLE_EQ(r.queue_ms, 110);
  EXPECT_DOUBLE_EQ(r.stages_ms, 55);
  EXPECT_DOUBLE_EQ(r.server_other_ms, 10);  // run 65 less stages 55
  EXPECT_DOUBLE_EQ(r.lag_ms + r.upload_ms + r.queue_ms + r.stages_ms + r.server_other_ms + r.transfer_other_ms,
                   r.latency.mean);
  ASSERT_EQ(r.stage_means.size(), 2u);
  EXPECT_EQ(r.stage_means[0].first, "render");
  EXPECT_DOUBLE_EQ(r.stage_means[0].second, 35);
  EXPECT_DOUBLE_EQ(r.result_bytes_mean, 2000);
}

class BenchCliTest : public ::testing::Test {
 protected:
  // One CPU worker: the queue is where concurrent requests wait.
  void SetUp() override {
    server_ = std::make_unique<ServerProcess>(std::vector<std::string>{"--workers", "1", "--device", "cpu"});
  }
  std::unique_ptr<ServerProcess> server_;
};

double split(const json& j, const char* part) {
  return j["split_ms"][part].get<double>();
}

// Two clients, four requests (one warmup first, not counted): all complete,
// percentiles in order, and with one worker one of the first two requests
// waits in the queue for the other's whole run.
TEST_F(BenchCliTest, ClosedLoopCompletesEveryRequest) {
  ASSERT_TRUE(server_->started()) << server_->log();
  const CliRun r = run_cli("bench --server " + server_->address() + kJob + " -c 2 -r 4 --warmup 1");
  ASSERT_EQ(r.code, 0) << r.err << "\n" << server_->log();
  const json j = json::parse(r.out);
  EXPECT_EQ(j["mode"], "closed");
  EXPECT_EQ(j["requests"], 4);
  EXPECT_EQ(j["completed"], 4) << r.out;
  EXPECT_EQ(j["errors"], 0) << r.out;
  EXPECT_TRUE(j["errors_by_code"].empty());
  EXPECT_EQ(j["connections"], 2);
  const json& l = j["latency_ms"];
  EXPECT_EQ(l["count"], 4);
  EXPECT_GT(l["min"].get<double>(), 0);
  EXPECT_LE(l["min"].get<double>(), l["p50"].get<double>());
  EXPECT_LE(l["p50"].get<double>(), l["p90"].get<double>());
  EXPECT_LE(l["p90"].get<double>(), l["p99"].get<double>());
  EXPECT_LE(l["p99"].get<double>(), l["p99.9"].get<double>());
  EXPECT_LE(l["p99.9"].get<double>(), l["max"].get<double>());
  EXPECT_GT(j["throughput_per_s"].get<double>(), 0);
  EXPECT_NEAR(j["throughput_per_s"].get<double>(), 4 / j["wall_s"].get<double>(), 1e-9);

  // The split: every part there, adding up to the mean latency.
  double parts = 0;
  for (const char* part : {"lag", "upload", "queue", "stages", "server_other", "transfer_other"}) {
    ASSERT_TRUE(j["split_ms"].contains(part)) << part;
    parts += split(j, part);
  }
  EXPECT_NEAR(parts, split(j, "total"), 1e-6 * split(j, "total"));
  EXPECT_NEAR(split(j, "total"), l["mean"].get<double>(), 1e-9);
  EXPECT_EQ(split(j, "lag"), 0);  // closed loop: sent when the client is free
  EXPECT_GT(split(j, "stages"), 0);
  EXPECT_GT(split(j, "upload"), 0);
  for (const char* stage : {"render", "image_saliency", "saliency_field", "cvt", "meshing"})
    EXPECT_GT(j["stages_ms"].value(stage, 0.0), 0) << stage << "\n" << r.out;
  double stage_sum = 0;
  for (const auto& [name, ms] : j["stages_ms"].items()) stage_sum += ms.get<double>();
  EXPECT_NEAR(stage_sum, split(j, "stages"), 1e-6 * stage_sum);
  // Two clients, one worker: a request waited for a whole job.
  EXPECT_GE(j["queue_ms"]["max"].get<double>(), 0.5 * split(j, "stages")) << r.out;
  EXPECT_GT(j["result_bytes_mean"].get<double>(), 0);  // the result came back
}

// 40 requests/s for 0.1 s: 4 requests within 75 ms, far above what one
// worker completes, so latency (from the intended send time) carries the
// queue: the last request waits behind at least one whole job before its own.
TEST_F(BenchCliTest, OpenLoopCountsTheQueueInTheLatency) {
  ASSERT_TRUE(server_->started()) << server_->log();
  const CliRun r = run_cli("bench --server " + server_->address() + kJob + " --rate 40 --duration 0.1 --no-result");
  ASSERT_EQ(r.code, 0) << r.err << "\n" << server_->log();
  const json j = json::parse(r.out);
  EXPECT_EQ(j["mode"], "open");
  EXPECT_NEAR(j["requests"].get<double>(), 40 * 0.1, 1);
  EXPECT_EQ(j["completed"], j["requests"]) << r.out;
  EXPECT_EQ(j["errors"], 0) << r.out;
  const json& l = j["latency_ms"];
  EXPECT_GE(l["p99"].get<double>(), l["p50"].get<double>());
  EXPECT_GT(split(j, "queue"), 0);
  EXPECT_GT(j["queue_ms"]["max"].get<double>(), 0);
  EXPECT_GE(l["max"].get<double>(), j["queue_ms"]["max"].get<double>() + split(j, "stages") * 0.5) << r.out;
  EXPECT_GE(l["max"].get<double>(), 2 * split(j, "stages")) << r.out;
  EXPECT_EQ(j["result_bytes_mean"], 0);  // --no-result
  EXPECT_EQ(j["return_mesh"], false);
}

// Nothing listening: exit 5 and one line naming the address.
TEST(BenchCli, ClosedPortExitsUnavailable) {
  const std::string closed = vpr::testing::closed_loopback_address();
  ASSERT_FALSE(closed.empty());
  const CliRun r = run_cli("bench --server " + closed + kJob + " -c 1 -r 2");
  EXPECT_EQ(r.code, 5) << r.err;
  EXPECT_EQ(r.err.rfind("vpremesh: UNAVAILABLE: cannot reach the server at " + closed, 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(r.out, "");
}

}  // namespace
}  // namespace vpr::testing
