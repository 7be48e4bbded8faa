// client/server_list.cpp: --server lists, good and bad, and what the error
// names.
#include "server_list.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace vpr::cli {
namespace {

using Addresses = std::vector<std::string>;

Addresses parsed(const std::string& text) {
  auto r = parse_server_list(text);
  EXPECT_TRUE(r.ok()) << text << ": " << r.status().to_string();
  return r.ok() ? *r : Addresses{};
}

// The message for a list that must be refused.
std::string refusal(const std::string& text) {
  auto r = parse_server_list(text);
  EXPECT_FALSE(r.ok()) << text << " was accepted";
  if (r.ok()) return "";
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
  return r.status().message();
}

TEST(ServerList, OneAddressIsItself) {
  EXPECT_EQ(parsed("127.0.0.1:50051"), Addresses{"127.0.0.1:50051"});
  EXPECT_EQ(parsed("localhost:1"), Addresses{"localhost:1"});
  EXPECT_EQ(parsed("vpremesh-server-0.vpremesh.svc.cluster.local:65535"),
            Addresses{"vpremesh-server-0.vpremesh.svc.cluster.local:65535"});
  EXPECT_EQ(parsed("[::1]:50051"), Addresses{"[::1]:50051"});
  EXPECT_EQ(parsed("[fe80::1%eth0]:7"), Addresses{"[fe80::1%eth0]:7"});
}

TEST(ServerList, GrpcTargetsWithASchemeGoThroughAsTheyAre) {
  EXPECT_EQ(parsed("unix:/run/vpremesh.sock"), Addresses{"unix:/run/vpremesh.sock"});
  EXPECT_EQ(parsed("dns:///vpremesh:50051"), Addresses{"dns:///vpremesh:50051"});
  EXPECT_EQ(parsed("ipv4:10.0.0.1:1,unix-abstract:vpr"), (Addresses{"ipv4:10.0.0.1:1", "unix-abstract:vpr"}));
}

TEST(ServerList, ListKeepsItsOrderAndDropsSpaces) {
  EXPECT_EQ(parsed("a:1,b:2,c:3"), (Addresses{"a:1", "b:2", "c:3"}));
  EXPECT_EQ(parsed(" b:2 ,  a:1\t"), (Addresses{"b:2", "a:1"}));
  EXPECT_EQ(parsed("10.0.0.2:50051,[2001:db8::2]:50051"), (Addresses{"10.0.0.2:50051", "[2001:db8::2]:50051"}));
}

TEST(ServerList, EmptyListsAndEntriesAreRefusedByPosition) {
  EXPECT_EQ(refusal(""), "the server list is empty (expected HOST:PORT[,HOST:PORT...])");
  EXPECT_EQ(refusal("  "), "the server list is empty (expected HOST:PORT[,HOST:PORT...])");
  EXPECT_EQ(refusal("a:1,,b:2"), "\"a:1,,b:2\": entry 2 is empty (expected HOST:PORT[,HOST:PORT...])");
  EXPECT_EQ(refusal("a:1,"), "\"a:1,\": entry 2 is empty (expected HOST:PORT[,HOST:PORT...])");
  EXPECT_EQ(refusal(",a:1"), "\",a:1\": entry 1 is empty (expected HOST:PORT[,HOST:PORT...])");
}

TEST(ServerList, BadEntriesAreNamedWithTheReason) {
  EXPECT_EQ(refusal("a:1,localhost"), "entry \"localhost\": it has no port (expected HOST:PORT)");
  EXPECT_EQ(refusal(":50051"), "entry \":50051\": it has no host (expected HOST:PORT)");
  EXPECT_EQ(refusal("a:"), "entry \"a:\": its port '' is not a number in 1..65535");
  EXPECT_EQ(refusal("a:0"), "entry \"a:0\": its port '0' is not a number in 1..65535");
  EXPECT_EQ(refusal("a:65536"), "entry \"a:65536\": its port '65536' is not a number in 1..65535");
  EXPECT_EQ(refusal("a:5x"), "entry \"a:5x\": its port '5x' is not a number in 1..65535");
  EXPECT_EQ(refusal("a:99999999999"), "entry \"a:99999999999\": its port '99999999999' is not a number in 1..65535");
  EXPECT_EQ(refusal("a b:1"), "entry \"a b:1\": 'a b' is not a host name or address");
  EXPECT_EQ(refusal("::1:50051"), "entry \"::1:50051\": an IPv6 address goes in brackets: [ADDRESS]:PORT");
  EXPECT_EQ(refusal("[::1:50051"), "entry \"[::1:50051\": its '[' has no ']'");
  EXPECT_EQ(refusal("[::1]"), "entry \"[::1]\": it has no port (expected [IPV6]:PORT)");
  EXPECT_EQ(refusal("[host]:1"), "entry \"[host]:1\": [host] is not an IPv6 address");
  EXPECT_EQ(refusal("unix:"), "entry \"unix:\": it names no target");
}

}  // namespace
}  // namespace vpr::cli
