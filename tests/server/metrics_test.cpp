// The registry's text output parses as Prometheus exposition format 0.0.4 and
// carries the values put in.
#include "server/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <regex>
#include <sstream>

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

}  // namespace
}  // namespace vpr::service
