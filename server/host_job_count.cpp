#include "server/host_job_count.h"

#include <spdlog/spdlog.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

namespace vpr::service {
namespace {

// A std::atomic<int> in memory two processes map works only when it is a
// plain lock-free word.
static_assert(std::atomic<int>::is_always_lock_free);
static_assert(sizeof(std::atomic<int>) == sizeof(int));

void* map_count(int fd) {
  void* page = mmap(nullptr, sizeof(std::atomic<int>), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  return page == MAP_FAILED ? nullptr : page;
}

}  // namespace

StatusOr<std::unique_ptr<HostJobCount>> HostJobCount::create() {
  const int made = memfd_create("vpremesh-host-jobs", MFD_CLOEXEC);
  if (made < 0) return internal_error(std::string("cannot create the job count's memory: ") + std::strerror(errno));
  // Above the descriptors a job process is given (3: its channel, 4: this),
  // so that moving the channel to 3 in the child never closes this one.
  const int fd = fcntl(made, F_DUPFD_CLOEXEC, 10);
  close(made);
  if (fd < 0) return internal_error(std::string("cannot move the job count's descriptor: ") + std::strerror(errno));
  void* page = nullptr;
  if (ftruncate(fd, sizeof(std::atomic<int>)) != 0 || !(page = map_count(fd))) {
    const int err = errno;
    close(fd);
    return internal_error(std::string("cannot map the job count's memory: ") + std::strerror(err));
  }
  auto* count = new (page) std::atomic<int>(0);
  return std::unique_ptr<HostJobCount>(new HostJobCount(fd, count));
}

HostJobCount::~HostJobCount() {
  munmap(count_, sizeof(std::atomic<int>));
  close(fd_);
}

const std::atomic<int>* HostJobCount::attach(int fd) {
  void* page = map_count(fd);
  if (!page) {
    spdlog::warn("cannot map the server's job count ({}): loops split as if this job ran alone",
                 std::strerror(errno));
    return nullptr;
  }
  close(fd);  // the mapping stays
  return static_cast<const std::atomic<int>*>(page);
}

}  // namespace vpr::service
