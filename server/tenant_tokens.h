// The tenants a server knows (--auth-tokens FILE) and the hashes of their
// bearer tokens. The file holds one tenant per line:
//
//   # comment
//   TENANT SHA256_HEX_OF_TOKEN [max_jobs=N]
//
// Only hashes are stored (the file and memory never hold a token), so a
// leaked file does not let anyone in. A tenant may have several lines (one
// token per line): that is how a token is rotated without a gap.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"

namespace vpr::service {

using Sha256 = std::array<uint8_t, 32>;

Sha256 sha256(std::string_view bytes);
// 64 lowercase hex digits.
std::string to_hex(const Sha256& hash);

struct Tenant {
  std::string name;
  size_t max_jobs = 0;  // unfinished jobs at once; 0: --max-jobs-per-client
};

class TenantTokens {
 public:
  // INVALID_ARGUMENT names the file and line of the first bad line.
  static StatusOr<TenantTokens> parse(const std::string& text, const std::string& file_name);
  // NOT_FOUND when the file cannot be read.
  static StatusOr<TenantTokens> load(const std::string& path);

  // The tenant whose token this is. Hashes the token and compares the hash
  // with every entry in constant time, so the answer's timing tells nothing
  // about how close a guess came or which line matched.
  std::optional<Tenant> find(std::string_view token) const;

  size_t tokens() const { return entries_.size(); }
  size_t tenants() const;

 private:
  struct Entry {
    Sha256 hash;
    Tenant tenant;
  };
  std::vector<Entry> entries_;
};

}  // namespace vpr::service
