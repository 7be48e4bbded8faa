// Re-attaching against the real vpremesh-server (embedded queue, so one
// server plays both replicas): `vpremesh watch JOB --server RELAY,SERVER`
// where the relay in front of the server dies part way through the event
// stream; the client picks the job up on the server itself with Watch from
// the next event, and what it writes and shows is what a watch without the
// break writes and shows.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "client/tcp_relay.h"
#include "service/service_harness.h"

namespace fs = std::filesystem;

namespace vpr {
namespace {

using testing::CliRun;
using testing::run_cli;

std::string read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// `text` without its lines that start with `prefix`.
std::string without_lines(const std::string& text, const std::string& prefix) {
  std::string kept;
  for (size_t begin = 0; begin < text.size();) {
    const size_t end = std::min(text.find('\n', begin), text.size() - 1) + 1;
    if (text.compare(begin, prefix.size(), prefix) != 0) kept += text.substr(begin, end - begin);
    begin = end;
  }
  return kept;
}

TEST(ReattachServer, WatchLosesItsServerPartWayAndResumesFromTheNextEvent) {
  const fs::path dir = fs::temp_directory_path() / ("vpremesh_reattach_server_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  testing::ServerProcess server({"--workers", "1", "--device", "cpu"});
  ASSERT_TRUE(server.started()) << server.log();
  const std::string at = server.address();
  const int port = std::stoi(at.substr(at.rfind(':') + 1));

  CliRun submitted = run_cli("submit ../shared/models/spot.obj --target-vertices 500 --no-wait --server " + at);
  ASSERT_EQ(submitted.code, 0) << submitted.all();
  const std::string job = submitted.out.substr(0, submitted.out.find('\n'));

  // The reference: the whole stream through a relay that never dies (which
  // also measures the stream).
  uint64_t stream_bytes = 0;
  CliRun whole;
  {
    testing::TcpRelay relay(port);
    whole = run_cli("watch " + job + " -o " + (dir / "whole.drc").string() + " --server " + relay.address());
    stream_bytes = relay.bytes_to_client();
  }
  ASSERT_EQ(whole.code, 0) << whole.all();
  const std::string reference = read_file((dir / "whole.drc").string());
  ASSERT_FALSE(reference.empty());

  // Early (among the stage events) and within the result chunks.
  int latest_resume = 0;
  for (int percent : {3, 10, 25, 50, 75}) {
    SCOPED_TRACE("the relay dies after " + std::to_string(percent) + "% of the stream");
    testing::TcpRelay relay(port, stream_bytes * percent / 100);
    const std::string out = (dir / ("cut" + std::to_string(percent) + ".drc")).string();
    CliRun r = run_cli("watch " + job + " -o " + out + " --server " + relay.address() + "," + at);
    ASSERT_EQ(r.code, 0) << r.all() << server.log();
    EXPECT_EQ(read_file(out), reference);
    const std::string lost = "vpremesh: lost " + relay.address() + " (";
    ASSERT_NE(r.err.find(lost), std::string::npos) << r.err;
    const std::string resumed = "); re-attaching to job " + job + " on " + at + " from event ";
    const size_t from = r.err.find(resumed);
    ASSERT_NE(from, std::string::npos) << r.err;
    latest_resume = std::max(latest_resume, std::stoi(r.err.substr(from + resumed.size())));
    // Every event shown once, in order: the same lines as without the break.
    EXPECT_EQ(without_lines(r.err, lost), whole.err);
  }
  EXPECT_GT(latest_resume, 0);  // from_sequence was used, not only a replay from 0
  fs::remove_all(dir);
}

}  // namespace
}  // namespace vpr
