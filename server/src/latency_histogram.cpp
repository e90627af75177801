#include "server/latency_histogram.h"

#include <algorithm>
#include <cmath>

namespace wj::server {

void LatencyHistogram::record(double ms) {
  const double us = std::isfinite(ms) ? std::max(ms * 1e3, 1.0) : 1.0;
  const int index = static_cast<int>(std::floor(std::log2(us) * kPerOctave));
  buckets_[static_cast<std::size_t>(std::clamp(index, 0, kBuckets - 1))].fetch_add(
      1, std::memory_order_relaxed);
  count_.fetch_add(1, std::memory_order_relaxed);
}

std::uint64_t LatencyHistogram::count() const {
  return count_.load(std::memory_order_relaxed);
}

double LatencyHistogram::quantile(double q) const {
  std::array<std::uint64_t, kBuckets> snapshot{};
  std::uint64_t total = 0;
  for (int i = 0; i < kBuckets; ++i) {
    snapshot[static_cast<std::size_t>(i)] =
        buckets_[static_cast<std::size_t>(i)].load(std::memory_order_relaxed);
    total += snapshot[static_cast<std::size_t>(i)];
  }
  if (total == 0) return 0.0;
  // The smallest bucket whose cumulative count reaches ceil(q * total) (at least 1).
  const auto rank = std::max<std::uint64_t>(
      1,
      static_cast<std::uint64_t>(std::ceil(std::clamp(q, 0.0, 1.0) * static_cast<double>(total))));
  std::uint64_t cumulative = 0;
  for (int i = 0; i < kBuckets; ++i) {
    cumulative += snapshot[static_cast<std::size_t>(i)];
    if (cumulative >= rank) return std::exp2(static_cast<double>(i + 1) / kPerOctave) * 1e-3;
  }
  return std::exp2(static_cast<double>(kBuckets) / kPerOctave) * 1e-3;
}

}  // namespace wj::server
