#include "server/tenant_tokens.h"

#include <openssl/crypto.h>
#include <openssl/sha.h>

#include <fstream>
#include <set>
#include <sstream>

namespace vpr::service {

Sha256 sha256(std::string_view bytes) {
  Sha256 hash;
  SHA256(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), hash.data());
  return hash;
}

std::string to_hex(const Sha256& hash) {
  static const char* const kDigits = "0123456789abcdef";
  std::string hex;
  for (uint8_t b : hash) {
    hex += kDigits[b >> 4];
    hex += kDigits[b & 15];
  }
  return hex;
}

namespace {

std::optional<Sha256> from_hex(const std::string& hex) {
  if (hex.size() != 64) return std::nullopt;
  Sha256 hash;
  for (size_t i = 0; i < 32; ++i) {
    int value = 0;
    for (char c : {hex[2 * i], hex[2 * i + 1]}) {
      int digit = c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
      if (digit < 0) return std::nullopt;
      value = value * 16 + digit;
    }
    hash[i] = uint8_t(value);
  }
  return hash;
}

// Tenant names appear in logs, metrics labels and Redis keys: keep them plain.
bool plain_name(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  for (char c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.') return false;
  return true;
}

}  // namespace

StatusOr<TenantTokens> TenantTokens::parse(const std::string& text, const std::string& file_name) {
  TenantTokens tokens;
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    if (size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream words(line);
    std::vector<std::string> w;
    for (std::string word; words >> word;) w.push_back(word);
    if (w.empty()) continue;
    const std::string where = file_name + ":" + std::to_string(number) + ": ";
    if (w.size() < 2 || w.size() > 3)
      return invalid_argument(where + "expected 'TENANT SHA256_HEX [max_jobs=N]', got " + std::to_string(w.size()) +
                              " words");
    Entry e;
    if (!plain_name(w[0]))
      return invalid_argument(where + "tenant name '" + w[0] + "' must be 1-64 letters, digits, '-', '_' or '.'");
    e.tenant.name = w[0];
    auto hash = from_hex(w[1]);
    // Never echo the word: someone may have pasted a token instead of its hash.
    if (!hash)
      return invalid_argument(where + "the second word must be the token's SHA-256 as 64 hex digits " +
                              "(sha256sum of the token), not the token itself");
    e.hash = *hash;
    if (w.size() == 3) {
      const std::string prefix = "max_jobs=";
      const std::string value = w[2].rfind(prefix, 0) == 0 ? w[2].substr(prefix.size()) : "";
      if (value.empty() || value.size() > 6 || value.find_first_not_of("0123456789") != std::string::npos ||
          std::stoul(value) == 0)
        return invalid_argument(where + "the third word must be max_jobs=N with N a positive number, got '" + w[2] +
                                "'");
      e.tenant.max_jobs = std::stoul(value);
    }
    for (const Entry& other : tokens.entries_) {
      if (other.hash == e.hash)
        return invalid_argument(where + "the same token hash is listed twice (tenants '" + other.tenant.name + "' and '" +
                                e.tenant.name + "')");
      if (other.tenant.name == e.tenant.name && other.tenant.max_jobs != e.tenant.max_jobs)
        return invalid_argument(where + "tenant '" + e.tenant.name + "' has lines with different max_jobs");
    }
    tokens.entries_.push_back(std::move(e));
  }
  return tokens;
}

StatusOr<TenantTokens> TenantTokens::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return not_found("cannot read the tokens file " + path + " (--auth-tokens)");
  std::ostringstream text;
  text << in.rdbuf();
  return parse(text.str(), path);
}

std::optional<Tenant> TenantTokens::find(std::string_view token) const {
  const Sha256 hash = sha256(token);
  const Entry* match = nullptr;
  for (const Entry& e : entries_) {
    // CRYPTO_memcmp takes the same time whether the first or the last byte differs.
    const bool equal = CRYPTO_memcmp(e.hash.data(), hash.data(), hash.size()) == 0;
    if (equal) match = &e;
  }
  if (!match) return std::nullopt;
  return match->tenant;
}

size_t TenantTokens::tenants() const {
  std::set<std::string> names;
  for (const Entry& e : entries_) names.insert(e.tenant.name);
  return names.size();
}

}  // namespace vpr::service
