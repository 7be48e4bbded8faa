// The supervising side of a job process (the worker thread's); the process
// itself is job_process_main.cpp.
#include "server/job_process.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <thread>

#include "server/job_channel.h"
#include "server/job_process_init.h"

namespace vpr::service {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;

// How often the supervisor looks at the process while it runs a job.
constexpr int kPollMs = 100;
// A job asked to stop (CancelJob, its deadline, the server draining) stops at
// its next stage boundary; a process still running it this long after the
// request is killed, so no stage can hold a worker past a cancellation.
constexpr auto kCancelGrace = seconds(10);

std::string mib(size_t bytes) {
  return std::to_string(bytes >> 20);
}

// The process's resident set in bytes (0 when it cannot be read).
size_t resident_bytes(pid_t pid) {
  std::ifstream statm("/proc/" + std::to_string(pid) + "/statm");
  size_t pages_total = 0, pages_resident = 0;
  if (!(statm >> pages_total >> pages_resident)) return 0;
  return pages_resident * size_t(sysconf(_SC_PAGESIZE));
}

std::string signal_name(int sig) {
  const char* abbrev = sigabbrev_np(sig);
  return abbrev ? std::string("SIG") + abbrev : "signal " + std::to_string(sig);
}

// The event and bytes counters the worker thread keeps itself when the job
// runs in it (run_job), kept here from the relayed events instead.
void observe(ServiceMetrics* metrics, const v1::JobEvent& e) {
  if (!metrics) return;
  if (e.has_stage()) metrics->stage_seconds(e.stage().name()).observe(e.stage().ms() / 1000.0);
  if (e.has_result()) metrics->bytes_out.inc(double(e.result().data().size()));
  if (e.has_saliency()) metrics->bytes_out.inc(double(e.saliency().values_size() * sizeof(float)));
  if (e.has_saliency_points()) metrics->bytes_out.inc(double(e.saliency_points().values_size() * sizeof(float)));
  if (e.has_input_saliency()) metrics->bytes_out.inc(double(e.input_saliency().values_size() * sizeof(float)));
  if (e.has_debug_image()) metrics->bytes_out.inc(double(e.debug_image().png().size()));
  if (e.has_completed()) metrics->job_seconds().observe(e.completed().total_ms() / 1000.0);
}

}  // namespace

namespace {

bool parse_fd(const char* text, int* fd) {
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (*end != '\0' || value < 0 || value > 1 << 20) return false;
  *fd = int(value);
  return true;
}

}  // namespace

bool is_job_process(int argc, char** argv, JobProcessFds* fds) {
  if ((argc != 3 && argc != 5) || std::strcmp(argv[1], "--job-process") != 0) return false;
  if (!parse_fd(argv[2], &fds->channel)) return false;
  fds->host_jobs = -1;
  return argc == 3 || (std::strcmp(argv[3], "--host-jobs") == 0 && parse_fd(argv[4], &fds->host_jobs));
}

Status crash_status(int wait_status, const std::string& step, const JobProcessOptions& options, size_t rss_bytes,
                    bool killed_for_memory) {
  const std::string where = "in stage " + (step.empty() ? std::string("start") : step);
  if (killed_for_memory)
    return resource_exhausted("the job's process held " + mib(rss_bytes) + " MiB, over its limit of " +
                              mib(options.memory_bytes) + " MiB (--job-memory-mib), " + where + "; not retried");
  if (WIFSIGNALED(wait_status) && WTERMSIG(wait_status) == SIGXCPU)
    return resource_exhausted("the job used its CPU time limit of " + std::to_string(std::lround(options.cpu_seconds)) +
                              " s (--job-cpu-seconds, all threads together) " + where + "; not retried");
  if (WIFSIGNALED(wait_status))
    return internal_error("the remesh process died on this job: " + signal_name(WTERMSIG(wait_status)) + " " + where +
                          "; not retried");
  if (WIFEXITED(wait_status))
    return internal_error("the remesh process exited with status " + std::to_string(WEXITSTATUS(wait_status)) +
                          " on this job " + where + "; not retried");
  return internal_error("the remesh process stopped answering on this job " + where + "; not retried");
}

StatusOr<std::unique_ptr<JobProcess>> JobProcess::start(const JobProcessOptions& options, const WorkerContext& ctx) {
  int sv[2];
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
    return internal_error(std::string("cannot create the job process's channel: ") + std::strerror(errno));
  // Everything the child needs is ready before fork: between fork and exec
  // it may only make async-signal-safe calls (the parent has other threads).
  std::string exe = options.exe, flag = "--job-process", fd_text = "3", jobs_flag = "--host-jobs", jobs_fd = "4";
  char name[4096] = {0};  // argv[0]: the binary's own path, for ps and the logs
  if (readlink(exe.c_str(), name, sizeof name - 1) <= 0) std::snprintf(name, sizeof name, "%s", exe.c_str());
  const bool count = options.host_jobs_fd >= 0;  // at 10 or above (HostJobCount::create)
  char* argv[] = {name, flag.data(), fd_text.data(), count ? jobs_flag.data() : nullptr, jobs_fd.data(), nullptr};
  const pid_t pid = fork();
  if (pid < 0) {
    const int err = errno;
    close(sv[0]);
    close(sv[1]);
    return resource_exhausted(std::string("cannot start a job process: ") + std::strerror(err));
  }
  if (pid == 0) {
    // dup2 clears close-on-exec on the copy; on fd 3 itself, clear it by hand.
    if (sv[1] == 3 ? fcntl(3, F_SETFD, 0) != 0 : dup2(sv[1], 3) != 3) _exit(127);
    if (count && dup2(options.host_jobs_fd, 4) != 4) _exit(127);
    sigset_t none;  // the server blocks SIGTERM/SIGINT in its threads; the job process takes them
    sigemptyset(&none);
    pthread_sigmask(SIG_SETMASK, &none, nullptr);
    execv(exe.c_str(), argv);
    _exit(127);
  }
  close(sv[1]);
  std::unique_ptr<JobProcess> process(new JobProcess(options, pid, sv[0]));
  Frame ready;
  if (!write_frame(process->fd_, FrameType::kInit, encode_init(ctx, options)) ||
      !read_frame(process->fd_, &ready)) {
    const int status = process->reap();
    return unavailable("the job process (" + options.exe + " --job-process) ended before it was ready: " +
                       crash_status(status, "start", options, 0, false).message());
  }
  if (ready.type == FrameType::kInitFailed) return unavailable(ready.payload);
  if (ready.type != FrameType::kReady) return internal_error("the job process answered its start with a wrong frame");
  process->renderer_ = ready.payload;
  return process;
}

