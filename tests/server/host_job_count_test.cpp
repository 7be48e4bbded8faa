// The server's count of busy job processes, as a job process reads it
// (server/host_job_count.h), and the job process's arguments.
#include "server/host_job_count.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/running_jobs.h"
#include "server/job_process.h"

namespace vpr::service {
namespace {

// A child process (as a job process is) maps the count from a copy of its
// descriptor and sees the server's changes while it runs.
TEST(HostJobCount, AJobProcessSeesTheServersCountChange) {
  auto count = HostJobCount::create();
  ASSERT_TRUE(count.ok()) << count.status().message();
  HostJobCount& jobs = **count;
  EXPECT_GE(jobs.fd(), 10) << "above the descriptors a job process is handed (3 and 4)";
  EXPECT_EQ(jobs.get(), 0);
  jobs.set(3);
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    close(ready[0]);
    const std::atomic<int>* host = HostJobCount::attach(dup(jobs.fd()));
    if (!host) _exit(10);
    count_host_jobs(host);
    if (running_jobs() != 3) _exit(11);
    if (write(ready[1], "r", 1) != 1) _exit(12);
    for (int i = 0; i < 500 && running_jobs() != 6; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    _exit(running_jobs() == 6 ? 0 : 13);
  }
  close(ready[1]);
  char c = 0;
  EXPECT_EQ(read(ready[0], &c, 1), 1) << "the child did not read 3";
  close(ready[0]);
  jobs.set(6);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "10: no mapping, 11: did not read 3, 13: did not see 6";
  EXPECT_EQ(running_jobs(), 1) << "this process never counted the host's jobs";
}

TEST(HostJobCount, AnUnmappableDescriptorGivesNoCount) {
  EXPECT_EQ(HostJobCount::attach(-1), nullptr);
  int p[2];
  ASSERT_EQ(pipe(p), 0);
  EXPECT_EQ(HostJobCount::attach(p[0]), nullptr) << "a pipe cannot be mapped";
  close(p[0]);
  close(p[1]);
}

std::optional<JobProcessFds> parse(std::vector<std::string> args) {
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  JobProcessFds fds;
  if (!is_job_process(int(argv.size()), argv.data(), &fds)) return std::nullopt;
  return fds;
}

TEST(JobProcessArguments, TheChannelAndTheServersJobCount) {
  auto plain = parse({"vpremesh-server", "--job-process", "3"});
  ASSERT_TRUE(plain);
  EXPECT_EQ(plain->channel, 3);
  EXPECT_EQ(plain->host_jobs, -1);
  auto counted = parse({"vpremesh-server", "--job-process", "3", "--host-jobs", "4"});
  ASSERT_TRUE(counted);
  EXPECT_EQ(counted->channel, 3);
  EXPECT_EQ(counted->host_jobs, 4);
  EXPECT_FALSE(parse({"vpremesh-server", "--listen", "3"}));
  EXPECT_FALSE(parse({"vpremesh-server", "--job-process", "x3"}));
  EXPECT_FALSE(parse({"vpremesh-server", "--job-process", "3", "--host-jobs"}));
  EXPECT_FALSE(parse({"vpremesh-server", "--job-process", "3", "--host-jobs", "-4"}));
  EXPECT_FALSE(parse({"vpremesh-server", "--job-process", "3", "--workers", "4"}));
}

}  // namespace
}  // namespace vpr::service
