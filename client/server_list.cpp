#include "server_list.h"

#include "channel_security.h"

#include <cassert>
#include <cctype>

namespace vpr::cli {
namespace {

// gRPC's own target schemes: such an entry goes to gRPC as it is.
constexpr const char* kSchemes[] = {"dns:", "ipv4:", "ipv6:", "unix:", "unix-abstract:", "vsock:"};

std::string trim(const std::string& s) {
  size_t begin = 0, end = s.size();
  while (begin < end && std::isspace(static_cast<unsigned char>(s[begin]))) ++begin;
  while (end > begin && std::isspace(static_cast<unsigned char>(s[end - 1]))) --end;
  return s.substr(begin, end - begin);
}

bool is_host_name(const std::string& host) {
  if (host.empty()) return false;
  for (char c : host)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-' && c != '_') return false;
  return true;
}

// An IPv6 address (an IPv4 tail allowed), with an optional %zone.
bool is_ipv6_literal(const std::string& host) {
  const size_t zone = host.find('%');
  const std::string address = host.substr(0, zone);
  if (address.find(':') == std::string::npos) return false;
  for (char c : address)
    if (!std::isxdigit(static_cast<unsigned char>(c)) && c != ':' && c != '.') return false;
  return zone == std::string::npos || is_host_name(host.substr(zone + 1));
}

// Why `entry` is not HOST:PORT, or "" when it is.
std::string entry_problem(const std::string& entry) {
  for (const char* scheme : kSchemes)
    if (entry.rfind(scheme, 0) == 0) return entry.size() > std::string(scheme).size() ? "" : "it names no target";
  std::string host, port;
  if (entry[0] == '[') {
    const size_t close = entry.find(']');
    if (close == std::string::npos) return "its '[' has no ']'";
    host = entry.substr(1, close - 1);
    if (!is_ipv6_literal(host)) return "[" + host + "] is not an IPv6 address";
    if (close + 1 >= entry.size() || entry[close + 1] != ':') return "it has no port (expected [IPV6]:PORT)";
    port = entry.substr(close + 2);
  } else {
    const size_t colon = entry.rfind(':');
    if (colon == std::string::npos) return "it has no port (expected HOST:PORT)";
    host = entry.substr(0, colon);
    port = entry.substr(colon + 1);
    if (host.find(':') != std::string::npos) return "an IPv6 address goes in brackets: [ADDRESS]:PORT";
    if (host.empty()) return "it has no host (expected HOST:PORT)";
    if (!is_host_name(host)) return "'" + host + "' is not a host name or address";
  }
  if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
      std::stoi(port) < 1 || std::stoi(port) > 65535)
    return "its port '" + port + "' is not a number in 1..65535";
  return "";
}

}  // namespace

StatusOr<std::vector<std::string>> parse_server_list(const std::string& text) {
  if (trim(text).empty()) return invalid_argument("the server list is empty (expected HOST:PORT[,HOST:PORT...])");
  std::vector<std::string> servers;
  size_t begin = 0;
  for (int index = 1;; ++index) {
    const size_t comma = text.find(',', begin);
    const std::string entry = trim(text.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin));
    if (entry.empty())
      return invalid_argument("\"" + text + "\": entry " + std::to_string(index) +
                              " is empty (expected HOST:PORT[,HOST:PORT...])");
    if (const std::string why = entry_problem(entry); !why.empty())
      return invalid_argument("entry \"" + entry + "\": " + why);
    servers.push_back(entry);
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  return servers;
}

std::vector<std::string> ServerFlags::servers() const {
  auto parsed = parse_server_list(list);
  assert(parsed.ok() && "the --server check accepts only lists that parse");
  return parsed.ok() ? *parsed : std::vector<std::string>{list};
}

void add_server_list_flags(CLI::App* cmd, ServerFlags& flags) {
  cmd->add_option("--server", flags.list,
                  "Server address HOST:PORT, or replicas serving the same jobs HOST:PORT,HOST:PORT,... "
                  "(or $VPREMESH_SERVER)")
      ->envname("VPREMESH_SERVER")
      ->required()
      ->check(CLI::Validator(
          [](std::string& value) {
            auto parsed = parse_server_list(value);
            return parsed.ok() ? std::string() : parsed.status().message();
          },
          "HOST:PORT[,HOST:PORT...]"));
  cmd->add_option("--deadline", flags.deadline_s,
                  "Give up after this many seconds, re-attachments included (0 = never)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  add_channel_security_flags(cmd);
}

void add_reattach_flag(CLI::App* cmd, ServerFlags& flags) {
  cmd->add_option("--reattach-timeout", flags.reattach_timeout_s,
                  "When the server following the job is lost, keep re-attaching to the job on the --server "
                  "replicas (round robin) for up to this many seconds without an event (0 = never)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
}

void add_server_flags(CLI::App* cmd, std::string& server, double& deadline_s) {
  cmd->add_option("--server", server, "Server address host:port (or $VPREMESH_SERVER)")
      ->envname("VPREMESH_SERVER")
      ->required()
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            auto parsed = parse_server_list(value);
            if (!parsed.ok()) return parsed.status().message();
            return parsed->size() == 1 ? "" : "bench loads one server: give one HOST:PORT";
          },
          "HOST:PORT"));
  cmd->add_option("--deadline", deadline_s, "Give up after this many seconds (0 = never)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  add_channel_security_flags(cmd);
}

}  // namespace vpr::cli
