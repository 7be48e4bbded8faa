// The --auth-tokens file: hashes only, per-tenant limits, and errors that
// name the line without echoing what may be a pasted token.
#include "server/tenant_tokens.h"

#include <gtest/gtest.h>

#include "server/authenticator.h"

namespace vpr::service {
namespace {

TEST(TenantTokens, FindsTheTenantOfAToken) {
  const std::string text = "# tenants\n"
                           "alpha " + to_hex(sha256("token-a")) + "\n"
                           "\n"
                           "beta  " + to_hex(sha256("token-b")) + " max_jobs=16  # a big customer\n"
                           "beta  " + to_hex(sha256("token-b2")) + " max_jobs=16\n";
  auto tokens = TenantTokens::parse(text, "tokens");
  ASSERT_TRUE(tokens.ok()) << tokens.status().message();
  EXPECT_EQ(tokens->tokens(), 3u);
  EXPECT_EQ(tokens->tenants(), 2u);
  ASSERT_TRUE(tokens->find("token-a"));
  EXPECT_EQ(tokens->find("token-a")->name, "alpha");
  EXPECT_EQ(tokens->find("token-a")->max_jobs, 0u);
  EXPECT_EQ(tokens->find("token-b2")->name, "beta");  // two tokens: rotation without a gap
  EXPECT_EQ(tokens->find("token-b")->max_jobs, 16u);
  EXPECT_FALSE(tokens->find("token-c"));
  EXPECT_FALSE(tokens->find(""));
  EXPECT_FALSE(tokens->find(to_hex(sha256("token-a"))));  // the hash is not a token
}

TEST(TenantTokens, KnownHashOfSha256) {
  EXPECT_EQ(to_hex(sha256("abc")), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(TenantTokens, BadLinesNameTheFileAndLineButNotTheWord) {
  auto pasted_token = TenantTokens::parse("# x\nalpha s3cr3t-token\n", "t.txt");
  ASSERT_FALSE(pasted_token.ok());
  EXPECT_NE(pasted_token.status().message().find("t.txt:2:"), std::string::npos) << pasted_token.status().message();
  EXPECT_EQ(pasted_token.status().message().find("s3cr3t"), std::string::npos) << pasted_token.status().message();

  const std::string h = to_hex(sha256("t"));
  EXPECT_FALSE(TenantTokens::parse("alpha\n", "t").ok());
  EXPECT_FALSE(TenantTokens::parse("al/pha " + h + "\n", "t").ok());
  EXPECT_FALSE(TenantTokens::parse("alpha " + h + " max_jobs=0\n", "t").ok());
  EXPECT_FALSE(TenantTokens::parse("alpha " + h + " jobs=3\n", "t").ok());
  EXPECT_FALSE(TenantTokens::parse("alpha " + h + "\nbeta " + h + "\n", "t").ok());  // one token, two tenants
  EXPECT_FALSE(TenantTokens::parse("alpha " + h + " max_jobs=2\nalpha " + to_hex(sha256("u")) + "\n", "t").ok());
  EXPECT_FALSE(TenantTokens::load("/nonexistent/tokens").ok());
}

TEST(Authenticator, AddressWithoutPort) {
  EXPECT_EQ(address_without_port("ipv4:10.1.2.3:5678"), "ipv4:10.1.2.3");
  EXPECT_EQ(address_without_port("ipv6:[::1]:80"), "ipv6:[::1]");
  EXPECT_EQ(address_without_port("unix:/tmp/s"), "unix:/tmp/s");
}

}  // namespace
}  // namespace vpr::service
