#include "server/solution_store.h"

#include <sqlite3.h>

#include <chrono>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace wj::server {

namespace {

std::string columnBlob(sqlite3_stmt* st, int col) {
  const auto* data = static_cast<const char*>(sqlite3_column_blob(st, col));
  const int n = sqlite3_column_bytes(st, col);
  return data ? std::string(data, static_cast<std::size_t>(n)) : std::string();
}

// Resets a statement when the scope ends, whatever happens in between.
class StatementScope {
 public:
  explicit StatementScope(sqlite3_stmt* st) : st_(st) {}
  ~StatementScope() {
    sqlite3_reset(st_);
    sqlite3_clear_bindings(st_);
  }
  StatementScope(const StatementScope&) = delete;
  StatementScope& operator=(const StatementScope&) = delete;

 private:
  sqlite3_stmt* st_;
};

// A database file SQLite cannot read (not a database, or a damaged structure).
struct CorruptDatabase : std::runtime_error {
  using std::runtime_error::runtime_error;
};

bool isCorruption(int rc) {
  return (rc & 0xff) == SQLITE_CORRUPT || (rc & 0xff) == SQLITE_NOTADB;
}

std::optional<CachedSolution> validRow(const std::string& key, const std::string& payload,
                                       std::int64_t checksum) {
  if (key.size() != CacheKey::kBytes) return std::nullopt;
  if (static_cast<std::int64_t>(rowChecksum(key, payload)) != checksum) return std::nullopt;
  return decodeSolution(payload);
}

}  // namespace

SolutionStore::SolutionStore(const std::filesystem::path& path, bool synchronous_full,
                             std::int64_t max_rows)
    : path_(path), max_rows_(max_rows) {
  if (path_.has_parent_path()) std::filesystem::create_directories(path_.parent_path());
  try {
    open(synchronous_full);
  } catch (const CorruptDatabase&) {
    // Unreadable as a database: keep it for inspection and start afresh.
    if (db_) {
      sqlite3_close(db_);
      db_ = nullptr;
    }
    const auto stamp = std::to_string(std::chrono::duration_cast<std::chrono::seconds>(
                                          std::chrono::system_clock::now().time_since_epoch())
                                          .count());
    for (const char* suffix : {"", "-wal", "-shm"}) {
      const std::filesystem::path p = path_.string() + suffix;
      std::error_code ec;
      if (std::filesystem::exists(p, ec))
        std::filesystem::rename(p, path_.string() + suffix + ".corrupt-" + stamp, ec);
    }
    counters_.recreated = true;
    open(synchronous_full);
  }
}

SolutionStore::~SolutionStore() {
  for (sqlite3_stmt* st : {put_, get_, delete_})
    if (st) sqlite3_finalize(st);
  if (db_) sqlite3_close(db_);
}

void SolutionStore::exec(const char* sql) {
  char* err = nullptr;
  const int rc = sqlite3_exec(db_, sql, nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    const std::string what = err ? err : sqlite3_errmsg(db_);
    sqlite3_free(err);
    if (isCorruption(rc))
      throw CorruptDatabase("solution store " + path_.string() + ": " + sql + ": " + what);
    throw std::runtime_error("solution store " + path_.string() + ": " + sql + ": " + what);
  }
}

sqlite3_stmt* SolutionStore::prepare(const char* sql) {
  sqlite3_stmt* st = nullptr;
  const int rc = sqlite3_prepare_v3(db_, sql, -1, SQLITE_PREPARE_PERSISTENT, &st, nullptr);
  if (isCorruption(rc))
    throw CorruptDatabase("solution store " + path_.string() + ": prepare: " + sqlite3_errmsg(db_));
  if (rc != SQLITE_OK)
    throw std::runtime_error("solution store " + path_.string() +
                             ": prepare: " + sqlite3_errmsg(db_));
  return st;
}

