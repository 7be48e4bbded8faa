// The job process (server/job_process.h): the same binary as the server or
// the worker, started with --job-process FD. It owns a renderer and a CUDA
// context and runs one job at a time through run_job, against a JobQueue
// whose publish and cancellation cross the channel to the worker thread.
#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "core/running_jobs.h"
#include "core/thread_share.h"
#include "server/host_job_count.h"
#include "server/job_channel.h"
#include "server/job_process.h"
#include "server/job_process_init.h"

namespace vpr::service {
namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif

// The queue as run_job sees it inside a job process: its events and
// cancellation queries go to the supervising worker thread, which holds the
// real queue. A lost channel means the supervisor is gone: so is the job.
class RelayQueue : public JobQueue {
 public:
  explicit RelayQueue(int fd) : fd_(fd) {}

  void publish(const std::string&, v1::JobEvent event) override {
    if (!write_frame(fd_, FrameType::kEvent, event.SerializeAsString())) std::_Exit(1);
  }
  std::optional<Status> cancellation(const std::string&) override {
    Frame answer;
    if (!write_frame(fd_, FrameType::kCancelQuery, "") || !read_frame(fd_, &answer) ||
        answer.type != FrameType::kCancelAnswer)
      std::_Exit(1);
    FieldReader r(answer.payload);
    uint64_t code = 0;
    std::string message;
    if (!r.u64(&code) || !r.str(&message)) std::_Exit(1);
    if (code == 0) return std::nullopt;
    return Status(StatusCode(code), message);
  }

  // run_job uses only the two above.
  StatusOr<std::string> submit(JobSubmission) override { return unsupported(); }
  std::optional<ClaimedJob> claim(const std::string&) override { return std::nullopt; }
  StatusOr<v1::JobStatus> cancel(const std::string&, const Status&) override { return unsupported(); }
  StatusOr<v1::JobStatus> status(const std::string&) override { return unsupported(); }
  Status check_owner(const std::string&, const std::string&) override { return unsupported(); }
  StatusOr<EventBatch> events(const std::string&, uint64_t, size_t) override { return unsupported(); }
  StatusOr<uint64_t> subscribe(const std::string&, Listener) override { return unsupported(); }
  void unsubscribe(const std::string&, uint64_t) override {}
  size_t drain(const Status&) override { return 0; }
  void close() override {}
  size_t expire() override { return 0; }
  QueueStats stats() override { return {}; }

 private:
  static Status unsupported() { return internal_error("a job process has no queue of its own"); }
  int fd_;
};

// RLIMIT_CPU counts the process's whole life: each job gets its allowance on
// top of what the process has used so far. Past it the kernel sends SIGXCPU,
// which ends the process (the supervisor reports it as the limit).
void allow_cpu_seconds(double seconds) {
  if (!(seconds > 0)) return;
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const double used = double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                      1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
  rlimit limit{};
  getrlimit(RLIMIT_CPU, &limit);
  limit.rlim_cur = rlim_t(std::ceil(used + seconds));
  if (limit.rlim_max != RLIM_INFINITY && limit.rlim_cur > limit.rlim_max) limit.rlim_cur = limit.rlim_max;
  if (setrlimit(RLIMIT_CPU, &limit) != 0) spdlog::warn("cannot set the job's CPU time limit");
}

}  // namespace

int job_process_main(const JobProcessFds& fds) {
  const int fd = fds.channel;
  prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive the worker thread's process
  if (getppid() == 1) return 1;      // it is gone already
  signal(SIGPIPE, SIG_IGN);
  spdlog::set_default_logger(spdlog::stderr_color_mt("vpremesh-job"));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");

  Frame frame;
  WorkerContext ctx;
  JobProcessOptions limits;
  if (!read_frame(fd, &frame) || frame.type != FrameType::kInit || !decode_init(frame.payload, &ctx, &limits))
    return 2;
  ctx.name += "/process-" + std::to_string(getpid());
  const bool uses_cuda = ctx.device_policy != DevicePolicy::kCpu && ctx.device.rfind("cuda:", 0) == 0;
  // Address space is the memory limit the kernel enforces (an allocation past
  // it fails, and the job ends RESOURCE_EXHAUSTED). Not with CUDA, whose
  // driver reserves address space by the size of the GPU, nor under
  // AddressSanitizer's shadow memory: there the supervisor's resident-set
  // watchdog alone holds the limit.
  // The address space holds more than the resident set (thread stacks,
  // malloc arenas, the meshing heap's reservation): twice the limit, so that
  // only a runaway allocation meets it before the watchdog does.
  if (limits.memory_bytes > 0 && !uses_cuda && !kAddressSanitizer) {
    const size_t bytes = std::max(2 * limits.memory_bytes, limits.memory_bytes + (size_t(4) << 30));
    const rlimit as{rlim_t(bytes), rlim_t(bytes)};
    if (setrlimit(RLIMIT_AS, &as) != 0) spdlog::warn("{}: cannot limit the address space", ctx.name);
    ctx.memory_limit_bytes = limits.memory_bytes;
  }
  // The server's busy job processes share this host's cores with this one:
  // loops split by this job's share of them (core/running_jobs.h).
  if (fds.host_jobs >= 0) count_host_jobs(HostJobCount::attach(fds.host_jobs));
  init_cuda(ctx);
  auto renderer = create_renderer(ctx.renderer_kind, renderer_gpu(ctx));
  if (!renderer.ok()) {
    write_frame(fd, FrameType::kInitFailed, renderer.status().message());
    return 1;
  }
  ctx.renderer = renderer->get();
  if (!write_frame(fd, FrameType::kReady, ctx.renderer->description())) return 1;

  RelayQueue relay(fd);
  ctx.on_step = [fd](const std::string& step) {
    if (!write_frame(fd, FrameType::kStep, step)) std::_Exit(1);
  };
  while (read_frame(fd, &frame)) {
    ClaimedJob job;
    if (frame.type != FrameType::kJob || !decode_job(frame.payload, &job)) return 2;
    allow_cpu_seconds(limits.cpu_seconds);
    // This process's TBB threads: its share of the host's cores while the
    // server's other job processes run (core/thread_share.h), all of them
    // when it runs alone.
    const ThreadCap share(one_job_process_threads(host_threads(), running_jobs()));
    run_job(relay, std::move(job), ctx);
    if (!write_frame(fd, FrameType::kJobDone, "")) break;
  }
  return 0;  // the supervisor closed the channel
}

}  // namespace vpr::service
