// A blocking HTTP/1.1 request to 127.0.0.1 for the tests that scrape
// /metrics, and a reader of one sample from the page.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <string>

namespace vpr::testing {

// The whole response (status line, headers, body); "" when nothing answered.
inline std::string http_request(int port, const std::string& request) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = htons(uint16_t(port));
  std::string response;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
      ::write(fd, request.data(), request.size()) == ssize_t(request.size())) {
    char buf[4096];
    for (ssize_t n; (n = ::read(fd, buf, sizeof buf)) > 0;) response.append(buf, size_t(n));
  }
  ::close(fd);
  return response;
}

inline std::string http_get(int port, const std::string& path) {
  return http_request(port, "GET " + path + " HTTP/1.1\r\nHost: test\r\n\r\n");
}

// The port a process printed as "metrics on http://HOST:PORT/metrics"; 0 if none.
inline int metrics_port(const std::string& log) {
  const std::string key = "metrics on http://";
  const size_t at = log.find(key);
  if (at == std::string::npos) return 0;
  const size_t colon = log.find(':', at + key.size()), slash = log.find('/', colon);
  return colon == std::string::npos || slash == std::string::npos ? 0
                                                                  : std::stoi(log.substr(colon + 1, slash - colon - 1));
}

// The value of the unlabelled sample `name` on a /metrics page; -1 if absent.
inline double sample(const std::string& page, const std::string& name) {
  const size_t line = page.find("\n" + name + " ");
  return line == std::string::npos ? -1 : std::stod(page.substr(line + name.size() + 2));
}

}  // namespace vpr::testing
