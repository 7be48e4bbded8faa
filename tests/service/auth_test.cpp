// Who may do what, end to end: the real vpremesh-server on a loopback port
// with --auth-tokens and TLS, driven by the real `vpremesh` client and by
// the C++ stubs carrying bearer tokens. Certificates are made for each test
// with the openssl command and thrown away after it.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "auth_harness.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "test_meshes.h"

namespace fs = std::filesystem;

namespace vpr::testing {
namespace {

const std::string kTokenA = "tok-alpha-4f1c9e", kTokenB = "tok-beta-77d2a0";

class AuthTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vpremesh_auth_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    write_tokens(path("tokens"), {{"alpha", kTokenA}, {"beta", kTokenB}});
    std::ofstream(path("a.token")) << kTokenA << "\n";
    std::ofstream(path("b.token")) << kTokenB << "\n";
    write_file(path("sphere.drc"), lossless_draco(icosphere(3)));
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  fs::path dir_;
};

grpc::health::v1::HealthCheckResponse::ServingStatus health(const std::string& address) {
  auto stub = grpc::health::v1::Health::NewStub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  grpc::health::v1::HealthCheckResponse response;
  if (!stub->Check(&context, grpc::health::v1::HealthCheckRequest(), &response).ok())
    return grpc::health::v1::HealthCheckResponse::UNKNOWN;
  return response.status();
}

// No token, a wrong one, and one revoked by editing the file and sending
// SIGHUP are all UNAUTHENTICATED; health answers without a token all along.
TEST_F(AuthTest, CallsWithoutAValidTokenAreUnauthenticated) {
  ServerProcess server({"--auth-tokens", path("tokens")});
  ASSERT_TRUE(server.started()) << server.log();
  auto stub = make_stub(server.address());
  const std::string unknown_job = "j-0000000000000000";

  EXPECT_EQ(get_job_as(*stub, "", unknown_job).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(get_job_as(*stub, "not-a-token", unknown_job).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(get_job_as(*stub, kTokenA, unknown_job).error_code(), grpc::StatusCode::NOT_FOUND);  // let in
  std::string id;
  EXPECT_EQ(submit_as(*stub, "", make_spec(300, 0), lossless_draco(icosphere(3)), &id).error_code(),
            grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(watch_as(*stub, "", unknown_job).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(cancel_as(*stub, "wrong", unknown_job).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(health(server.address()), grpc::health::v1::HealthCheckResponse::SERVING);

  // The real client: no token is exit 10; the token from a file or the environment lets it in.
  const std::string s = " --server " + server.address();
  EXPECT_EQ(run_cli("status " + unknown_job + s).code, 10);
  EXPECT_EQ(run_cli("status " + unknown_job + s + " --token-file " + path("b.token")).code, 7);
  EXPECT_EQ(run_cli("status " + unknown_job + s + " --token-file " + path("a.token")).code, 7);
  CliRun env = run_cli("submit " + path("sphere.drc") + " -o " + path("out.drc") + " -n 300" + s);
  EXPECT_EQ(env.code, 10) << env.err;
  ::setenv("VPREMESH_TOKEN", kTokenA.c_str(), 1);
  CliRun with_env = run_cli("submit " + path("sphere.drc") + " -o " + path("out.drc") + " -n 300 --device cpu" + s);
  ::unsetenv("VPREMESH_TOKEN");
  EXPECT_EQ(with_env.code, 0) << with_env.err << server.log();

  // Revoke alpha: the file without its line, then SIGHUP. Jobs are not dropped.
  write_tokens(path("tokens"), {{"beta", kTokenB}});
  server.kill(SIGHUP);
  const auto give_up = std::chrono::steady_clock::now() + kStartupLimit;
  while (get_job_as(*stub, kTokenA, unknown_job).error_code() != grpc::StatusCode::UNAUTHENTICATED &&
         std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(get_job_as(*stub, kTokenA, unknown_job).error_code(), grpc::StatusCode::UNAUTHENTICATED) << server.log();
  EXPECT_EQ(get_job_as(*stub, kTokenB, unknown_job).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(health(server.address()), grpc::health::v1::HealthCheckResponse::SERVING);

  // A broken file on SIGHUP keeps the tenants read before.
  std::ofstream(path("tokens")) << "beta not-a-hash\n";
  server.kill(SIGHUP);
  std::this_thread::sleep_for(std::chrono::seconds(2));
  EXPECT_EQ(get_job_as(*stub, kTokenB, unknown_job).error_code(), grpc::StatusCode::NOT_FOUND) << server.log();

  // The log names tenants, never a token.
  for (const std::string& token : {kTokenA, kTokenB}) EXPECT_EQ(server.log().find(token), std::string::npos);
  EXPECT_NE(server.log().find("alpha"), std::string::npos);
}

// Tenant beta cannot get, watch or cancel alpha's job: NOT_FOUND, with the
// message of an id that does not exist. Alpha still gets its result.
TEST_F(AuthTest, TenantsSeeOnlyTheirOwnJobs) {
  ServerProcess server({"--auth-tokens", path("tokens"), "--workers", "1", "--device", "cpu"});
  ASSERT_TRUE(server.started()) << server.log();
  auto stub = make_stub(server.address());
  const std::vector<uint8_t> mesh = lossless_draco(icosphere(3));
  std::string id;
  ASSERT_TRUE(submit_as(*stub, kTokenA, make_spec(300, mesh.size()), mesh, &id).ok()) << server.log();

  v1::JobStatus status;
  const grpc::Status get = get_job_as(*stub, kTokenB, id, &status);
  EXPECT_EQ(get.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(status.job_id(), "");
  const std::string other_id = "j-ffffffffffffffff";
  const grpc::Status unknown = get_job_as(*stub, kTokenB, other_id);
  std::string expected = unknown.error_message();
  expected.replace(expected.find(other_id), other_id.size(), id);
  EXPECT_EQ(get.error_message(), expected);  // nothing tells that the id exists
  EXPECT_EQ(watch_as(*stub, kTokenB, id).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(cancel_as(*stub, kTokenB, id).error_code(), grpc::StatusCode::NOT_FOUND);
  const std::string s = " --server " + server.address() + " --token-file " + path("b.token");
  EXPECT_EQ(run_cli("status " + id + s).code, 7);
  EXPECT_EQ(run_cli("cancel " + id + s).code, 7);
  EXPECT_EQ(run_cli("watch " + id + " -o " + path("stolen.drc") + s).code, 7);
  EXPECT_FALSE(fs::exists(path("stolen.drc")));

  std::string result;
  EXPECT_TRUE(watch_as(*stub, kTokenA, id, &result).ok()) << server.log();
  EXPECT_FALSE(result.empty());
  ASSERT_TRUE(get_job_as(*stub, kTokenA, id, &status).ok());
  EXPECT_EQ(status.state(), v1::JOB_STATE_SUCCEEDED);
  CliRun watch = run_cli("watch " + id + " -o " + path("mine.drc") + " --server " + server.address() +
                         " --token-file " + path("a.token"));
  EXPECT_EQ(watch.code, 0) << watch.err;
  EXPECT_TRUE(fs::exists(path("mine.drc")));
}

// Alpha (max_jobs=1 in the tokens file) opens a new connection for every
// submission and is still held to one unfinished job; beta is not held back
// by it. Without tokens the same holds per source address.
TEST_F(AuthTest, QuotaHoldsATenantAcrossConnections) {
  write_tokens(path("tokens"), {{"alpha", kTokenA + " max_jobs=1"}, {"beta", kTokenB}});
  ServerProcess server({"--auth-tokens", path("tokens"), "--workers", "1", "--device", "cpu",
                        "--max-jobs-per-client", "2"});
  ASSERT_TRUE(server.started()) << server.log();
  const std::vector<uint8_t> mesh = lossless_draco(icosphere(4));
  v1::JobSpec slow = make_spec(4000, mesh.size());
  slow.mutable_options()->set_awlop_iterations(200);  // seconds: still unfinished at the next submission

  std::string first, refused;
  ASSERT_TRUE(submit_as(*make_own_connection_stub(server.address()), kTokenA, slow, mesh, &first).ok()) << server.log();
  const grpc::Status again = submit_as(*make_own_connection_stub(server.address()), kTokenA, slow, mesh, &refused);
  EXPECT_EQ(again.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(again.error_message().find("client alpha"), std::string::npos) << again.error_message();
  EXPECT_NE(again.error_message().find("limit is 1"), std::string::npos) << again.error_message();

  // Beta submits its two (the server-wide limit) while alpha is held.
  auto beta = make_stub(server.address());
  const std::vector<uint8_t> small = lossless_draco(icosphere(3));
  std::string b1, b2, b3;
  EXPECT_TRUE(submit_as(*beta, kTokenB, make_spec(300, small.size()), small, &b1).ok());
  EXPECT_TRUE(submit_as(*make_own_connection_stub(server.address()), kTokenB, make_spec(300, small.size()), small, &b2).ok());
  EXPECT_EQ(submit_as(*beta, kTokenB, make_spec(300, small.size()), small, &b3).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
  // Alpha's place comes back when its job ends; beta's jobs complete.
  EXPECT_TRUE(cancel_as(*beta, kTokenA, first).ok());
  EXPECT_TRUE(watch_as(*beta, kTokenB, b1).ok());
  EXPECT_TRUE(watch_as(*beta, kTokenB, b2).ok());
  std::string second;
  EXPECT_TRUE(submit_as(*make_own_connection_stub(server.address()), kTokenA, make_spec(300, small.size()), small,
                        &second).ok());
  EXPECT_TRUE(watch_as(*beta, kTokenA, second).ok());
}

TEST_F(AuthTest, WithoutTokensTheQuotaCountsTheSourceAddressNotTheConnection) {
  ServerProcess server({"--workers", "1", "--device", "cpu", "--max-jobs-per-client", "1"});
  ASSERT_TRUE(server.started()) << server.log();
  const std::vector<uint8_t> mesh = lossless_draco(icosphere(4));
  v1::JobSpec slow = make_spec(4000, mesh.size());
  slow.mutable_options()->set_awlop_iterations(200);
  std::string first, second;
  ASSERT_TRUE(submit_as(*make_own_connection_stub(server.address()), "", slow, mesh, &first).ok()) << server.log();
  const grpc::Status again = submit_as(*make_own_connection_stub(server.address()), "", slow, mesh, &second);
  EXPECT_EQ(again.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(again.error_message().find("client ipv4:127.0.0.1 "), std::string::npos) << again.error_message();
  EXPECT_TRUE(cancel_as(*make_stub(server.address()), "", first).ok());
}

// TLS: a plaintext client, a client trusting another CA, and (with mutual
// TLS) a client without a certificate are all refused; the right ones get in.
// A refused client never connects: it waits for the server up to its
// deadline (client/channel.h) and exits DEADLINE_EXCEEDED (8), or
// UNAVAILABLE (5) when gRPC gives up on the connection first.
bool never_connected(int code) {
  return code == 5 || code == 8;
}

TEST_F(AuthTest, TlsRefusesPlaintextWrongCaAndMissingClientCertificates) {
  ASSERT_TRUE(make_certificates(dir_.string())) << "openssl failed";
  ServerProcess tls({"--tls-cert", path("server.pem"), "--tls-key", path("server.key"), "--auth-tokens",
                     path("tokens"), "--health-listen", "127.0.0.1:0"});
  ASSERT_TRUE(tls.started()) << tls.log();
  // Probes speak neither TLS nor tokens: --health-listen answers them in plaintext.
  const std::string health_key = "vpremesh-server health on ";
  const size_t at = tls.log().find(health_key);
  ASSERT_NE(at, std::string::npos) << tls.log();
  const std::string health_address =
      tls.log().substr(at + health_key.size(), tls.log().find('\n', at) - at - health_key.size());
  EXPECT_EQ(health(health_address), grpc::health::v1::HealthCheckResponse::SERVING) << health_address;
  EXPECT_EQ(health(tls.address()), grpc::health::v1::HealthCheckResponse::UNKNOWN);  // TLS only there
  const std::string unknown_job = "j-0000000000000000";
  const std::string s = " --deadline 10 --token-file " + path("a.token") + " --server " + tls.address();
  EXPECT_TRUE(never_connected(run_cli("status " + unknown_job + s).code));  // plaintext: no connection
  EXPECT_TRUE(never_connected(run_cli("status " + unknown_job + s + " --tls-ca " + path("other-ca.pem")).code));
  EXPECT_EQ(run_cli("status " + unknown_job + s + " --tls-ca " + path("ca.pem")).code, 7);  // in, and asked
  ::setenv("VPREMESH_TLS_CA", path("ca.pem").c_str(), 1);
  CliRun env = run_cli("submit " + path("sphere.drc") + " -o " + path("tls.drc") + " -n 300 --device cpu" + s);
  ::unsetenv("VPREMESH_TLS_CA");
  EXPECT_EQ(env.code, 0) << env.err << tls.log();
  EXPECT_EQ(run_cli("status " + unknown_job + " --deadline 10 --tls-ca " + path("ca.pem") + " --server " +
                    tls.address()).code,
            10);  // TLS is no token

  ServerProcess mtls({"--tls-cert", path("server.pem"), "--tls-key", path("server.key"), "--tls-client-ca",
                      path("ca.pem")});
  ASSERT_TRUE(mtls.started()) << mtls.log();
  const std::string m = " --deadline 10 --tls-ca " + path("ca.pem") + " --server " + mtls.address();
  EXPECT_TRUE(never_connected(run_cli("status " + unknown_job + m).code));
  EXPECT_TRUE(never_connected(run_cli("status " + unknown_job + m + " --tls-cert " + path("server.pem") +
                                     " --tls-key " + path("server.key"))
                                  .code));  // a certificate for servers only
  EXPECT_EQ(run_cli("status " + unknown_job + m + " --tls-cert " + path("client.pem") + " --tls-key " +
                    path("client.key")).code,
            7);
}

// Secure by default: a non-loopback --listen needs --auth-tokens or --insecure.
TEST_F(AuthTest, AnOpenAddressNeedsTokensOrInsecure) {
  ChildProcess refused({VPR_SERVER_PATH, "--listen", "0.0.0.0:0"});
  EXPECT_EQ(refused.wait(kStartupLimit), 2);
  EXPECT_NE(refused.output().find("refusing to listen on 0.0.0.0:0 without --auth-tokens"), std::string::npos)
      << refused.output();
  EXPECT_NE(refused.output().find("--insecure"), std::string::npos);
  for (const std::vector<std::string>& flags :
       {std::vector<std::string>{"--insecure"}, std::vector<std::string>{"--auth-tokens", path("tokens")}}) {
    std::vector<std::string> args = {VPR_SERVER_PATH, "--listen", "0.0.0.0:0", "--workers", "0"};
    args.insert(args.end(), flags.begin(), flags.end());
    ChildProcess open(args);
    EXPECT_TRUE(open.wait_for_text("vpremesh-server listening on 0.0.0.0:", kStartupLimit)) << open.output();
    EXPECT_EQ(open.terminate(kStartupLimit), 0);
  }
}

}  // namespace
}  // namespace vpr::testing
