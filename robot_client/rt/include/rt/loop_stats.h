#pragma once
/// @file Statistics of a periodic loop: histograms of period jitter (or wake-up lateness) and
/// of compute time, overruns and iterations. Recording is allocation-free (fixed histogram
/// allocated at construction) and lock-free; reading and toJson() belong outside the loop.

#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

namespace wj::rt {

/// Fixed-bin histogram of durations in microseconds: bins of `bin_width_us` from 0 to
/// num_bins * bin_width_us, plus one overflow bin; the exact maximum is kept beside. Percentiles
/// are exact to one bin width (the upper edge of the bin holding the nearest-rank sample,
/// capped at the maximum).
class Histogram {
 public:
  /// Throws std::invalid_argument unless bin_width_us > 0 and num_bins >= 1.
  Histogram(double bin_width_us, int num_bins);

  /// Adds one sample [µs] (negative samples count as 0). Allocation-free.
  void add(double value_us);
  /// Forgets all samples.
  void clear();

  /// Number of samples.
  std::uint64_t count() const { return count_; }
  /// Nearest-rank q-quantile, q in [0, 1] [µs]; 0 without samples.
  double percentile(double q) const;
  /// Median [µs].
  double p50() const { return percentile(0.5); }
  /// 99th percentile [µs].
  double p99() const { return percentile(0.99); }
  /// Largest sample [µs] (exact); 0 without samples.
  double max() const { return max_; }
  /// Mean of the samples [µs] (exact); 0 without samples.
  double mean() const { return count_ > 0 ? sum_ / static_cast<double>(count_) : 0.0; }
  /// Samples beyond the last bin.
  std::uint64_t overflowCount() const { return bins_.back(); }
  /// Bin width [µs].
  double binWidth() const { return bin_width_us_; }
  /// {"count", "mean_us", "p50_us", "p99_us", "max_us"}.
  nlohmann::json toJson() const;

 private:
  double bin_width_us_;
  std::vector<std::uint64_t> bins_;  // num_bins + overflow
  std::uint64_t count_ = 0;
  double sum_ = 0.0;
  double max_ = 0.0;
};

/// Jitter and compute-time statistics of one loop. One thread records; read the figures after
/// the loop stopped (or accept a torn snapshot).
class LoopStats {
 public:
  /// Histograms of `num_bins` bins of `bin_width_us` each (default: 1 µs up to 20 ms).
  explicit LoopStats(std::chrono::nanoseconds nominal_period, double bin_width_us = 1.0,
                     int num_bins = 20000);

  /// One iteration: `jitter` (|actual period - nominal| or wake-up lateness, as the caller
  /// chooses and says in its report), `compute` (time of the loop body), whether it overran.
  void record(std::chrono::nanoseconds jitter, std::chrono::nanoseconds compute, bool overrun);
  /// Same, jitter taken as |actual_period - nominal period|.
  void recordPeriod(std::chrono::nanoseconds actual_period, std::chrono::nanoseconds compute,
                    bool overrun);
  /// Forgets everything.
  void clear();

  /// Jitter histogram [µs].
  const Histogram& jitter() const { return jitter_; }
  /// Compute-time histogram [µs].
  const Histogram& compute() const { return compute_; }
  /// Iterations recorded.
  std::uint64_t iterations() const { return jitter_.count(); }
  /// Iterations recorded as overruns.
  std::uint64_t overruns() const { return overruns_; }
  /// Nominal period of the loop.
  std::chrono::nanoseconds nominalPeriod() const { return nominal_; }

  /// {"period_us", "iterations", "overruns", "jitter": {...}, "compute": {...}} (allocates).
  nlohmann::json toJson() const;

 private:
  std::chrono::nanoseconds nominal_;
  Histogram jitter_;
  Histogram compute_;
  std::uint64_t overruns_ = 0;
};

}  // namespace wj::rt
