// What the Redis queue tests share: a real redis-server on a free loopback
// port (AOF on, so a SIGKILL loses nothing), a small hiredis client to look at
// its keys, and vpremesh-worker processes. Every process is killed by its
// destructor, so a failing test leaves nothing behind.
#pragma once

#include <hiredis/hiredis.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "process_harness.h"
#include "service_harness.h"

namespace vpr::testing {

inline constexpr const char* kNoRedisServer = "redis-server not found: run scripts/install-deps.sh";

// $VPR_REDIS_SERVER (when executable), else redis-server on $PATH or in the usual places; ""
// when there is none.
inline std::string find_redis_server() {
  if (const char* given = std::getenv("VPR_REDIS_SERVER"); given && *given)
    return ::access(given, X_OK) == 0 ? given : "";
  std::vector<std::string> dirs;
  if (const char* path = std::getenv("PATH")) {
    std::string p = path;
    for (size_t start = 0, end; start <= p.size(); start = end + 1) {
      end = p.find(':', start);
      if (end == std::string::npos) end = p.size();
      if (end > start) dirs.push_back(p.substr(start, end - start));
    }
  }
  for (const char* d : {"/usr/bin", "/usr/local/bin", "/usr/sbin", "/usr/local/sbin"}) dirs.push_back(d);
  for (const std::string& d : dirs) {
    const std::string candidate = d + "/redis-server";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return "";
}

// One reply, copied out of hiredis: a string (bulk, status or error), an
// integer, nil or an array.
struct RedisReply {
  int type = REDIS_REPLY_NIL;
  std::string str;
  long long integer = 0;
  std::vector<RedisReply> elements;

  bool is_error() const { return type == REDIS_REPLY_ERROR; }
  bool is_nil() const { return type == REDIS_REPLY_NIL; }
  // A flat [field, value, ...] array (a stream entry's fields, HGETALL) as a lookup.
  std::optional<std::string> field(const std::string& name) const {
    for (size_t i = 0; i + 1 < elements.size(); i += 2)
      if (elements[i].str == name) return elements[i + 1].str;
    return std::nullopt;
  }
};

// A blocking hiredis connection to 127.0.0.1:port.
class RedisClient {
 public:
  explicit RedisClient(int port) {
    context_ = ::redisConnectWithTimeout("127.0.0.1", port, timeval{5, 0});
    if (context_ && !context_->err) ::redisSetTimeout(context_, timeval{30, 0});
  }
  ~RedisClient() {
    if (context_) ::redisFree(context_);
  }
  RedisClient(const RedisClient&) = delete;
  RedisClient& operator=(const RedisClient&) = delete;

  bool connected() const { return context_ && !context_->err; }
  std::string error() const { return !context_ ? "out of memory" : context_->err ? context_->errstr : ""; }

  // nullopt when the connection failed (error() says why).
  std::optional<RedisReply> command(const std::vector<std::string>& args) {
    if (!connected()) return std::nullopt;
    std::vector<const char*> argv;
    std::vector<size_t> lengths;
    for (const std::string& a : args) {
      argv.push_back(a.data());
      lengths.push_back(a.size());
    }
    auto* reply = static_cast<redisReply*>(::redisCommandArgv(context_, int(argv.size()), argv.data(), lengths.data()));
    if (!reply) return std::nullopt;
    RedisReply out = copy(reply);
    ::freeReplyObject(reply);
    return out;
  }

 private:
  static RedisReply copy(const redisReply* r) {
    RedisReply out;
    out.type = r->type;
    if (r->type == REDIS_REPLY_INTEGER) out.integer = r->integer;
    if (r->str) out.str.assign(r->str, r->len);
    for (size_t i = 0; i < r->elements; ++i) out.elements.push_back(copy(r->element[i]));
    return out;
  }

  redisContext* context_ = nullptr;
};

// `redis-server` on 127.0.0.1:port with its data in dir: the append-only file
// fsynced on every write and no RDB snapshots, so a SIGKILL loses nothing
// and a restart on the same port and dir finds every key again.
class RedisProcess {
 public:
  RedisProcess(std::string executable, std::filesystem::path dir, int port)
      : executable_(std::move(executable)), dir_(std::move(dir)), port_(port) {
    std::filesystem::create_directories(dir_);
  }

  // Starts (or starts again) and waits until it answers PING: after it has
  // loaded its append-only file. False when it did not come up.
  bool start() {
    log_before_ += process_ ? process_->output() : "";
    process_ = std::make_unique<ChildProcess>(std::vector<std::string>{
        executable_, "--port", std::to_string(port_), "--bind", "127.0.0.1", "--dir", dir_.string(), "--appendonly",
        "yes", "--appendfsync", "always", "--save", "", "--daemonize", "no", "--logfile", "", "--loglevel", "notice"});
    if (!process_->wait_for_text("Ready to accept connections", kStartupLimit)) return false;
    RedisClient client(port_);
    auto pong = client.command({"PING"});
    return pong && pong->str == "PONG";
  }

  // SIGKILL and wait for the exit: the crash Redis must survive.
  void kill() {
    if (!process_) return;
    process_->kill(SIGKILL);
    process_->wait(kStartupLimit);
  }

  int port() const { return port_; }
  std::string url() const { return "redis://127.0.0.1:" + std::to_string(port_); }
  // Everything every run printed (for failure messages).
  std::string log() const { return log_before_ + (process_ ? process_->output() : ""); }

 private:
  std::string executable_;
  std::filesystem::path dir_;
  int port_;
  std::unique_ptr<ChildProcess> process_;
  std::string log_before_;
};

// `vpremesh-worker --queue URL FLAGS...`, ready once it prints
// "vpremesh-worker ready: N worker(s) on URL".
class WorkerProcess {
 public:
  WorkerProcess(const std::string& url, const std::vector<std::string>& flags, const std::vector<std::string>& env = {})
      : process_(arguments(url, flags), env) {
    ready_ = process_.wait_for_text("vpremesh-worker ready: ", kStartupLimit);
  }

  bool ready() const { return ready_; }
  pid_t pid() const { return process_.pid(); }
  std::string log() const { return process_.output(); }
  void kill(int signal) { process_.kill(signal); }
  bool running() const { return process_.running(); }
  std::optional<int> exit_code() const { return process_.exit_code(); }
  int wait() { return process_.wait(kJobLimit); }
  int terminate() { return process_.terminate(kJobLimit); }

 private:
  static std::vector<std::string> arguments(const std::string& url, const std::vector<std::string>& flags) {
    std::vector<std::string> args = {VPR_WORKER_PATH, "--queue", url};
    args.insert(args.end(), flags.begin(), flags.end());
    return args;
  }

  ChildProcess process_;
  bool ready_ = false;
};

// The pid in a worker name "HOST:PID/worker-I"; -1 when it has none.
inline pid_t worker_pid(const std::string& worker) {
  const std::string process = worker.substr(0, worker.find('/'));
  const size_t colon = process.rfind(':');
  if (colon == std::string::npos || colon + 1 == process.size()) return -1;
  char* end = nullptr;
  const long pid = std::strtol(process.c_str() + colon + 1, &end, 10);
  return *end == '\0' && pid > 0 ? pid_t(pid) : -1;
}

}  // namespace vpr::testing
