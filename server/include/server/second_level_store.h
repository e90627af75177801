#pragma once
/// @file The second level of the solution cache, behind the in-memory LRU: the embedded SQLite
/// file (SolutionStore, the default) or a Redis shared by several replicas (RedisStore). Both
/// keep the same value discipline: a CRC-32 over key and payload (rowChecksum), and a value that
/// fails it or does not decode is never served. docs/service.md ("Cache"), docs/scaling.md.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "server/cache_key.h"
#include "server/cached_solution.h"

namespace wj::server {

/// Counters of a store since it was opened. Fields a backend has no use for stay 0.
struct StoreCounters {
  std::int64_t rows_loaded = 0;     ///< entries read back at open (preloaded into memory)
  std::int64_t corrupt_rows = 0;    ///< entries refused (checksum, decode, key length)
  std::int64_t writes = 0;          ///< committed puts
  std::int64_t write_errors = 0;    ///< puts that failed (disk full, I/O, Redis unreachable)
  std::int64_t pruned_rows = 0;     ///< oldest rows deleted to respect the row bound (SQLite)
  bool recreated = false;           ///< the file was unreadable and was moved aside (SQLite)
  std::int64_t read_errors = 0;     ///< gets that failed and were answered as misses (Redis)
  std::int64_t reconnects = 0;      ///< connections re-established after a failure (Redis)
  std::int64_t writes_skipped = 0;  ///< puts not applied: the stored entry was better (Redis)
  bool available = true;            ///< the last operation reached the store
};

/// A persistent or shared store of solutions. Implementations are thread-safe; every call may
/// do I/O, so SolutionCache calls them off the RPC threads and outside its own lock.
class SecondLevelStore {
 public:
  virtual ~SecondLevelStore() = default;

  /// Stores the entry of `key`; returns when it is durable in the store. Throws
  /// std::runtime_error on failure (the caller keeps the solution in memory).
  virtual void put(const CacheKey& key, const CachedSolution& solution) = 0;
  /// The entry of `key` if it exists and passes its checksum; nullopt on a miss, and also when
  /// the store cannot be reached (counted, never thrown: a failed read is a miss).
  virtual std::optional<CachedSolution> get(const CacheKey& key) = 0;
  /// Calls `visit` for at most `limit` valid entries, newest first where the store knows the
  /// order; used once at start to fill the memory level.
  virtual void forEachNewest(
      std::int64_t limit,
      const std::function<void(const CacheKey&, const CachedSolution&)>& visit) = 0;
  /// Makes everything written durable (SQLite: WAL checkpoint); called at shutdown.
  virtual void checkpoint() = 0;
  virtual StoreCounters counters() const = 0;
  /// "sqlite" or "redis" (GetStats, logs).
  virtual std::string_view backend() const = 0;
  /// One line for the start-up log: where the store is.
  virtual std::string describe() const = 0;
};

}  // namespace wj::server
