// vpremesh-worker's command line (worker/service/worker_options.cpp).
#include <gtest/gtest.h>

#include "service/worker_options.h"

namespace vpr::service {
namespace {

WorkerOptions valid() {
  WorkerOptions o;
  o.queue = "redis://127.0.0.1:6379";
  return o;
}

TEST(WorkerOptions, GpuListsAreDistinctIndices) {
  EXPECT_EQ(parse_gpu_list("0").value(), std::vector<int>{0});
  EXPECT_EQ(parse_gpu_list("2,0,1").value(), (std::vector<int>{2, 0, 1}));
  for (const char* bad : {"", "0,", ",1", "a", "0,0", "-1", "1.5"}) {
    auto ids = parse_gpu_list(bad);
    ASSERT_FALSE(ids.ok()) << bad;
    EXPECT_NE(ids.status().message().find("--gpus"), std::string::npos);
  }
}

TEST(WorkerOptions, HeartbeatMustFitTwiceInTheVisibilityTimeout) {
  WorkerOptions o = valid();
  EXPECT_TRUE(check_worker_options(o).ok());
  o.heartbeat_s = 40;  // default visibility 60: one missed beat would lose the job
  const Status s = check_worker_options(o);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("--heartbeat"), std::string::npos);
  EXPECT_NE(s.message().find("--visibility-timeout"), std::string::npos);
}

TEST(WorkerOptions, RefusesABadQueueAndGpusOnTheCpu) {
  WorkerOptions o = valid();
  o.queue = "embedded";
  EXPECT_NE(check_worker_options(o).message().find("--queue"), std::string::npos);
  o = valid();
  o.gpus = "0";
  o.device = "cpu";
  EXPECT_NE(check_worker_options(o).message().find("--device cpu"), std::string::npos);
}

TEST(WorkerOptions, FlagsReachTheOptions) {
  WorkerOptions o;
  CLI::App app;
  add_worker_options(app, &o);
  std::vector<std::string> args = {"--max-faces",        "7",   "--visibility-timeout", "5", "--heartbeat", "1",
                                   "--max-deliveries", "4",   "--concurrency",        "2", "--queue",     "redis://h:1"};
  std::reverse(args.begin(), args.end());  // CLI11 parses a reversed vector
  app.parse(args);
  EXPECT_EQ(o.limits.max_faces, 7u);
  EXPECT_DOUBLE_EQ(o.visibility_timeout_s, 5);
  EXPECT_DOUBLE_EQ(o.heartbeat_s, 1);
  EXPECT_EQ(o.max_deliveries, 4);
  EXPECT_EQ(o.concurrency, 2);
  EXPECT_TRUE(check_worker_options(o).ok());
  // --gpus and --concurrency exclude each other.
  WorkerOptions p;
  CLI::App other;
  add_worker_options(other, &p);
  std::vector<std::string> both = {"1", "--concurrency", "0", "--gpus", "redis://h:1", "--queue"};
  EXPECT_THROW(other.parse(both), CLI::ParseError);
}

}  // namespace
}  // namespace vpr::service
