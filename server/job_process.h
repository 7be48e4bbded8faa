// Jobs in supervised child processes: a crash costs one job, never the
// server or the other jobs of a worker (issue 23).
//
// Each worker thread of a WorkerPool owns one job process: the same binary
// started again with `--job-process FD` (job_process_main), which creates
// its own renderer and CUDA context once and then runs the jobs the thread
// hands it, one at a time, through run_job. The thread relays the process's
// events to the queue and answers its cancellation queries, so the queue,
// uploads and results stay in the parent. When the process dies, the thread
// fails the job it was running with the signal and the step it was in (with
// a shared queue, to the dead-letter stream: JobQueue::fail_crashed), and
// starts a new process for the next job. Each process also maps the pool's
// count of busy job processes (server/host_job_count.h), so that its loops
// split by its job's share of the host's cores.
//
// Limits per job process: CPU seconds per job (RLIMIT_CPU, raised by the
// job's allowance at each job's start) and memory (RLIMIT_AS where the
// process does not use CUDA, whose driver reserves address space by the
// size of the GPU; everywhere a resident-set watchdog in the parent). Past
// either, the job fails RESOURCE_EXHAUSTED naming the limit and its flag.
#pragma once

#include <sys/types.h>

#include <memory>
#include <string>

#include "server/job_queue.h"
#include "server/service_metrics.h"
#include "server/worker_pool.h"

namespace vpr::service {

// Where a job process finds its channel and the server's job count.
struct JobProcessFds {
  int channel = -1;
  int host_jobs = -1;  // -1: none (HostJobCount)
};

// Reads `--job-process FD [--host-jobs FD]` from a main()'s arguments: true
// (and *fds set) when this process is a job process and must run
// job_process_main(*fds).
bool is_job_process(int argc, char** argv, JobProcessFds* fds);

// The job process's whole life: read kInit, create the renderer, then run
// each kJob and answer kJobDone, until the channel closes. Returns the exit
// code.
int job_process_main(const JobProcessFds& fds);

// The crash report for a job whose process ended: the status the job fails
// with. `wait_status` is waitpid's; `step` the step it was in.
Status crash_status(int wait_status, const std::string& step, const JobProcessOptions& options, size_t rss_bytes,
                    bool killed_for_memory);

class JobProcess {
 public:
  // Starts a job process for the worker `ctx` describes and waits until it
  // has its renderer. The error says why it has none.
  static StatusOr<std::unique_ptr<JobProcess>> start(const JobProcessOptions& options, const WorkerContext& ctx);
  ~JobProcess();  // closes the channel: the process exits; reaped (killed after a grace)
  JobProcess(const JobProcess&) = delete;
  JobProcess& operator=(const JobProcess&) = delete;

  const std::string& renderer_description() const { return renderer_; }
  pid_t pid() const { return pid_; }

  // False when the process has ended (killed while it waited for a job):
  // it must be replaced, and no job is lost.
  bool alive();

  enum class Outcome {
    kEnded,          // the job ended; the process is ready for the next one
    kProcessDied,    // the job ended with the crash report; replace the process
    kNotTaken,       // the process died before it took the job (killed while
                     // idle, and still exiting): the job has not started and
                     // may run in a new process; replace this one
  };
  // Runs one job (job_frame: encode_job's payload) in the process,
  // publishing its events to `queue` and observing them in `metrics` (may
  // be null). With last_try, kNotTaken is reported as kProcessDied, the job
  // failed like any crash.
  Outcome run(JobQueue& queue, const std::string& job_id, const std::string& job_frame, ServiceMetrics* metrics,
              bool last_try);

 private:
  JobProcess(const JobProcessOptions& options, pid_t pid, int fd) : options_(options), pid_(pid), fd_(fd) {}
  int reap();  // waits for the process to end (SIGKILL after a grace); waitpid's status

  JobProcessOptions options_;
  pid_t pid_ = -1;
  int fd_ = -1;
  std::string renderer_;
};

}  // namespace vpr::service
