#pragma once
/// @file The solution cache: an LRU in memory with an entry bound, over an optional second-level
/// store (SQLite that survives restarts, or a Redis shared by replicas). An index by key family
/// (everything but v0) finds the nearest cached run-up speeds to warm-start a miss.

#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "server/cache_key.h"
#include "server/cached_solution.h"
#include "server/second_level_store.h"

namespace wj::server {

/// Counters of the cache since it was built.
struct CacheCounters {
  std::int64_t entries = 0;         ///< in memory now
  std::int64_t evictions = 0;       ///< memory evictions (the entries stay in the store)
  std::int64_t persisted_hits = 0;  ///< misses in memory found in the store
  std::string backend = "none";     ///< the store's backend(): "none", "sqlite", "redis"
  StoreCounters store;
};

/// Thread-safe; every operation holds one mutex for a short time except the store's calls,
/// which take the store's own lock.
class SolutionCache {
 public:
  /// `store` may be null (memory only). Loads the newest `max_entries` valid rows of the store.
  SolutionCache(std::int64_t max_entries, std::unique_ptr<SecondLevelStore> store);

  /// The entry of `key` in memory (and marks it most recently used). `generation`, if given,
  /// receives the entry's generation: a number that no other value stored in this cache, for
  /// any key, ever had or will have (a stamp for what is built from the entry).
  std::optional<CachedSolution> find(const CacheKey& key, std::uint64_t* generation = nullptr);
  /// The entry of `key` in the store, promoted into memory when found. Slow path: call it off
  /// the RPC threads. A store that cannot be reached answers a miss.
  std::optional<CachedSolution> findPersisted(const CacheKey& key);
  /// Stores `solution` unless the current entry is better (isBetterSolution). Persists it first,
  /// so that it is committed when put() returns; returns false if it was not stored. A failed
  /// store write keeps the solution in memory and rethrows.
  bool put(const CacheKey& key, const CachedSolution& solution);
  /// Up to `n` entries of the family of `key` (other v0 bins) nearest to its v0 bin, at most
  /// `max_bin_distance` bins away, nearest first, as (v0 bin, solution).
  std::vector<std::pair<std::int32_t, CachedSolution>> nearestByV0(const CacheKey& key, int n,
                                                                   int max_bin_distance);
  /// Checkpoints the store (the WAL is folded into the database file).
  void flush();
  CacheCounters counters() const;
  bool persistent() const { return store_ != nullptr; }

 private:
  struct Node {
    CacheKey key;
    CachedSolution solution;
    std::uint64_t generation = 0;  ///< see find()
  };
  using Lru = std::list<Node>;
  void insertLocked(const CacheKey& key, const CachedSolution& solution);

  std::int64_t max_entries_;
  std::unique_ptr<SecondLevelStore> store_;
  mutable std::mutex mu_;
  Lru lru_;  ///< most recently used first
  std::unordered_map<CacheKey, Lru::iterator, CacheKeyHash> map_;
  /// Family key -> the v0 bins cached in memory.
  std::unordered_map<CacheKey, std::map<std::int32_t, int>, CacheKeyHash> families_;
  std::uint64_t next_generation_ = 1;
  std::int64_t evictions_ = 0;
  std::int64_t persisted_hits_ = 0;
};

}  // namespace wj::server
