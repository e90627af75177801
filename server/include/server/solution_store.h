#pragma once
/// @file Persistence of cached solutions in SQLite (WAL journal). A put() returns only once its
/// transaction is committed, so a crash at any instant (kill -9 included) loses no solution whose
/// put() returned. Every row carries a CRC-32 of key and payload; a row that fails it (or does
/// not decode) is deleted and never served.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "server/cache_key.h"
#include "server/cached_solution.h"
#include "server/second_level_store.h"

struct sqlite3;
struct sqlite3_stmt;

namespace wj::server {

/// One SQLite database of solutions. Thread-safe (one connection behind a mutex).
class SolutionStore final : public SecondLevelStore {
 public:
  /// Opens or creates `path`. A file that SQLite cannot read as a database is renamed to
  /// `<path>.corrupt-<unix time>` and a fresh one is created (recreated = true). Throws
  /// std::runtime_error if the database cannot be opened at all.
  SolutionStore(const std::filesystem::path& path, bool synchronous_full, std::int64_t max_rows);
  ~SolutionStore() override;
  SolutionStore(const SolutionStore&) = delete;
  SolutionStore& operator=(const SolutionStore&) = delete;

  /// Inserts or replaces the row of `key`; returns when committed. Throws std::runtime_error on
  /// failure (the caller keeps the solution in memory).
  void put(const CacheKey& key, const CachedSolution& solution) override;
  /// Inserts or replaces many rows in one transaction (bulk loads, benchmarks); returns when
  /// committed. Throws std::runtime_error on failure (nothing of the batch is written then).
  void putMany(const std::vector<std::pair<CacheKey, CachedSolution>>& rows);
  /// The row of `key` if it exists and passes its checksum.
  std::optional<CachedSolution> get(const CacheKey& key) override;
  /// Calls `visit` for every valid row, most recently written first, at most `limit` rows.
  /// Invalid rows are deleted and counted.
  void forEachNewest(
      std::int64_t limit,
      const std::function<void(const CacheKey&, const CachedSolution&)>& visit) override;
  /// Number of rows.
  std::int64_t count();
  /// Copies the WAL into the database file (TRUNCATE checkpoint); called at shutdown.
  void checkpoint() override;
  StoreCounters counters() const override;
  std::string_view backend() const override { return "sqlite"; }
  std::string describe() const override;
  const std::filesystem::path& path() const { return path_; }

 private:
  void open(bool synchronous_full);
  void exec(const char* sql);
  sqlite3_stmt* prepare(const char* sql);
  void deleteRow(const std::string& key_bytes);
  void pruneLocked();

  std::filesystem::path path_;
  std::int64_t max_rows_;
  mutable std::mutex mu_;
  sqlite3* db_ = nullptr;
  sqlite3_stmt* put_ = nullptr;
  sqlite3_stmt* get_ = nullptr;
  sqlite3_stmt* delete_ = nullptr;
  std::int64_t next_seq_ = 1;
  std::int64_t rows_ = 0;
  mutable std::mutex counters_mu_;  ///< never held during I/O: counters() does not wait for it
  StoreCounters counters_;
};

}  // namespace wj::server
