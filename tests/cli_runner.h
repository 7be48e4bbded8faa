// Runs the real `vpremesh` binary (VPR_CLI_PATH, set by the test's CMake) and
// the helpers the CLI and service tests share.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace vpr::testing {

struct CliRun {
  int code = -1;
  std::string out, err;
  std::string all() const { return out + err; }
};

// Runs `vpremesh ARGS` (a shell command line), stdout and stderr apart.
// stderr goes to `err_path` when one is given (and stays there, so that a test
// can watch the client's progress while it runs), else to a temporary file.
inline CliRun run_cli(const std::string& args, std::string err_path = {}) {
  static std::atomic<int> counter{0};
  const bool keep_err = !err_path.empty();
  if (!keep_err)
    err_path = (std::filesystem::temp_directory_path() /
                ("vpremesh_cli_err_" + std::to_string(::getpid()) + "_" + std::to_string(counter++)))
                   .string();
  const std::string cmd = std::string(VPR_CLI_PATH) + " " + args + " 2>" + err_path;
  CliRun r;
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
  const int status = ::pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream err(err_path, std::ios::binary);
  r.err.assign(std::istreambuf_iterator<char>(err), std::istreambuf_iterator<char>());
  if (!keep_err) std::filesystem::remove(err_path);
  return r;
}

// "127.0.0.1:PORT" of a loopback port that was free a moment ago and that
// nothing listens on (bound, then closed).
inline std::string closed_loopback_address() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return "";
  }
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return "127.0.0.1:" + std::to_string(ntohs(addr.sin_port));
}

}  // namespace vpr::testing
