#include "server/redis_client.h"

#include <sys/time.h>

#include <cstdlib>

namespace vpr::service {
namespace {

timeval to_timeval(std::chrono::milliseconds ms) {
  timeval tv;
  tv.tv_sec = ms.count() / 1000;
  tv.tv_usec = (ms.count() % 1000) * 1000;
  return tv;
}

bool all_digits(const std::string& s) {
  return !s.empty() && s.size() <= 9 && s.find_first_not_of("0123456789") == std::string::npos;
}

}  // namespace

std::string RedisEndpoint::url() const {
  return "redis://" + (user.empty() ? "" : user + "@") + host + ":" + std::to_string(port) +
         (db ? "/" + std::to_string(db) : "");
}

StatusOr<RedisEndpoint> parse_redis_url(const std::string& url) {
  const std::string scheme = "redis://";
  // Messages show the URL with its password blanked out: they reach logs.
  std::string shown = url;
  if (const size_t at = shown.rfind('@'), colon = shown.find(':', scheme.size());
      at != std::string::npos && colon != std::string::npos && colon < at)
    shown.replace(colon + 1, at - colon - 1, "***");
  auto bad = [&](const std::string& why) {
    return invalid_argument("queue URL '" + shown + "': " + why +
                            " (expected redis://[[USER]:PASSWORD@]HOST[:PORT][/DB])");
  };
  if (url.rfind("rediss://", 0) == 0)
    return bad("TLS to Redis (rediss://) needs hiredis 1.x with SSL, and Debian 12 ships 0.14; reach Redis through "
               "a TLS tunnel on this host (docs/security.md)");
  if (url.rfind(scheme, 0) != 0) return bad("must start with redis://");
  std::string rest = url.substr(scheme.size());
  RedisEndpoint e;
  if (const size_t at = rest.rfind('@'); at != std::string::npos) {
    std::string auth = rest.substr(0, at);
    rest = rest.substr(at + 1);
    const size_t colon = auth.find(':');
    if (colon == std::string::npos || colon + 1 == auth.size())
      return bad("credentials must be ':PASSWORD' or 'USER:PASSWORD'");
    e.user = auth.substr(0, colon);
    e.password = auth.substr(colon + 1);
  }
  if (const size_t slash = rest.find('/'); slash != std::string::npos) {
    const std::string db = rest.substr(slash + 1);
    rest = rest.substr(0, slash);
    if (!db.empty()) {
      if (!all_digits(db)) return bad("database '" + db + "' is not a number");
      e.db = std::atoi(db.c_str());
    }
  }
  std::string host = rest;
  if (!rest.empty() && rest[0] == '[') {  // [IPv6]:PORT
    const size_t close = rest.find(']');
    if (close == std::string::npos) return bad("unclosed '['");
    host = rest.substr(1, close - 1);
    rest = rest.substr(close + 1);
    if (!rest.empty() && rest[0] != ':') return bad("expected ':' after ']'");
    if (!rest.empty()) rest = rest.substr(1);
    else rest.clear();
    if (!rest.empty()) {
      if (!all_digits(rest) || std::atoi(rest.c_str()) > 65535) return bad("port '" + rest + "' is not in [1, 65535]");
      e.port = std::atoi(rest.c_str());
    }
  } else if (const size_t colon = rest.rfind(':'); colon != std::string::npos) {
    host = rest.substr(0, colon);
    const std::string port = rest.substr(colon + 1);
    if (!all_digits(port) || std::atoi(port.c_str()) < 1 || std::atoi(port.c_str()) > 65535)
      return bad("port '" + port + "' is not in [1, 65535]");
    e.port = std::atoi(port.c_str());
  }
  if (host.empty()) return bad("no host");
  e.host = host;
  return e;
}

bool is_nil(const redisReply* r) {
  return r == nullptr || r->type == REDIS_REPLY_NIL;
}

std::string as_string(const redisReply* r) {
  if (r && (r->type == REDIS_REPLY_STRING || r->type == REDIS_REPLY_STATUS)) return std::string(r->str, r->len);
  return {};
}

int64_t as_int(const redisReply* r) {
  if (!r) return 0;
  if (r->type == REDIS_REPLY_INTEGER) return r->integer;
  if (r->type == REDIS_REPLY_STRING) return std::strtoll(std::string(r->str, r->len).c_str(), nullptr, 10);
  return 0;
}

size_t array_size(const redisReply* r) {
  return r && r->type == REDIS_REPLY_ARRAY ? r->elements : 0;
}

const redisReply* element(const redisReply* r, size_t i) {
  return i < array_size(r) ? r->element[i] : nullptr;
}

RedisClient::RedisClient(RedisEndpoint endpoint, std::chrono::milliseconds command_timeout)
    : endpoint_(std::move(endpoint)), timeout_(command_timeout) {}

RedisClient::~RedisClient() {
  for (redisContext* c : idle_) redisFree(c);
}

Status RedisClient::unreachable(const std::string& why) const {
  return unavailable("the job queue " + endpoint_.url() + " is unreachable: " + why);
}

StatusOr<redisContext*> RedisClient::connect() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (!idle_.empty()) {
      redisContext* c = idle_.back();
      idle_.pop_back();
      return c;
    }
  }
  // Connecting is quick or hopeless: a short timeout keeps RPCs responsive
  // while Redis is down.
  redisContext* c = redisConnectWithTimeout(endpoint_.host.c_str(), endpoint_.port,
                                            to_timeval(std::min(timeout_, std::chrono::milliseconds(2000))));
  if (c == nullptr) return unreachable("cannot allocate a connection");
  if (c->err) {
    Status s = unreachable(c->errstr);
    redisFree(c);
    return s;
  }
  redisSetTimeout(c, to_timeval(timeout_));
  redisEnableKeepAlive(c);
  auto setup = [&](std::vector<std::string> args) -> Status {
    std::vector<const char*> argv;
    std::vector<size_t> len;
    for (const std::string& a : args) {
      argv.push_back(a.data());
      len.push_back(a.size());
    }
    auto* r = static_cast<redisReply*>(redisCommandArgv(c, int(argv.size()), argv.data(), len.data()));
    if (r == nullptr) return unreachable(c->errstr);
    RedisReply reply(r);
    if (r->type == REDIS_REPLY_ERROR) return unavailable("the job queue " + endpoint_.url() + " refused " + args[0] + ": " + std::string(r->str, r->len));
    return Status::Ok();
  };
  Status s;
  if (!endpoint_.user.empty())
    s = setup({"AUTH", endpoint_.user, endpoint_.password});  // a Redis 6 ACL user
  else if (!endpoint_.password.empty())
    s = setup({"AUTH", endpoint_.password});
  if (s.ok() && endpoint_.db != 0) s = setup({"SELECT", std::to_string(endpoint_.db)});
  if (!s.ok()) {
    redisFree(c);
    return s;
  }
  return c;
}

