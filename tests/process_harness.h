// A child process for the end-to-end tests: started with fork/exec, its
// stdout and stderr (merged) collected as it runs, waited on by what it prints
// or by its exit, and always killed by the destructor, so a failing test
// leaves nothing behind.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace vpr::testing {

class ChildProcess {
 public:
  // argv[0] is the executable's path; env holds "NAME=VALUE" entries added to
  // (or replacing) this process's environment. The child dies with this
  // process (PR_SET_PDEATHSIG: with the thread that started it, so start
  // long-lived children from the test's main thread) and dumps no core.
  explicit ChildProcess(std::vector<std::string> argv, const std::vector<std::string>& env = {}) {
    std::vector<std::string> environment;
    for (char** e = environ; *e; ++e) {
      const std::string entry = *e;
      const std::string name = entry.substr(0, entry.find('='));
      bool replaced = false;
      for (const std::string& extra : env) replaced |= extra.substr(0, extra.find('=')) == name;
      if (!replaced) environment.push_back(entry);
    }
    environment.insert(environment.end(), env.begin(), env.end());
    std::vector<char*> args, envp;
    for (std::string& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    for (std::string& e : environment) envp.push_back(e.data());
    envp.push_back(nullptr);

    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) return;
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(127);
      const rlimit no_core{0, 0};
      ::setrlimit(RLIMIT_CORE, &no_core);
      ::setpgid(0, 0);  // Ctrl-C in the terminal reaches the test, which kills its children
      ::dup2(fds[1], 1);
      ::dup2(fds[1], 2);
      ::execve(args[0], args.data(), envp.data());
      ::_exit(127);
    }
    ::close(fds[1]);
    if (pid_ < 0) {
      ::close(fds[0]);
      return;
    }
    reader_ = std::thread([this, fd = fds[0]] { read_output(fd); });
    reaper_ = std::thread([this] { reap(); });
  }

  ~ChildProcess() {
    kill(SIGKILL);
    if (reaper_.joinable()) reaper_.join();
    stop_reading_ = true;
    if (reader_.joinable()) reader_.join();
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool started() const { return pid_ > 0; }
  pid_t pid() const { return pid_; }

  // Everything the process printed so far.
  std::string output() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return output_;
  }

  // Sends a signal unless the process has been reaped (so never to a reused pid).
  void kill(int signal) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (pid_ > 0 && !exit_code_) ::kill(pid_, signal);
  }

  bool running() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return pid_ > 0 && !exit_code_;
  }

  // The exit code, or -signal when a signal ended it; nullopt while it runs.
  std::optional<int> exit_code() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return exit_code_;
  }

  // Waits until `ready(output)` holds; false when the process ended (and its
  // output was read to the end) without it, or after `limit`.
  bool wait_for_output(const std::function<bool(const std::string&)>& ready, std::chrono::milliseconds limit) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, limit, [&] { return ready(output_) || (eof_ && exit_code_); }) && ready(output_);
  }
  bool wait_for_text(const std::string& text, std::chrono::milliseconds limit) {
    return wait_for_output([&](const std::string& out) { return out.find(text) != std::string::npos; }, limit);
  }

  // Waits for the exit (after `limit`, SIGKILL), and for the rest of its
  // output, so output() is complete. Returns the exit code, or -signal when a
  // signal ended it.
  int wait(std::chrono::milliseconds limit) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (pid_ <= 0) return -SIGKILL;
    if (!changed_.wait_for(lock, limit, [&] { return exit_code_.has_value(); })) {
      ::kill(pid_, SIGKILL);
      changed_.wait(lock, [&] { return exit_code_.has_value(); });
    }
    // A grandchild may hold the pipe open: not for long.
    changed_.wait_for(lock, std::chrono::seconds(10), [&] { return eof_; });
    return *exit_code_;
  }

  // SIGTERM, then wait() with `limit`.
  int terminate(std::chrono::milliseconds limit) {
    kill(SIGTERM);
    return wait(limit);
  }

 private:
  void read_output(int fd) {
    char buf[4096];
    // poll with a timeout: a grandchild that inherited the pipe must not
    // keep the destructor waiting.
    while (!stop_reading_) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      const ssize_t n = ::read(fd, buf, sizeof buf);
      if (n <= 0) break;
      std::lock_guard<std::mutex> lock(mutex_);
      output_.append(buf, size_t(n));
      changed_.notify_all();
    }
    ::close(fd);
    std::lock_guard<std::mutex> lock(mutex_);
    eof_ = true;
    changed_.notify_all();
  }

  // Waits for the exit without reaping, then reaps under the lock: kill()
  // never races with the pid being freed.
  void reap() {
    siginfo_t info{};
    while (::waitid(P_PID, id_t(pid_), &info, WEXITED | WNOWAIT) != 0 && errno == EINTR) {
    }
    std::lock_guard<std::mutex> lock(mutex_);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
    changed_.notify_all();
  }

  pid_t pid_ = -1;
  std::thread reader_, reaper_;
  std::atomic<bool> stop_reading_{false};
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::string output_;
  bool eof_ = false;
  std::optional<int> exit_code_;
};

}  // namespace vpr::testing
