// --server for the service commands: one address, or a comma-separated list of
// replicas that serve the same jobs (a shared queue), so that a command can go
// on when one of them is lost. Parsed and checked here, and nowhere else.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "core/status.h"

namespace vpr::cli {

// "HOST:PORT,HOST:PORT,..." -> the addresses in the order given. An entry is
// HOST:PORT (HOST a name, an IPv4 address or a bracketed IPv6 address, PORT
// 1..65535), or a gRPC target with a scheme (dns:, ipv4:, ipv6:, unix:,
// unix-abstract:, vsock:), which gRPC resolves itself; an entry cannot hold a
// comma. Spaces around entries are dropped. INVALID_ARGUMENT names the entry
// that is wrong and why.
StatusOr<std::vector<std::string>> parse_server_list(const std::string& text);

// The flags of submit, watch, status and cancel.
struct ServerFlags {
  std::string list;                // --server as given (or $VPREMESH_SERVER)
  double deadline_s = 0;           // --deadline: the whole command, re-attachments included; 0 = none
  double reattach_timeout_s = 60;  // --reattach-timeout (submit, watch): 0 = never re-attach

  // The parsed list; the flag's check has accepted it already.
  std::vector<std::string> servers() const;
};

// --server (a list) and --deadline; a bad list is a usage error (exit 2).
void add_server_list_flags(CLI::App* cmd, ServerFlags& flags);
// --reattach-timeout, for the commands that follow a job.
void add_reattach_flag(CLI::App* cmd, ServerFlags& flags);

// --server (exactly one address) and --deadline, for `vpremesh bench`, whose
// load goes to one server.
void add_server_flags(CLI::App* cmd, std::string& server, double& deadline_s);

}  // namespace vpr::cli
