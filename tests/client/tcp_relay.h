// A TCP relay in front of a server that can die like a machine does: cut()
// (or the byte limit given to the constructor) resets every connection
// through it and refuses new ones, so that the client sees the transport fail,
// not a status the server chose to send; reset_connections() resets the open
// ones only, as a network hiccup would.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <limits>
#include <string>
#include <thread>
#include <vector>

namespace vpr::testing {

class TcpRelay {
 public:
  // backend_port: on 127.0.0.1. The relay dies once it has passed
  // `bytes_to_client` bytes from the server to the client, mid-frame.
  explicit TcpRelay(int backend_port, uint64_t bytes_to_client = std::numeric_limits<uint64_t>::max())
      : backend_port_(backend_port), limit_(bytes_to_client) {
    listener_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr = loopback(0);
    ::bind(listener_, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    ::listen(listener_, 16);
    socklen_t len = sizeof addr;
    ::getsockname(listener_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    acceptor_ = std::thread([this] { accept_loop(); });
  }
  ~TcpRelay() { cut(); }
  TcpRelay(const TcpRelay&) = delete;
  TcpRelay& operator=(const TcpRelay&) = delete;

  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  uint64_t bytes_to_client() const { return to_client_; }

  // Resets the connections open now, as a network hiccup does, and goes on
  // relaying new ones: a client that connects again reaches the server.
  void reset_connections() { ++generation_; }

  void cut() {
    dead_ = true;
    if (acceptor_.joinable()) acceptor_.join();  // after it, nothing adds to relays_
    for (std::thread& t : relays_) t.join();
    relays_.clear();
  }

 private:
  static sockaddr_in loopback(int port) {
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = htons(uint16_t(port));
    return addr;
  }

  // A reset, not an orderly close: the peer reads ECONNRESET.
  static void reset(int fd) {
    linger l{1, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_LINGER, &l, sizeof l);
    ::close(fd);
  }

  void accept_loop() {
    while (!dead_) {
      pollfd p{listener_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      const int client = ::accept(listener_, nullptr, nullptr);
      if (client < 0) continue;
      const int backend = ::socket(AF_INET, SOCK_STREAM, 0);
      sockaddr_in addr = loopback(backend_port_);
      if (::connect(backend, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        reset(client);
        ::close(backend);
        continue;
      }
      relays_.emplace_back([this, client, backend, g = generation_.load()] { relay(client, backend, g); });
    }
    ::close(listener_);  // from now on, connecting is refused
  }

  void relay(int client, int backend, int generation) {
    char buf[16384];
    bool open = true;
    while (open && !dead_ && generation_ == generation) {
      pollfd p[2] = {{client, POLLIN, 0}, {backend, POLLIN, 0}};
      if (::poll(p, 2, 20) <= 0) continue;
      for (int i = 0; i < 2 && open; ++i) {
        if (!(p[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
        ssize_t n = ::read(p[i].fd, buf, sizeof buf);
        if (n <= 0) open = false;
        const bool to_client = p[i].fd == backend;
        if (to_client && n > 0) {
          const uint64_t room = limit_ - std::min(limit_, to_client_.load());
          if (uint64_t(n) >= room) {
            n = ssize_t(room);
            dead_ = true;
          }
          to_client_ += uint64_t(n);
        }
        for (ssize_t sent = 0; open && sent < n;) {
          const ssize_t w = ::write(p[1 - i].fd, buf + sent, size_t(n - sent));
          if (w <= 0) open = false;
          sent += w;
        }
      }
    }
    reset(client);
    reset(backend);
  }

  const int backend_port_;
  const uint64_t limit_;
  int listener_ = -1;
  int port_ = 0;
  std::atomic<bool> dead_{false};
  std::atomic<int> generation_{0};  // connections of an older one are reset
  std::atomic<uint64_t> to_client_{0};
  std::thread acceptor_;
  std::vector<std::thread> relays_;  // one per connection
};

}  // namespace vpr::testing
