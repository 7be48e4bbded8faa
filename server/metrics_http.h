// Serves GET /metrics (Prometheus text format) over HTTP/1.1 for the server
// and the worker.
//
// Not civetweb: Debian's libcivetweb runs its handlers on threads with a
// fixed 100 KiB stack, and glibc carves a thread's static TLS out of that
// stack (prometheus-cpp's exposer is civetweb too). CGAL's thread_local scratch maps alone take 64 KiB of TLS in these
// binaries, so civetweb overflowed its stack on the first request and the
// process died (a Kubernetes liveness probe on /metrics killed every pod).
// One thread with the default stack answers the requests in turn: Prometheus
// and probes send one small GET every few seconds.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <thread>

#include "core/status.h"

namespace vpr::service {

class MetricsHttpServer {
 public:
  MetricsHttpServer() = default;
  MetricsHttpServer(const MetricsHttpServer&) = delete;
  MetricsHttpServer& operator=(const MetricsHttpServer&) = delete;
  ~MetricsHttpServer();

  // listen: "HOST:PORT" or "[IPv6]:PORT" (PORT 0 picks a free one). render
  // is called on the server's thread for each GET /metrics. Returns the port
  // bound; UNAVAILABLE naming --metrics-listen when it cannot bind.
  StatusOr<int> start(const std::string& listen, std::function<std::string()> render);
  void stop();

 private:
  void serve();
  void answer(int connection);

  int listener_ = -1;
  std::atomic<bool> stopping_{false};
  std::thread thread_;
  std::function<std::string()> render_;
};

}  // namespace vpr::service