void SolutionStore::open(bool synchronous_full) {
  if (sqlite3_open_v2(path_.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) !=
      SQLITE_OK)
    throw std::runtime_error("solution store " + path_.string() +
                             ": open: " + (db_ ? sqlite3_errmsg(db_) : "out of memory"));
  sqlite3_busy_timeout(db_, 5000);
  exec("PRAGMA journal_mode=WAL");
  exec(synchronous_full ? "PRAGMA synchronous=FULL" : "PRAGMA synchronous=NORMAL");
  exec(
      "CREATE TABLE IF NOT EXISTS solutions ("
      " key BLOB PRIMARY KEY, payload BLOB NOT NULL, checksum INTEGER NOT NULL,"
      " seq INTEGER NOT NULL)");
  exec("CREATE INDEX IF NOT EXISTS solutions_seq ON solutions(seq)");
  // The structure must be sound; rows are checked one by one by their checksums.
  {
    sqlite3_stmt* st = prepare("PRAGMA quick_check");
    const int rc = sqlite3_step(st);
    const std::string result =
        rc == SQLITE_ROW ? reinterpret_cast<const char*>(sqlite3_column_text(st, 0)) : "";
    sqlite3_finalize(st);
    if (isCorruption(rc) || (rc == SQLITE_ROW && result != "ok"))
      throw CorruptDatabase("solution store " + path_.string() + ": quick_check: " + result);
    if (rc != SQLITE_ROW)
      throw std::runtime_error("solution store " + path_.string() +
                               ": quick_check failed: " + sqlite3_errmsg(db_));
  }
  {
    sqlite3_stmt* st = prepare("SELECT COALESCE(MAX(seq), 0) + 1, COUNT(*) FROM solutions");
    const int rc = sqlite3_step(st);
    if (isCorruption(rc)) {
      sqlite3_finalize(st);
      throw CorruptDatabase("solution store " + path_.string() + ": " + sqlite3_errmsg(db_));
    }
    if (rc == SQLITE_ROW) {
      next_seq_ = sqlite3_column_int64(st, 0);
      rows_ = sqlite3_column_int64(st, 1);
    }
    sqlite3_finalize(st);
  }
  put_ = prepare(
      "INSERT INTO solutions (key, payload, checksum, seq) VALUES (?1, ?2, ?3, ?4) "
      "ON CONFLICT(key) DO UPDATE SET payload = excluded.payload, "
      "checksum = excluded.checksum, seq = excluded.seq");
  get_ = prepare("SELECT payload, checksum FROM solutions WHERE key = ?1");
  delete_ = prepare("DELETE FROM solutions WHERE key = ?1");
}

void SolutionStore::put(const CacheKey& key, const CachedSolution& solution) {
  const std::string k = key.bytes();
  const std::string payload = encodeSolution(solution);
  const std::uint32_t crc = rowChecksum(k, payload);
  std::lock_guard lock(mu_);
  bool existed = false;
  {
    StatementScope scope(get_);
    sqlite3_bind_blob(get_, 1, k.data(), static_cast<int>(k.size()), SQLITE_STATIC);
    existed = sqlite3_step(get_) == SQLITE_ROW;
  }
  StatementScope scope(put_);
  sqlite3_bind_blob(put_, 1, k.data(), static_cast<int>(k.size()), SQLITE_STATIC);
  sqlite3_bind_blob(put_, 2, payload.data(), static_cast<int>(payload.size()), SQLITE_STATIC);
  sqlite3_bind_int64(put_, 3, static_cast<sqlite3_int64>(crc));
  sqlite3_bind_int64(put_, 4, next_seq_);
  if (sqlite3_step(put_) != SQLITE_DONE) {
    {
      std::lock_guard c(counters_mu_);
      ++counters_.write_errors;
    }
    throw std::runtime_error("solution store " + path_.string() + ": put: " + sqlite3_errmsg(db_));
  }
  ++next_seq_;
  {
    std::lock_guard c(counters_mu_);
    ++counters_.writes;
  }
  if (!existed) ++rows_;
  if (rows_ > max_rows_) pruneLocked();
}

void SolutionStore::putMany(const std::vector<std::pair<CacheKey, CachedSolution>>& rows) {
  std::lock_guard lock(mu_);
  exec("BEGIN IMMEDIATE");
  try {
    for (const auto& [key, solution] : rows) {
      const std::string k = key.bytes();
      const std::string payload = encodeSolution(solution);
      StatementScope scope(put_);
      sqlite3_bind_blob(put_, 1, k.data(), static_cast<int>(k.size()), SQLITE_STATIC);
      sqlite3_bind_blob(put_, 2, payload.data(), static_cast<int>(payload.size()), SQLITE_STATIC);
      sqlite3_bind_int64(put_, 3, static_cast<sqlite3_int64>(rowChecksum(k, payload)));
      sqlite3_bind_int64(put_, 4, next_seq_);
      if (sqlite3_step(put_) != SQLITE_DONE)
        throw std::runtime_error("solution store " + path_.string() +
                                 ": put: " + sqlite3_errmsg(db_));
      ++next_seq_;
    }
    exec("COMMIT");
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    std::lock_guard c(counters_mu_);
    ++counters_.write_errors;
    throw;
  }
  {
    std::lock_guard c(counters_mu_);
    counters_.writes += static_cast<std::int64_t>(rows.size());
  }
  // Recount: the batch may have replaced existing rows.
  sqlite3_stmt* st = prepare("SELECT COUNT(*) FROM solutions");
  if (sqlite3_step(st) == SQLITE_ROW) rows_ = sqlite3_column_int64(st, 0);
  sqlite3_finalize(st);
  if (rows_ > max_rows_) pruneLocked();
}

