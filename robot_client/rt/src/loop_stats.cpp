#include "rt/loop_stats.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace wj::rt {
namespace {

double toUs(std::chrono::nanoseconds d) {
  return static_cast<double>(d.count()) * 1e-3;
}

}  // namespace

Histogram::Histogram(double bin_width_us, int num_bins) : bin_width_us_(bin_width_us) {
  if (!(bin_width_us > 0.0))
    throw std::invalid_argument("Histogram: bin_width_us must be > 0, got " +
                                std::to_string(bin_width_us));
  if (num_bins < 1)
    throw std::invalid_argument("Histogram: num_bins must be >= 1, got " +
                                std::to_string(num_bins));
  bins_.assign(static_cast<std::size_t>(num_bins) + 1, 0);
}

void Histogram::add(double value_us) {
  const double v = std::isnan(value_us) ? 0.0 : std::max(value_us, 0.0);
  const double last = static_cast<double>(bins_.size() - 1);
  const double b = std::min(std::floor(v / bin_width_us_), last);
  ++bins_[static_cast<std::size_t>(b)];
  ++count_;
  sum_ += v;
  max_ = std::max(max_, v);
}

void Histogram::clear() {
  std::fill(bins_.begin(), bins_.end(), 0);
  count_ = 0;
  sum_ = 0.0;
  max_ = 0.0;
}

double Histogram::percentile(double q) const {
  if (count_ == 0) return 0.0;
  const double qc = std::clamp(q, 0.0, 1.0);
  // Nearest rank: the smallest sample with at least ceil(q n) samples at or below it.
  const auto rank = std::max<std::uint64_t>(
      1, static_cast<std::uint64_t>(std::ceil(qc * static_cast<double>(count_))));
  std::uint64_t cumulative = 0;
  for (std::size_t b = 0; b < bins_.size(); ++b) {
    cumulative += bins_[b];
    if (cumulative >= rank) {
      if (b + 1 == bins_.size()) return max_;  // overflow bin: only the maximum is known
      return std::min(static_cast<double>(b + 1) * bin_width_us_, max_);
    }
  }
  return max_;
}

nlohmann::json Histogram::toJson() const {
  return {{"count", count_},
          {"mean_us", mean()},
          {"p50_us", p50()},
          {"p99_us", p99()},
          {"max_us", max()}};
}

LoopStats::LoopStats(std::chrono::nanoseconds nominal_period, double bin_width_us, int num_bins)
    : nominal_(nominal_period), jitter_(bin_width_us, num_bins), compute_(bin_width_us, num_bins) {}

void LoopStats::record(std::chrono::nanoseconds jitter, std::chrono::nanoseconds compute,
                       bool overrun) {
  jitter_.add(std::abs(toUs(jitter)));
  compute_.add(toUs(compute));
  if (overrun) ++overruns_;
}

void LoopStats::recordPeriod(std::chrono::nanoseconds actual_period,
                             std::chrono::nanoseconds compute, bool overrun) {
  record(actual_period - nominal_, compute, overrun);
}

void LoopStats::clear() {
  jitter_.clear();
  compute_.clear();
  overruns_ = 0;
}

nlohmann::json LoopStats::toJson() const {
  return {{"period_us", toUs(nominal_)},
          {"iterations", iterations()},
          {"overruns", overruns_},
          {"jitter", jitter_.toJson()},
          {"compute", compute_.toJson()}};
}

}  // namespace wj::rt
