// LoopStats / Histogram: percentiles against a sorted-vector computation (seeded samples).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "rt/loop_stats.h"

namespace wj::rt {
namespace {

using namespace std::chrono_literals;

double nearestRank(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const auto rank = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))));
  return v[rank - 1];
}

TEST(Histogram, PercentilesMatchSortedSamplesWithinOneBin) {
  std::mt19937_64 rng(7);
  std::lognormal_distribution<double> dist(2.0, 1.0);  // heavy tail, like jitter [µs]
  const double bin = 0.5;
  Histogram h(bin, 4000);
  std::vector<double> samples;
  for (int i = 0; i < 20000; ++i) {
    const double x = dist(rng);
    samples.push_back(x);
    h.add(x);
  }
  EXPECT_EQ(h.count(), samples.size());
  for (const double q : {0.01, 0.1, 0.5, 0.9, 0.99, 0.999}) {
    const double ref = nearestRank(samples, q);
    EXPECT_GE(h.percentile(q), ref) << "q = " << q;
    EXPECT_LE(h.percentile(q), ref + bin) << "q = " << q;
  }
  EXPECT_DOUBLE_EQ(h.max(), *std::max_element(samples.begin(), samples.end()));
  double sum = 0.0;
  for (double x : samples) sum += x;
  EXPECT_NEAR(h.mean(), sum / static_cast<double>(samples.size()), 1e-9);
  EXPECT_DOUBLE_EQ(h.percentile(1.0), h.max());
}

TEST(Histogram, OverflowReportsTheMaximum) {
  Histogram h(1.0, 10);
  for (int i = 0; i < 98; ++i) h.add(1.5);
  h.add(50.0);
  h.add(70.0);
  EXPECT_EQ(h.overflowCount(), 2u);
  EXPECT_DOUBLE_EQ(h.p50(), 2.0);
  EXPECT_DOUBLE_EQ(h.percentile(1.0), 70.0);
  EXPECT_DOUBLE_EQ(h.max(), 70.0);
  h.clear();
  EXPECT_EQ(h.count(), 0u);
  EXPECT_DOUBLE_EQ(h.p99(), 0.0);
}

TEST(Histogram, RejectsBadSizes) {
  EXPECT_THROW(Histogram(0.0, 10), std::invalid_argument);
  EXPECT_THROW(Histogram(1.0, 0), std::invalid_argument);
}

TEST(LoopStats, RecordsJitterComputeAndOverruns) {
  LoopStats stats(1ms);
  std::vector<double> jitter;
  for (int i = 0; i < 1000; ++i) {
    const auto period = 1ms + std::chrono::microseconds((i * 37) % 101 - 50);
    stats.recordPeriod(period, std::chrono::microseconds(100 + i % 7), i % 250 == 0);
    jitter.push_back(std::abs(static_cast<double>((i * 37) % 101 - 50)));
  }
  EXPECT_EQ(stats.iterations(), 1000u);
  EXPECT_EQ(stats.overruns(), 4u);
  EXPECT_NEAR(stats.jitter().p99(), nearestRank(jitter, 0.99), 1.0);
  EXPECT_NEAR(stats.jitter().p50(), nearestRank(jitter, 0.5), 1.0);
  EXPECT_DOUBLE_EQ(stats.jitter().max(), 50.0);
  EXPECT_DOUBLE_EQ(stats.compute().max(), 106.0);
  const nlohmann::json j = stats.toJson();
  EXPECT_EQ(j.at("iterations").get<std::uint64_t>(), 1000u);
  EXPECT_EQ(j.at("overruns").get<std::uint64_t>(), 4u);
  EXPECT_DOUBLE_EQ(j.at("jitter").at("max_us").get<double>(), 50.0);
  EXPECT_DOUBLE_EQ(j.at("period_us").get<double>(), 1000.0);
}

}  // namespace
}  // namespace wj::rt
