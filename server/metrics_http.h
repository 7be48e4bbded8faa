// Serves /metrics over HTTP with civetweb (libcivetweb-dev).
#pragma once

#include <functional>
#include <string>

#include "pipeline/status.h"

struct mg_context;
struct mg_connection;

namespace vpr::service {

class MetricsHttpServer {
 public:
  MetricsHttpServer() = default;
  MetricsHttpServer(const MetricsHttpServer&) = delete;
  MetricsHttpServer& operator=(const MetricsHttpServer&) = delete;
  ~MetricsHttpServer();

  // listen: "HOST:PORT" (PORT 0 picks a free one). render is called on
  // civetweb's threads for each GET /metrics. Returns the port bound.
  StatusOr<int> start(const std::string& listen, std::function<std::string()> render);
  void stop();

 private:
  static int handle(::mg_connection* conn, void* self);
  mg_context* ctx_ = nullptr;
  std::function<std::string()> render_;
};

}  // namespace vpr::service