void RedisClient::give_back(redisContext* c, bool healthy) {
  if (!healthy) {
    redisFree(c);
    return;
  }
  std::lock_guard<std::mutex> lock(mu_);
  idle_.push_back(c);
}

StatusOr<RedisReply> RedisClient::command(const std::vector<std::string_view>& args) {
  auto c = connect();
  if (!c.ok()) return c.status();
  std::vector<const char*> argv;
  std::vector<size_t> len;
  argv.reserve(args.size());
  len.reserve(args.size());
  for (std::string_view a : args) {
    argv.push_back(a.data());
    len.push_back(a.size());
  }
  auto* r = static_cast<redisReply*>(redisCommandArgv(*c, int(argv.size()), argv.data(), len.data()));
  if (r == nullptr) {
    Status s = unreachable((*c)->errstr);
    give_back(*c, false);
    return s;
  }
  RedisReply reply(r);
  give_back(*c, true);
  if (r->type == REDIS_REPLY_ERROR) {
    const std::string text(r->str, r->len);
    // While Redis replays its append-only file it answers LOADING: a restart
    // in progress, not a bad command.
    if (text.rfind("LOADING", 0) == 0 || text.rfind("MASTERDOWN", 0) == 0) return unreachable(text);
    return internal_error("Redis " + std::string(args.empty() ? "" : args[0]) + " failed: " + text);
  }
  return reply;
}

StatusOr<RedisReply> RedisClient::eval(std::string_view script, const std::vector<std::string>& keys,
                                       const std::vector<std::string_view>& args) {
  const std::string nkeys = std::to_string(keys.size());
  std::vector<std::string_view> argv = {"EVAL", script, nkeys};
  for (const std::string& k : keys) argv.push_back(k);
  argv.insert(argv.end(), args.begin(), args.end());
  return command(argv);
}

}  // namespace vpr::service
