// Jobs run in supervised job processes (server/job_process.h): killing one
// mid-job costs that job alone, with an error naming the signal and the
// stage; the server keeps its PID and serves; the other jobs complete; the
// limits per job end a job RESOURCE_EXHAUSTED naming the flag.
#include <gtest/gtest.h>

#include <future>

#include "service_harness.h"
#include "test_meshes.h"

namespace vpr::testing {
namespace {

// Seconds of work in stages of about a second each on the CPU (14 views at
// 1024 px), long enough to be killed mid-job.
std::vector<uint8_t> heavy_model() {
  auto mesh = read_mesh("../shared/models/spot.obj");
  return mesh.ok() ? lossless_draco(*mesh) : std::vector<uint8_t>{};
}

v1::JobSpec heavy_spec(uint64_t size) {
  v1::JobSpec spec = make_spec(2000, size);
  spec.set_label("heavy");
  spec.set_device(v1::DEVICE_CPU);
  spec.mutable_options()->set_views(14);
  spec.mutable_options()->set_resolution(1024);
  return spec;
}

// The job process's PID, from the `started` event's worker ("…/process-PID").
pid_t job_process_pid(const v1::JobEvent& started) {
  const std::string& worker = started.started().worker();
  const size_t at = worker.rfind("/process-");
  return at == std::string::npos ? -1 : pid_t(std::stol(worker.substr(at + 9)));
}

bool process_exists(pid_t pid) {
  return ::kill(pid, 0) == 0;
}

// Dead: gone, or a zombie its parent has not reaped yet.
bool process_dead(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string id, name, state;
  return !(stat >> id >> name >> state) || state == "Z";
}

class JobProcessTest : public ::testing::TestWithParam<int> {};

// SIGSEGV (a crash) and SIGKILL (the OOM killer, an operator) sent to the
// job process running a job, while two more jobs run beside it.
TEST_P(JobProcessTest, KilledJobProcessFailsOnlyItsJob) {
  const int signal_number = GetParam();
  ServerProcess server({"--workers", "3", "--device", "cpu"});
  ASSERT_TRUE(server.started()) << server.log();
  const pid_t server_pid = server.pid();
  auto stub = make_stub(server.address());
  const std::vector<uint8_t> heavy = heavy_model(), sphere = lossless_draco(icosphere(3));
  ASSERT_FALSE(heavy.empty());

  std::promise<pid_t> victim;
  bool sent = false;
  auto killed = std::async(std::launch::async, [&] {
    return remesh(*stub, heavy_spec(heavy.size()), heavy, [&](const v1::JobEvent& e) {
      // Kill after the first stage has ended: mid-job, not before it.
      if (e.has_started()) victim.set_value(job_process_pid(e));
      if (e.has_stage() && !sent) {
        sent = true;
        EXPECT_EQ(::kill(victim.get_future().get(), signal_number), 0);
      }
    });
  });
  std::vector<std::future<RemeshOutcome>> others;
  for (uint32_t target : {400u, 500u})
    others.push_back(std::async(std::launch::async, [&, target] {
      return remesh(*stub, make_spec(target, sphere.size()), sphere);
    }));

  const RemeshOutcome k = killed.get();
  ASSERT_TRUE(sent) << server.log();
  EXPECT_EQ(k.status.error_code(), grpc::StatusCode::INTERNAL) << k.status.error_message();
  const std::string name = signal_number == SIGSEGV ? "SIGSEGV" : "SIGKILL";
  EXPECT_NE(k.status.error_message().find("the remesh process died on this job: " + name + " in stage "),
            std::string::npos)
      << k.status.error_message();
  EXPECT_NE(k.status.error_message().find("; not retried"), std::string::npos) << k.status.error_message();
  ASSERT_TRUE(k.last() && k.last()->has_failed());
  EXPECT_EQ(get_job(*stub, k.job_id).state(), v1::JOB_STATE_FAILED);

  for (auto& other : others) {
    const RemeshOutcome r = other.get();
    EXPECT_TRUE(r.status.ok() && r.completed()) << r.status.error_message() << "\n" << server.log();
  }
  // Same server, still serving, with a fresh job process for the next job.
  EXPECT_EQ(server.pid(), server_pid);
  EXPECT_TRUE(process_exists(server_pid));
  const RemeshOutcome after = remesh(*stub, make_spec(300, sphere.size()), sphere);
  EXPECT_TRUE(after.status.ok() && after.completed()) << after.status.error_message() << "\n" << server.log();
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

INSTANTIATE_TEST_SUITE_P(Signals, JobProcessTest, ::testing::Values(SIGSEGV, SIGKILL),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return std::string(info.param == SIGSEGV ? "SIGSEGV" : "SIGKILL");
                         });

// A job process killed while it waits for work costs no job: the next job
// runs in a new one.
TEST(JobProcessIdleTest, ProcessKilledWhileIdleCostsNoJob) {
  ServerProcess server({"--workers", "1", "--device", "cpu"});
  ASSERT_TRUE(server.started()) << server.log();
  auto stub = make_stub(server.address());
  const std::vector<uint8_t> sphere = lossless_draco(icosphere(3));
  const RemeshOutcome first = remesh(*stub, make_spec(300, sphere.size()), sphere);
  ASSERT_TRUE(first.status.ok() && first.completed()) << first.status.error_message();
  auto started = [](const RemeshOutcome& r) {
    for (const v1::JobEvent& e : r.events)
      if (e.has_started()) return job_process_pid(e);
    return pid_t(-1);
  };
  const pid_t pid = started(first);
  ASSERT_GT(pid, 0);
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  while (!process_dead(pid)) std::this_thread::sleep_for(std::chrono::milliseconds(5));

  const RemeshOutcome second = remesh(*stub, make_spec(300, sphere.size()), sphere);
  EXPECT_TRUE(second.status.ok() && second.completed()) << second.status.error_message() << "\n" << server.log();
  EXPECT_NE(started(second), pid);
}

// The CPU time limit per job: the job ends RESOURCE_EXHAUSTED naming the
// flag; the next job gets its own allowance and completes.
TEST(JobProcessLimitsTest, CpuTimeLimitEndsTheJob) {
  ServerProcess server({"--workers", "1", "--device", "cpu", "--job-cpu-seconds", "1"});
  ASSERT_TRUE(server.started()) << server.log();
  auto stub = make_stub(server.address());
  // igea (134k vertices) at 14 views of 1024 px: several CPU seconds.
  auto igea = read_mesh("../shared/models/igea.ply");
  ASSERT_TRUE(igea.ok()) << igea.status().to_string();
  const std::vector<uint8_t> heavy = lossless_draco(*igea), sphere = lossless_draco(icosphere(2));
  v1::JobSpec spec = heavy_spec(heavy.size());
  spec.set_target_vertices(10000);
  const RemeshOutcome r = remesh(*stub, spec, heavy);
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << r.status.error_message();
  EXPECT_NE(r.status.error_message().find("--job-cpu-seconds"), std::string::npos) << r.status.error_message();
  std::printf("[job process] CPU limit: %s\n", r.status.error_message().c_str());
  const RemeshOutcome next = remesh(*stub, make_spec(100, sphere.size()), sphere);
  EXPECT_TRUE(next.status.ok() && next.completed()) << next.status.error_message() << "\n" << server.log();
}

// The memory limit per job, held by the address-space limit (an allocation
// past it fails) or by the supervisor's resident-set watchdog.
TEST(JobProcessLimitsTest, MemoryLimitEndsTheJob) {
  ServerProcess server({"--workers", "1", "--device", "cpu", "--job-memory-mib", "64"});
  ASSERT_TRUE(server.started()) << server.log();
  auto stub = make_stub(server.address());
  const std::vector<uint8_t> heavy = heavy_model();
  ASSERT_FALSE(heavy.empty());
  const RemeshOutcome r = remesh(*stub, heavy_spec(heavy.size()), heavy);
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << r.status.error_message();
  EXPECT_NE(r.status.error_message().find("--job-memory-mib"), std::string::npos) << r.status.error_message();
  std::printf("[job process] memory limit: %s\n", r.status.error_message().c_str());
  EXPECT_TRUE(process_exists(server.pid()));
}

}  // namespace
}  // namespace vpr::testing
