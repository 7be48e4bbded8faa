// Where the Redis queue keeps job uploads: the seam for object storage.
// RedisBlobStore (the default) keeps them in Redis next to the job; an S3 or
// GCS store implements the same three calls and Redis then holds only the
// job's key. RedisQueue calls put() before the job is queued, get() when a
// worker claims it and remove() when it ends (put's TTL covers anything a
// crash leaves behind).
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <string_view>

#include "server/redis_client.h"

namespace vpr::service {

class BlobStore {
 public:
  virtual ~BlobStore() = default;
  virtual Status put(const std::string& key, std::string_view bytes, std::chrono::milliseconds ttl) = 0;
  // nullopt when the blob is missing or expired.
  virtual StatusOr<std::optional<std::string>> get(const std::string& key) = 0;
  virtual Status remove(const std::string& key) = 0;
};

class RedisBlobStore final : public BlobStore {
 public:
  explicit RedisBlobStore(RedisClient& client) : client_(client) {}
  Status put(const std::string& key, std::string_view bytes, std::chrono::milliseconds ttl) override {
    return client_.command({"SET", key, bytes, "PX", std::to_string(std::max<int64_t>(1, ttl.count()))}).status();
  }
  StatusOr<std::optional<std::string>> get(const std::string& key) override {
    auto r = client_.command({"GET", key});
    if (!r.ok()) return r.status();
    if (is_nil(r->get())) return std::optional<std::string>();
    return std::optional<std::string>(as_string(r->get()));
  }
  Status remove(const std::string& key) override { return client_.command({"DEL", key}).status(); }

 private:
  RedisClient& client_;
};

}  // namespace vpr::service