void SolutionStore::pruneLocked() {
  // Keep the newest max_rows_ rows (seq is the write order).
  sqlite3_stmt* st = prepare(
      "DELETE FROM solutions WHERE seq < (SELECT MIN(seq) FROM "
      "(SELECT seq FROM solutions ORDER BY seq DESC LIMIT ?1))");
  sqlite3_bind_int64(st, 1, max_rows_);
  if (sqlite3_step(st) == SQLITE_DONE) {
    const auto n = sqlite3_changes(db_);
    {
      std::lock_guard c(counters_mu_);
      counters_.pruned_rows += n;
    }
    rows_ -= n;
  }
  sqlite3_finalize(st);
}

void SolutionStore::deleteRow(const std::string& key_bytes) {
  StatementScope scope(delete_);
  sqlite3_bind_blob(delete_, 1, key_bytes.data(), static_cast<int>(key_bytes.size()),
                    SQLITE_STATIC);
  if (sqlite3_step(delete_) == SQLITE_DONE && sqlite3_changes(db_) > 0) --rows_;
}

std::optional<CachedSolution> SolutionStore::get(const CacheKey& key) {
  const std::string k = key.bytes();
  std::lock_guard lock(mu_);
  std::string payload;
  std::int64_t checksum = 0;
  {
    StatementScope scope(get_);
    sqlite3_bind_blob(get_, 1, k.data(), static_cast<int>(k.size()), SQLITE_STATIC);
    const int rc = sqlite3_step(get_);
    if (rc != SQLITE_ROW) return std::nullopt;
    payload = columnBlob(get_, 0);
    checksum = sqlite3_column_int64(get_, 1);
  }
  auto s = validRow(k, payload, checksum);
  if (!s) {
    {
      std::lock_guard c(counters_mu_);
      ++counters_.corrupt_rows;
    }
    deleteRow(k);
  }
  return s;
}

void SolutionStore::forEachNewest(
    std::int64_t limit, const std::function<void(const CacheKey&, const CachedSolution&)>& visit) {
  std::lock_guard lock(mu_);
  std::vector<std::string> bad;
  sqlite3_stmt* st =
      prepare("SELECT key, payload, checksum FROM solutions ORDER BY seq DESC LIMIT ?1");
  sqlite3_bind_int64(st, 1, limit);
  int rc = SQLITE_OK;
  while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
    const std::string k = columnBlob(st, 0);
    const auto s = validRow(k, columnBlob(st, 1), sqlite3_column_int64(st, 2));
    const auto key = CacheKey::fromBytes(k);
    if (!s || !key) {
      bad.push_back(k);
      continue;
    }
    {
      std::lock_guard c(counters_mu_);
      ++counters_.rows_loaded;
    }
    visit(*key, *s);
  }
  sqlite3_finalize(st);
  if (rc != SQLITE_DONE)
    throw std::runtime_error("solution store " + path_.string() + ": load: " + sqlite3_errmsg(db_));
  for (const auto& k : bad) {
    {
      std::lock_guard c(counters_mu_);
      ++counters_.corrupt_rows;
    }
    deleteRow(k);
  }
}

std::int64_t SolutionStore::count() {
  std::lock_guard lock(mu_);
  return rows_;
}

void SolutionStore::checkpoint() {
  std::lock_guard lock(mu_);
  exec("PRAGMA wal_checkpoint(TRUNCATE)");
}

std::string SolutionStore::describe() const {
  return "sqlite " + path_.string();
}

StoreCounters SolutionStore::counters() const {
  std::lock_guard lock(counters_mu_);
  return counters_;
}

}  // namespace wj::server
