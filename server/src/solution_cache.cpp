#include "server/solution_cache.h"

#include <algorithm>
#include <cstdlib>
#include <string>

namespace wj::server {

SolutionCache::SolutionCache(std::int64_t max_entries, std::unique_ptr<SecondLevelStore> store)
    : max_entries_(std::max<std::int64_t>(1, max_entries)), store_(std::move(store)) {
  if (!store_) return;
  // Newest first: the first rows read are the most recently written, so the LRU order after
  // loading matches the write order.
  std::vector<std::pair<CacheKey, CachedSolution>> rows;
  store_->forEachNewest(
      max_entries_, [&](const CacheKey& k, const CachedSolution& s) { rows.emplace_back(k, s); });
  std::lock_guard lock(mu_);
  for (auto it = rows.rbegin(); it != rows.rend(); ++it) insertLocked(it->first, it->second);
}

void SolutionCache::insertLocked(const CacheKey& key, const CachedSolution& solution) {
  if (const auto it = map_.find(key); it != map_.end()) {
    it->second->solution = solution;
    it->second->generation = next_generation_++;
    lru_.splice(lru_.begin(), lru_, it->second);
    return;
  }
  lru_.push_front(Node{key, solution, next_generation_++});
  map_.emplace(key, lru_.begin());
  ++families_[key.family()][key.v0_bin];
  while (static_cast<std::int64_t>(map_.size()) > max_entries_) {
    const CacheKey& victim = lru_.back().key;
    const auto fam = families_.find(victim.family());
    if (fam != families_.end()) {
      if (--fam->second[victim.v0_bin] <= 0) fam->second.erase(victim.v0_bin);
      if (fam->second.empty()) families_.erase(fam);
    }
    map_.erase(victim);
    lru_.pop_back();
    ++evictions_;
  }
}

std::optional<CachedSolution> SolutionCache::find(const CacheKey& key, std::uint64_t* generation) {
  std::lock_guard lock(mu_);
  const auto it = map_.find(key);
  if (it == map_.end()) return std::nullopt;
  lru_.splice(lru_.begin(), lru_, it->second);
  if (generation) *generation = it->second->generation;
  return it->second->solution;
}

std::optional<CachedSolution> SolutionCache::findPersisted(const CacheKey& key) {
  if (!store_) return std::nullopt;
  auto s = store_->get(key);
  if (!s) return std::nullopt;
  std::lock_guard lock(mu_);
  ++persisted_hits_;
  if (!map_.count(key)) insertLocked(key, *s);
  return s;
}

bool SolutionCache::put(const CacheKey& key, const CachedSolution& solution) {
  {
    std::lock_guard lock(mu_);
    const auto it = map_.find(key);
    if (it != map_.end() && !isBetterSolution(solution, it->second->solution)) return false;
  }
  std::exception_ptr write_error;
  if (store_) {
    try {
      store_->put(key, solution);
    } catch (...) {
      write_error = std::current_exception();
    }
  }
  {
    std::lock_guard lock(mu_);
    const auto it = map_.find(key);
    // A concurrent put may have stored a better one meanwhile.
    if (it == map_.end() || isBetterSolution(solution, it->second->solution))
      insertLocked(key, solution);
  }
  if (write_error) std::rethrow_exception(write_error);
  return true;
}

std::vector<std::pair<std::int32_t, CachedSolution>> SolutionCache::nearestByV0(
    const CacheKey& key, int n, int max_bin_distance) {
  std::vector<std::pair<std::int32_t, CachedSolution>> out;
  if (n <= 0) return out;
  std::lock_guard lock(mu_);
  const auto fam = families_.find(key.family());
  if (fam == families_.end()) return out;
  std::vector<std::int32_t> bins;
  for (const auto& [bin, count] : fam->second)
    if (bin != key.v0_bin && std::abs(bin - key.v0_bin) <= max_bin_distance) bins.push_back(bin);
  std::stable_sort(bins.begin(), bins.end(), [&](std::int32_t a, std::int32_t b) {
    return std::abs(a - key.v0_bin) < std::abs(b - key.v0_bin);
  });
  for (const std::int32_t bin : bins) {
    if (static_cast<int>(out.size()) >= n) break;
    CacheKey k = key;
    k.v0_bin = bin;
    const auto it = map_.find(k);
    if (it != map_.end()) out.emplace_back(bin, it->second->solution);
  }
  return out;
}

void SolutionCache::flush() {
  if (store_) store_->checkpoint();
}

CacheCounters SolutionCache::counters() const {
  CacheCounters c;
  {
    std::lock_guard lock(mu_);
    c.entries = static_cast<std::int64_t>(map_.size());
    c.evictions = evictions_;
    c.persisted_hits = persisted_hits_;
  }
  if (store_) {
    c.store = store_->counters();
    c.backend = std::string(store_->backend());
  }
  return c;
}

}  // namespace wj::server
