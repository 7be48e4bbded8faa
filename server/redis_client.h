// A thread-safe Redis client on hiredis (Debian's libhiredis 0.14): a pool of
// blocking connections, one borrowed per command. A connection that fails
// (I/O error, timeout, Redis restarting) is dropped and the command returns
// UNAVAILABLE naming the URL; the next command connects afresh, so callers
// retry by calling again (the queue does, with backoff).
#pragma once

#include <hiredis/hiredis.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"

namespace vpr::service {

// redis://[[USER]:PASSWORD@]HOST[:PORT][/DB]: USER is a Redis 6 ACL user
// (AUTH USER PASSWORD); without it, the default user (AUTH PASSWORD).
struct RedisEndpoint {
  std::string host;
  int port = 6379;
  int db = 0;
  std::string user;
  std::string password;
  // The URL without the password (the user is kept), for messages and logs.
  std::string url() const;
};

// INVALID_ARGUMENT naming what is wrong with `url`.
StatusOr<RedisEndpoint> parse_redis_url(const std::string& url);

// One reply; owns the hiredis object.
class RedisReply {
 public:
  RedisReply() = default;
  explicit RedisReply(redisReply* r) : r_(r, freeReplyObject) {}
  const redisReply* get() const { return r_.get(); }
  const redisReply* operator->() const { return r_.get(); }

 private:
  std::shared_ptr<redisReply> r_;
};

// Reading replies.
bool is_nil(const redisReply* r);
std::string as_string(const redisReply* r);  // STRING / STATUS; "" otherwise
int64_t as_int(const redisReply* r);         // INTEGER, or a STRING holding a number; 0 otherwise
size_t array_size(const redisReply* r);      // 0 unless ARRAY
const redisReply* element(const redisReply* r, size_t i);

class RedisClient {
 public:
  explicit RedisClient(RedisEndpoint endpoint,
                       std::chrono::milliseconds command_timeout = std::chrono::seconds(30));
  ~RedisClient();
  RedisClient(const RedisClient&) = delete;
  RedisClient& operator=(const RedisClient&) = delete;

  // Runs one command. UNAVAILABLE when Redis cannot be reached or is still
  // loading its data; INTERNAL for any other error reply (with Redis' text).
  StatusOr<RedisReply> command(const std::vector<std::string_view>& args);
  // EVAL script with these keys and arguments.
  StatusOr<RedisReply> eval(std::string_view script, const std::vector<std::string>& keys,
                            const std::vector<std::string_view>& args);

  const RedisEndpoint& endpoint() const { return endpoint_; }

 private:
  StatusOr<redisContext*> connect();
  void give_back(redisContext* c, bool healthy);
  Status unreachable(const std::string& why) const;

  RedisEndpoint endpoint_;
  std::chrono::milliseconds timeout_;
  std::mutex mu_;
  std::vector<redisContext*> idle_;
};

}  // namespace vpr::service
