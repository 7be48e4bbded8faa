// vpremesh-server's flags: defaults, the MiB flag and address checks.
#include "server/server_options.h"

#include <gtest/gtest.h>

namespace vpr::service {
namespace {

ServerOptions parse(std::vector<std::string> args) {
  ServerOptions o;
  CLI::App app;
  add_server_options(app, &o);
  std::reverse(args.begin(), args.end());
  app.parse(args);
  return o;
}

TEST(ServerOptions, FlagsReachTheLimits) {
  const ServerOptions o = parse({"--listen",
                                 "127.0.0.1:0",
                                 "--max-upload-mib",
                                 "3",
                                 "--max-vertices",
                                 "10",
                                 "--max-faces",
                                 "20",
                                 "--max-queue",
                                 "5",
                                 "--max-jobs-per-client",
                                 "2",
                                 "--max-target-vertices",
                                 "5000",
                                 "--result-ttl",
                                 "1.5",
                                 "--drain-grace",
                                 "4",
                                 "--workers",
                                 "3",
                                 "--device",
                                 "cpu",
                                 "--metrics-listen",
                                 "127.0.0.1:9464"});
  EXPECT_EQ(o.limits.max_upload_bytes, uint64_t(3) << 20);
  EXPECT_EQ(o.limits.max_vertices, 10u);
  EXPECT_EQ(o.limits.max_faces, 20u);
  EXPECT_EQ(o.limits.max_queue, 5u);
  EXPECT_EQ(o.limits.max_jobs_per_client, 2u);
  EXPECT_EQ(o.limits.max_target_vertices, 5000u);
  EXPECT_EQ(o.result_ttl_s, 1.5);
  EXPECT_EQ(o.drain_grace_s, 4);
  EXPECT_EQ(o.workers, 3);
  EXPECT_EQ(o.device, "cpu");
  EXPECT_TRUE(check_server_options(o).ok());
}

TEST(ServerOptions, DefaultsKeepTheLibraryLimits) {
  const ServerOptions o = parse({});
  EXPECT_EQ(o.limits.max_upload_bytes, ServerLimits{}.max_upload_bytes);
  EXPECT_EQ(o.workers, -1);  // one per GPU (or 1) with the embedded queue, 0 with Redis
  EXPECT_EQ(o.device, "auto");
  EXPECT_EQ(o.queue, "embedded");
  EXPECT_FALSE(uses_redis(o));
}

// Without --workers: one on the CPU; per GPU a quarter of the cores, 1 to 4
// (a GPU job's host steps keep about 4 cores busy); -1 still means "not given".
TEST(ServerOptions, DefaultWorkersAreAQuarterOfTheCoresPerGpuAtMostFour) {
  EXPECT_EQ(parse({}).workers, -1);
  EXPECT_EQ(default_workers(0, 2), 1);
  EXPECT_EQ(default_workers(0, 64), 1);  // CPU only: every stage already uses every core
  EXPECT_EQ(default_workers(1, 2), 1);
  EXPECT_EQ(default_workers(1, 7), 1);
  EXPECT_EQ(default_workers(1, 8), 2);
  EXPECT_EQ(default_workers(1, 16), 4);
  EXPECT_EQ(default_workers(1, 128), 4);
  EXPECT_EQ(default_workers(2, 16), 8);
  EXPECT_EQ(default_workers(8, 128), 32);
}

TEST(ServerOptions, QueueIsEmbeddedOrARedisUrl) {
  ServerOptions o = parse({"--listen", "127.0.0.1:0", "--queue", "redis://cache:6380/1", "--upload-ttl", "60"});
  EXPECT_TRUE(uses_redis(o));
  EXPECT_TRUE(check_server_options(o).ok());
  EXPECT_DOUBLE_EQ(o.upload_ttl_s, 60);
  o.queue = "redis://cache:port";
  const Status s = check_server_options(o);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("--queue"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("port"), std::string::npos) << s.message();
}

TEST(ServerOptions, AddressesNeedAPortInRange) {
  for (const char* bad : {"nonsense", "127.0.0.1:99999", "127.0.0.1:", ":50051", "127.0.0.1:x"}) {
    ServerOptions o;
    o.listen = bad;
    const Status s = check_server_options(o);
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(s.message().find("--listen"), std::string::npos);
  }
  ServerOptions o;
  o.listen = "[::]:0";
  o.insecure = true;
  EXPECT_TRUE(check_server_options(o).ok());
  o.metrics_listen = "9464";
  EXPECT_NE(check_server_options(o).message().find("--metrics-listen"), std::string::npos);
}

// No tokens: only this machine may connect, unless --insecure says otherwise.
TEST(ServerOptions, AnOpenAddressNeedsTokensOrInsecure) {
  for (const char* open : {"0.0.0.0:50051", "[::]:0", "10.0.0.5:1", "myhost:80"}) {
    ServerOptions o;
    o.listen = open;
    const Status s = check_server_options(o);
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << open;
    EXPECT_NE(s.message().find("--auth-tokens"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("--insecure"), std::string::npos) << s.message();
    o.insecure = true;
    EXPECT_TRUE(check_server_options(o).ok()) << open;
    o.insecure = false;
    o.auth_tokens = "tokens.txt";
    EXPECT_TRUE(check_server_options(o).ok()) << open;
  }
  for (const char* loopback : {"127.0.0.1:0", "localhost:50051", "[::1]:0", "127.0.0.2:1"}) {
    ServerOptions o;
    o.listen = loopback;
    EXPECT_TRUE(check_server_options(o).ok()) << loopback;
  }
}

TEST(ServerOptions, TlsFilesGoTogether) {
  ServerOptions o;
  o.listen = "127.0.0.1:0";
  o.tls_cert = "cert.pem";
  EXPECT_NE(check_server_options(o).message().find("--tls-key"), std::string::npos);
  o.tls_key = "key.pem";
  EXPECT_TRUE(check_server_options(o).ok());
  o.tls_cert = o.tls_key = "";
  o.tls_client_ca = "ca.pem";
  EXPECT_NE(check_server_options(o).message().find("--tls-cert"), std::string::npos);
}

TEST(ServerOptions, UnknownDeviceIsAParseError) {
  EXPECT_THROW(parse({"--device", "tpu"}), CLI::ValidationError);
}

}  // namespace
}  // namespace vpr::service
