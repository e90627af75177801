#pragma once
/// @file A lock-free latency histogram with logarithmic buckets (16 per octave, about 4.4 %
/// relative resolution) from 1 microsecond to about 1000 seconds: fixed memory whatever the
/// number of samples, percentiles good to a bucket's width.

#include <array>
#include <atomic>
#include <cstdint>

namespace wj::server {

class LatencyHistogram {
 public:
  /// Records one latency [ms]; values outside the range fall in the first or last bucket.
  void record(double ms);
  /// Samples recorded.
  std::uint64_t count() const;
  /// The q-quantile (q in [0, 1]) [ms]: the upper edge of the bucket holding it; 0 if empty.
  double quantile(double q) const;

 private:
  static constexpr int kPerOctave = 16;
  static constexpr int kOctaves = 30;  // 1 us * 2^30 ~ 1074 s
  static constexpr int kBuckets = kPerOctave * kOctaves;
  std::array<std::atomic<std::uint64_t>, kBuckets> buckets_{};
  std::atomic<std::uint64_t> count_{0};
};

}  // namespace wj::server
