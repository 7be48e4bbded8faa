#include "server/metrics_http.h"

#include <civetweb.h>

#include <cstring>
#include <mutex>

namespace vpr::service {

MetricsHttpServer::~MetricsHttpServer() {
  stop();
}

StatusOr<int> MetricsHttpServer::start(const std::string& listen, std::function<std::string()> render) {
  static std::once_flag init;
  std::call_once(init, [] { mg_init_library(0); });
  render_ = std::move(render);
  // civetweb takes "HOST:PORT" for IPv4; "[::1]:PORT" needs a '+' or 'r' suffix
  // for IPv6, which we leave to civetweb's own parser.
  const char* options[] = {"listening_ports", listen.c_str(), "num_threads", "2", nullptr};
  mg_callbacks callbacks;
  std::memset(&callbacks, 0, sizeof callbacks);
  ctx_ = mg_start(&callbacks, this, options);
  if (!ctx_) return unavailable("cannot serve metrics on " + listen + " (--metrics-listen): address in use or invalid");
  mg_set_request_handler(ctx_, "/metrics", &MetricsHttpServer::handle, this);
  mg_server_port ports[4];
  std::memset(ports, 0, sizeof ports);
  const int n = mg_get_server_ports(ctx_, 4, ports);
  return n > 0 ? ports[0].port : 0;
}

void MetricsHttpServer::stop() {
  if (ctx_) mg_stop(ctx_);
  ctx_ = nullptr;
}

int MetricsHttpServer::handle(::mg_connection* conn, void* self) {
  const std::string body = static_cast<MetricsHttpServer*>(self)->render_();
  mg_printf(conn,
            "HTTP/1.1 200 OK\r\nContent-Type: text/plain; version=0.0.4; charset=utf-8\r\n"
            "Content-Length: %zu\r\nConnection: close\r\n\r\n",
            body.size());
  mg_write(conn, body.data(), body.size());
  return 200;
}

}  // namespace vpr::service
