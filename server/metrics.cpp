#include "server/metrics.h"

#include <cassert>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace vpr::service {

void Counter::inc(double v) {
  assert(v >= 0);
  std::lock_guard<std::mutex> lock(mu_);
  value_ += v;
}
double Counter::value() const {
  std::lock_guard<std::mutex> lock(mu_);
  return value_;
}

void Gauge::set(double v) {
  std::lock_guard<std::mutex> lock(mu_);
  value_ = v;
}
void Gauge::add(double v) {
  std::lock_guard<std::mutex> lock(mu_);
  value_ += v;
}
double Gauge::value() const {
  std::lock_guard<std::mutex> lock(mu_);
  return value_;
}

Histogram::Histogram(std::vector<double> upper_bounds)
    : bounds_(std::move(upper_bounds)), counts_(bounds_.size() + 1, 0) {
  for (size_t i = 1; i < bounds_.size(); ++i) assert(bounds_[i - 1] < bounds_[i]);
}

void Histogram::observe(double v) {
  std::lock_guard<std::mutex> lock(mu_);
  size_t b = 0;
  while (b < bounds_.size() && v > bounds_[b]) ++b;  // buckets are "le": v <= bound
  ++counts_[b];
  sum_ += v;
}

Histogram::Snapshot Histogram::snapshot() const {
  std::lock_guard<std::mutex> lock(mu_);
  Snapshot s;
  s.upper_bounds = bounds_;
  uint64_t running = 0;
  for (uint64_t c : counts_) {
    running += c;
    s.cumulative.push_back(running);
  }
  s.count = running;
  s.sum = sum_;
  return s;
}

std::string format_labels(const Labels& labels) {
  if (labels.empty()) return "";
  std::string out = "{";
  for (size_t i = 0; i < labels.size(); ++i) {
    if (i) out += ',';
    out += labels[i].first + "=\"";
    for (char c : labels[i].second) {
      if (c == '\\')
        out += "\\\\";
      else if (c == '"')
        out += "\\\"";
      else if (c == '\n')
        out += "\\n";
      else
        out += c;
    }
    out += '"';
  }
  return out + "}";
}

std::string format_value(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  char buf[32];
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

MetricsRegistry::Family& MetricsRegistry::family(const std::string& name, const std::string& help, Type type) {
  auto [it, inserted] = families_.try_emplace(name);
  if (inserted) {
    it->second.help = help;
    it->second.type = type;
  }
  assert(it->second.type == type);
  return it->second;
}

Counter& MetricsRegistry::counter(const std::string& name, const std::string& help, const Labels& labels) {
  std::lock_guard<std::mutex> lock(mu_);
  Family& f = family(name, help, Type::kCounter);
  const std::string key = format_labels(labels);
  f.labels.emplace(key, labels);
  auto& slot = f.counters[key];
  if (!slot) slot = std::make_unique<Counter>();
  return *slot;
}

Gauge& MetricsRegistry::gauge(const std::string& name, const std::string& help, const Labels& labels) {
  std::lock_guard<std::mutex> lock(mu_);
  Family& f = family(name, help, Type::kGauge);
  const std::string key = format_labels(labels);
  f.labels.emplace(key, labels);
  auto& slot = f.gauges[key];
  if (!slot) slot = std::make_unique<Gauge>();
  return *slot;
}

Histogram& MetricsRegistry::histogram(const std::string& name, const std::string& help,
                                      const std::vector<double>& upper_bounds, const Labels& labels) {
  std::lock_guard<std::mutex> lock(mu_);
  Family& f = family(name, help, Type::kHistogram);
  const std::string key = format_labels(labels);
  f.labels.emplace(key, labels);
  auto& slot = f.histograms[key];
  if (!slot) slot = std::make_unique<Histogram>(upper_bounds);
  return *slot;
}

std::string MetricsRegistry::render() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::string out;
  for (const auto& [name, f] : families_) {
    std::string help;
    for (char c : f.help) help += c == '\n' ? std::string("\\n") : c == '\\' ? std::string("\\\\") : std::string(1, c);
    out += "# HELP " + name + " " + help + "\n";
    out += "# TYPE " + name + " " +
           (f.type == Type::kCounter ? "counter"
            : f.type == Type::kGauge ? "gauge"
                                     : "histogram") +
           "\n";
    for (const auto& [key, labels] : f.labels) {
      if (f.type == Type::kCounter) {
        out += name + key + " " + format_value(f.counters.at(key)->value()) + "\n";
      } else if (f.type == Type::kGauge) {
        out += name + key + " " + format_value(f.gauges.at(key)->value()) + "\n";
      } else {
        const Histogram::Snapshot s = f.histograms.at(key)->snapshot();
        for (size_t b = 0; b <= s.upper_bounds.size(); ++b) {
          Labels with_le = labels;
          with_le.emplace_back("le", b < s.upper_bounds.size() ? format_value(s.upper_bounds[b]) : "+Inf");
          out += name + "_bucket" + format_labels(with_le) + " " + std::to_string(s.cumulative[b]) + "\n";
        }
        out += name + "_sum" + key + " " + format_value(s.sum) + "\n";
        out += name + "_count" + key + " " + std::to_string(s.count) + "\n";
      }
    }
  }
  return out;
}

}  // namespace vpr::service
