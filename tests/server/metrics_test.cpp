// The registry's text output parses as Prometheus exposition format 0.0.4 and
// carries the values put in.
#include "server/metrics.h"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>

#include <cmath>
#include <map>
#include <regex>
#include <sstream>

#include "http_get.h"
#include "server/metrics_http.h"

namespace vpr::service {
namespace {

struct Parsed {
  std::map<std::string, std::string> type, help;
  std::map<std::string, double> samples;  // "name{labels}" -> value
};

// A strict reader of the format: comment lines are HELP/TYPE, every sample
// line is `name{label="value",...} number`, and each sample belongs to a
// family declared (TYPE) before it.
Parsed parse(const std::string& text) {
  Parsed p;
  const std::regex help(R"(^# HELP ([a-zA-Z_:][a-zA-Z0-9_:]*) (.*)$)");
  const std::regex type(R"(^# TYPE ([a-zA-Z_:][a-zA-Z0-9_:]*) (counter|gauge|histogram|summary|untyped)$)");
  const std::regex sample(
      R"(^([a-zA-Z_:][a-zA-Z0-9_:]*)(\{([a-zA-Z_][a-zA-Z0-9_]*="([^"\\\n]|\\.)*",?)*\})? ([-+]?([0-9.eE+-]+|Inf|NaN))$)");
  std::istringstream in(text);
  std::string line, family;
  while (std::getline(in, line)) {
    std::smatch m;
    if (std::regex_match(line, m, help)) {
      p.help[m[1]] = m[2];
    } else if (std::regex_match(line, m, type)) {
      family = m[1];
      p.type[family] = m[2];
    } else if (std::regex_match(line, m, sample)) {
      const std::string name = m[1];
      EXPECT_EQ(name.rfind(family, 0), 0u) << "sample " << name << " outside its family " << family;
      const std::string v = m[5];
      p.samples[name + std::string(m[2])] = v == "+Inf" ? INFINITY : std::stod(v);
    } else {
      ADD_FAILURE() << "not exposition format: '" << line << "'";
    }
  }
  EXPECT_TRUE(text.empty() || text.back() == '\n');
  return p;
}

TEST(Metrics, CountersAndGaugesWithLabels) {
  MetricsRegistry r;
  r.counter("jobs_total", "Jobs", {{"state", "failed"}}).inc(2);
  r.counter("jobs_total", "Jobs", {{"state", "succeeded"}}).inc();
  r.counter("jobs_total", "Jobs", {{"state", "succeeded"}}).inc(0.5);
  r.gauge("queue_length", "Waiting jobs").set(7);
  r.gauge("queue_length", "Waiting jobs").add(-2);
  const Parsed p = parse(r.render());
  EXPECT_EQ(p.type.at("jobs_total"), "counter");
  EXPECT_EQ(p.type.at("queue_length"), "gauge");
  EXPECT_EQ(p.help.at("queue_length"), "Waiting jobs");
  EXPECT_EQ(p.samples.at("jobs_total{state=\"failed\"}"), 2);
  EXPECT_EQ(p.samples.at("jobs_total{state=\"succeeded\"}"), 1.5);
  EXPECT_EQ(p.samples.at("queue_length"), 5);
}

TEST(Metrics, HistogramBucketsAreCumulativeWithInfSumAndCount) {
  MetricsRegistry r;
  Histogram& h = r.histogram("stage_seconds", "Stage time", {0.1, 1, 10}, {{"stage", "awlop"}});
  for (double v : {0.05, 0.1, 0.5, 3.0, 20.0}) h.observe(v);
  const Parsed p = parse(r.render());
  EXPECT_EQ(p.type.at("stage_seconds"), "histogram");
  EXPECT_EQ(p.samples.at("stage_seconds_bucket{stage=\"awlop\",le=\"0.1\"}"), 2);  // le is inclusive
  EXPECT_EQ(p.samples.at("stage_seconds_bucket{stage=\"awlop\",le=\"1\"}"), 3);
  EXPECT_EQ(p.samples.at("stage_seconds_bucket{stage=\"awlop\",le=\"10\"}"), 4);
  EXPECT_EQ(p.samples.at("stage_seconds_bucket{stage=\"awlop\",le=\"+Inf\"}"), 5);
  EXPECT_EQ(p.samples.at("stage_seconds_count{stage=\"awlop\"}"), 5);
  EXPECT_DOUBLE_EQ(p.samples.at("stage_seconds_sum{stage=\"awlop\"}"), 23.65);
}

TEST(Metrics, LabelValuesAreEscaped) {
  EXPECT_EQ(format_labels({{"a", "x\"y\\z\nw"}}), "{a=\"x\\\"y\\\\z\\nw\"}");
  MetricsRegistry r;
  r.gauge("g", "help with \\ and\nnewline", {{"label", "quote\" here"}}).set(1);
  const Parsed p = parse(r.render());
  EXPECT_EQ(p.help.at("g"), "help with \\\\ and\\nnewline");
  EXPECT_EQ(p.samples.size(), 1u);
}

TEST(Metrics, ValuesRoundTrip) {
  for (double v : {0.0, 1.0, 0.1, 1e-9, 123456789.0, 2.5e300, -3.25})
    EXPECT_EQ(std::stod(format_value(v)), v) << format_value(v);
  EXPECT_EQ(format_value(0.1), "0.1");
  EXPECT_EQ(format_value(INFINITY), "+Inf");
  EXPECT_EQ(format_value(NAN), "NaN");
}

// The /metrics endpoint: each GET renders afresh; other paths and methods
// get their HTTP error; HEAD has no body; a client that connects and sends
// nothing holds the endpoint for the read timeout only.
TEST(MetricsHttp, ServesMetricsAndRefusesEverythingElse) {
  std::atomic<int> renders{0};
  MetricsHttpServer http;
  auto port = http.start("127.0.0.1:0", [&] { return "scrapes " + std::to_string(++renders) + "\n"; });
  ASSERT_TRUE(port.ok()) << port.status().to_string();
  ASSERT_GT(*port, 0);

  const std::string first = testing::http_get(*port, "/metrics");
  EXPECT_EQ(first.rfind("HTTP/1.1 200 OK\r\n", 0), 0u) << first;
  EXPECT_NE(first.find("Content-Type: text/plain; version=0.0.4"), std::string::npos) << first;
  EXPECT_NE(first.find("Content-Length: 10\r\n"), std::string::npos) << first;
  EXPECT_EQ(first.substr(first.size() - 10), "scrapes 1\n");
  EXPECT_NE(testing::http_get(*port, "/metrics?x=1").find("\r\n\r\nscrapes 2\n"), std::string::npos);

  EXPECT_EQ(testing::http_get(*port, "/").rfind("HTTP/1.1 404 ", 0), 0u);
  EXPECT_EQ(testing::http_request(*port, "POST /metrics HTTP/1.1\r\nHost: t\r\n\r\n").rfind("HTTP/1.1 405 ", 0), 0u);
  const std::string head = testing::http_request(*port, "HEAD /metrics HTTP/1.1\r\nHost: t\r\n\r\n");
  EXPECT_EQ(head.rfind("HTTP/1.1 200 OK\r\n", 0), 0u) << head;
  EXPECT_EQ(head.substr(head.size() - 4), "\r\n\r\n") << head;
  const std::string huge(20000, 'x');
  EXPECT_EQ(testing::http_request(*port, "GET /metrics HTTP/1.1\r\nX: " + huge + "\r\n\r\n").rfind("HTTP/1.1 431 ", 0),
            0u);

  const int silent = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = htons(uint16_t(*port));
  ASSERT_EQ(::connect(silent, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  const auto start = std::chrono::steady_clock::now();
  const std::string after = testing::http_get(*port, "/metrics");
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ::close(silent);
  EXPECT_NE(after.find("scrapes "), std::string::npos) << after;
  EXPECT_LT(waited, 30.0) << "a silent client held the endpoint";
  http.stop();
  EXPECT_EQ(testing::http_get(*port, "/metrics"), "") << "still serving after stop()";
}

// Rendering on a thread whose stack must hold this process's static TLS
// (CGAL's is 64 KiB here): civetweb's 100 KiB threads overflowed on this.
TEST(MetricsHttp, RenderMayUseADeepStack) {
  MetricsHttpServer http;
  auto port = http.start("127.0.0.1:0", [] {
    volatile char scratch[512 * 1024];
    for (size_t i = 0; i < sizeof scratch; i += 4096) scratch[i] = char(i);
    return std::string("deep ") + std::to_string(int(scratch[4096])) + "\n";
  });
  ASSERT_TRUE(port.ok());
  EXPECT_NE(testing::http_get(*port, "/metrics").find("\r\n\r\ndeep 0\n"), std::string::npos);
}

TEST(MetricsHttp, AnAddressInUseNamesTheFlag) {
  MetricsHttpServer first, second;
  auto port = first.start("127.0.0.1:0", [] { return std::string(); });
  ASSERT_TRUE(port.ok());
  auto clash = second.start("127.0.0.1:" + std::to_string(*port), [] { return std::string(); });
  ASSERT_FALSE(clash.ok());
  EXPECT_EQ(clash.status().code(), StatusCode::kUnavailable);
  EXPECT_NE(clash.status().message().find("--metrics-listen"), std::string::npos) << clash.status().message();
  EXPECT_NE(clash.status().message().find("in use"), std::string::npos) << clash.status().message();
}

}  // namespace
}  // namespace vpr::service
