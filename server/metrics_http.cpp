#include "server/metrics_http.h"

#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace vpr::service {
namespace {

constexpr size_t kMaxRequestHead = 8192;  // a GET from Prometheus is a few hundred bytes
constexpr int kReadTimeoutS = 2;          // a client that stalls holds the thread no longer
constexpr int kWriteTimeoutS = 10;

bool write_all(int fd, const std::string& bytes) {
  for (size_t sent = 0; sent < bytes.size();) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return false;
    sent += size_t(n);
  }
  return true;
}

std::string response(const std::string& status, const std::string& type, const std::string& body, bool head_only) {
  std::string r = "HTTP/1.1 " + status + "\r\nContent-Type: " + type +
                  "\r\nContent-Length: " + std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n";
  if (!head_only) r += body;
  return r;
}

}  // namespace

MetricsHttpServer::~MetricsHttpServer() {
  stop();
}

StatusOr<int> MetricsHttpServer::start(const std::string& listen, std::function<std::string()> render) {
  auto refuse = [&](const std::string& why) {
    return unavailable("cannot serve metrics on " + listen + " (--metrics-listen): " + why);
  };
  const size_t colon = listen.rfind(':');
  if (colon == std::string::npos) return refuse("expected HOST:PORT");
  std::string host = listen.substr(0, colon);
  const std::string port = listen.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);

  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  if (int e = ::getaddrinfo(host.empty() ? nullptr : host.c_str(), port.c_str(), &hints, &found); e != 0)
    return refuse(::gai_strerror(e));
  std::string why = "no address";
  for (addrinfo* a = found; a && listener_ < 0; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    const int on = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) == 0 && ::listen(fd, 16) == 0) {
      listener_ = fd;
    } else {
      why = std::strerror(errno);
      ::close(fd);
    }
  }
  ::freeaddrinfo(found);
  if (listener_ < 0) return refuse(why);

  sockaddr_storage bound{};
  socklen_t len = sizeof bound;
  ::getsockname(listener_, reinterpret_cast<sockaddr*>(&bound), &len);
  const int bound_port = bound.ss_family == AF_INET6 ? ntohs(reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port)
                                                     : ntohs(reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
  render_ = std::move(render);
  stopping_ = false;
  thread_ = std::thread([this] { serve(); });
  return bound_port;
}

void MetricsHttpServer::stop() {
  stopping_ = true;
  if (thread_.joinable()) thread_.join();
  if (listener_ >= 0) ::close(listener_);
  listener_ = -1;
}

void MetricsHttpServer::serve() {
  while (!stopping_) {
    pollfd p{listener_, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;  // wakes every 100 ms to see stop()
    const int connection = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
    if (connection < 0) continue;
    answer(connection);
    ::close(connection);
  }
}

// One request per connection: reads the head, answers, closes.
void MetricsHttpServer::answer(int connection) {
  const timeval read_timeout{kReadTimeoutS, 0}, write_timeout{kWriteTimeoutS, 0};
  ::setsockopt(connection, SOL_SOCKET, SO_RCVTIMEO, &read_timeout, sizeof read_timeout);
  ::setsockopt(connection, SOL_SOCKET, SO_SNDTIMEO, &write_timeout, sizeof write_timeout);
  std::string head;
  char buf[1024];
  while (head.find("\r\n\r\n") == std::string::npos) {
    if (head.size() > kMaxRequestHead) {
      write_all(connection, response("431 Request Header Fields Too Large", "text/plain", "request head over 8 KiB\n",
                                     false));
      return;
    }
    const ssize_t n = ::recv(connection, buf, sizeof buf, 0);
    if (n <= 0) return;  // closed, reset or timed out: nothing to answer
    head.append(buf, size_t(n));
  }
  // Request line: METHOD SP TARGET SP VERSION
  const size_t sp1 = head.find(' '), sp2 = head.find(' ', sp1 + 1);
  const std::string method = head.substr(0, sp1);
  std::string path = sp1 == std::string::npos ? "" : head.substr(sp1 + 1, sp2 - sp1 - 1);
  path = path.substr(0, path.find('?'));
  const bool head_only = method == "HEAD";
  if (method != "GET" && !head_only) {
    write_all(connection, response("405 Method Not Allowed", "text/plain", "only GET /metrics\n", false));
  } else if (path != "/metrics") {
    write_all(connection, response("404 Not Found", "text/plain", "only GET /metrics\n", head_only));
  } else {
    write_all(connection,
              response("200 OK", "text/plain; version=0.0.4; charset=utf-8", render_ ? render_() : "", head_only));
  }
}

}  // namespace vpr::service
