// The count of a server's busy job processes, on one page of shared memory
// that the server writes and its job processes read (core/running_jobs.h).
// Jobs in one process split their loops by their share of its threads; job
// processes are separate thread pools on the same cores, and without the
// count each split its loops for the whole host, as if it ran alone.
#pragma once

#include <atomic>
#include <memory>

#include "core/status.h"

namespace vpr::service {

class HostJobCount {
 public:
  // A new count of 0, in a memfd that job processes inherit (close-on-exec:
  // the child dup2s it to the descriptor it is told).
  static StatusOr<std::unique_ptr<HostJobCount>> create();
  ~HostJobCount();
  HostJobCount(const HostJobCount&) = delete;
  HostJobCount& operator=(const HostJobCount&) = delete;

  int fd() const { return fd_; }
  void set(int jobs) { count_->store(jobs, std::memory_order_relaxed); }
  int get() const { return count_->load(std::memory_order_relaxed); }

  // In a job process: maps the count the server handed down as `fd`, for the
  // rest of the process's life. Null (and the reason logged) when it cannot.
  static const std::atomic<int>* attach(int fd);

 private:
  HostJobCount(int fd, std::atomic<int>* count) : fd_(fd), count_(count) {}
  int fd_;
  std::atomic<int>* count_;
};

}  // namespace vpr::service
