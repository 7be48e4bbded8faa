// What vpremesh-server's and vpremesh-worker's main() share: the stop
// signals, their wait, and small conversions of flag values.
#pragma once

#include <signal.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdint>
#include <string>

namespace vpr::service {

// Logs `message` and returns `code` (the process's exit code).
inline int fail(const std::string& message, int code = 1) {
  spdlog::error("{}", message);
  return code;
}

// The host part of HOST:PORT ("[::]" kept with its brackets).
inline std::string host_of(const std::string& address) {
  return address.substr(0, address.rfind(':'));
}

inline std::chrono::milliseconds seconds(double s) {
  return std::chrono::milliseconds(int64_t(s * 1000));
}

// Blocks SIGTERM and SIGINT in this thread and every thread started after
// it; the main thread then takes them with wait_for_stop_signal.
inline sigset_t block_stop_signals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return signals;
}

// Waits for SIGTERM or SIGINT, calling `tick` about once a second meanwhile.
// Returns the signal.
template <class Tick>
int wait_for_stop_signal(const sigset_t& signals, Tick tick) {
  while (true) {
    timespec one_second{1, 0};
    const int signal_number = sigtimedwait(&signals, nullptr, &one_second);
    if (signal_number >= 0) return signal_number;
    tick();
  }
}

}  // namespace vpr::service