JobProcess::~JobProcess() {
  if (fd_ >= 0) close(fd_);  // end of stream: the process's loop ends and it exits
  if (pid_ > 0) reap();
}

int JobProcess::reap() {
  int status = 0;
  // A process that has closed its end is dying: give it a moment, then kill it.
  const auto give_up = std::chrono::steady_clock::now() + seconds(5);
  while (true) {
    const pid_t r = waitpid(pid_, &status, WNOHANG);
    if (r == pid_ || (r < 0 && errno != EINTR)) break;
    if (std::chrono::steady_clock::now() > give_up) {
      kill(pid_, SIGKILL);
      while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
      }
      break;
    }
    std::this_thread::sleep_for(milliseconds(10));
  }
  pid_ = -1;
  return status;
}

bool JobProcess::alive() {
  if (pid_ <= 0) return false;
  int status = 0;
  if (waitpid(pid_, &status, WNOHANG) != pid_) return true;
  spdlog::warn("job process {} ended while idle ({})", pid_,
               crash_status(status, "idle", options_, 0, false).message());
  pid_ = -1;
  return false;
}

JobProcess::Outcome JobProcess::run(JobQueue& queue, const std::string& id, const std::string& job_frame,
                                    ServiceMetrics* metrics, bool last_try) {
  std::string step = "start";
  bool ended = false;     // the job's last event has been published
  bool answered = false;  // the process has sent something for this job
  bool alive = write_frame(fd_, FrameType::kJob, job_frame);

  size_t peak_rss = 0;
  bool killed_for_memory = false, killed_after_cancel = false;
  auto next_cancel_check = Clock::now() + seconds(1);
  std::optional<Clock::time_point> cancel_seen;
  while (alive) {
    pollfd p{fd_, POLLIN, 0};
    const int ready = poll(&p, 1, kPollMs);
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      // Watchdogs: memory (where RLIMIT_AS cannot be used) and cancellation.
      if (options_.memory_bytes > 0) {
        peak_rss = std::max(peak_rss, resident_bytes(pid_));
        if (peak_rss > options_.memory_bytes && !killed_for_memory) {
          killed_for_memory = true;
          kill(pid_, SIGKILL);
        }
      }
      if (Clock::now() >= next_cancel_check) {
        next_cancel_check = Clock::now() + seconds(1);
        if (!queue.cancellation(id)) {
          cancel_seen.reset();
        } else if (!cancel_seen) {
          cancel_seen = Clock::now();
        } else if (Clock::now() - *cancel_seen > kCancelGrace && !killed_after_cancel) {
          killed_after_cancel = true;
          kill(pid_, SIGKILL);
        }
      }
      continue;
    }
    Frame f;
    if (!read_frame(fd_, &f)) break;
    answered = true;
    switch (f.type) {
      case FrameType::kEvent: {
        v1::JobEvent e;
        if (!e.ParseFromString(f.payload)) {
          alive = false;
          break;
        }
        ended = ended || is_terminal(e);
        observe(metrics, e);
        queue.publish(id, std::move(e));
        break;
      }
      case FrameType::kStep:
        step = f.payload;
        break;
      case FrameType::kCancelQuery: {
        const std::optional<Status> why = queue.cancellation(id);
        FieldWriter w;
        w.u64(why ? uint64_t(why->code()) : 0).str(why ? why->message() : "");
        alive = write_frame(fd_, FrameType::kCancelAnswer, w.take());
        break;
      }
      case FrameType::kJobDone:
        if (!ended) queue.fail_crashed(id, internal_error("the job process returned without ending job " + id));
        return Outcome::kEnded;
      default:
        alive = false;  // not a frame of this protocol: the process is not well
    }
  }

  // The process died (or broke the protocol: then it is killed here).
  kill(pid_, SIGKILL);
  const pid_t pid = pid_;
  const int status = reap();
  close(fd_);
  fd_ = -1;
  if (!answered && !last_try) {
    spdlog::warn("job {}: process {} died before it took the job ({}); running it in a new one", id, pid,
                 crash_status(status, "idle", options_, 0, false).message());
    return Outcome::kNotTaken;
  }
  if (!ended) {
    if (killed_after_cancel) {
      const std::optional<Status> why = queue.cancellation(id);
      v1::JobEvent e;
      *e.mutable_cancelled() = to_failure(why ? *why : Status(StatusCode::kCancelled, "cancelled"));
      queue.publish(id, std::move(e));
    } else {
      queue.fail_crashed(id, crash_status(status, step, options_, peak_rss, killed_for_memory));
    }
  }
  spdlog::error("job {}: its process {} ended in stage {} ({}); starting another", id, pid, step,
                crash_status(status, step, options_, peak_rss, killed_for_memory).message());
  return Outcome::kProcessDied;
}

}  // namespace vpr::service
