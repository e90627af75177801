#pragma once
/// @file The shared second-level store on Redis (cache.backend: redis): several planner_server
/// replicas behind one Redis share their solutions, so that a plan computed by one is a hit on
/// the others. docs/scaling.md.
///
/// Keys are "<key_prefix>:plan:v<kRedisSchemaVersion>:<CacheKey::hex()>"; values are the
/// little-endian CRC-32 of key bytes and payload (rowChecksum, as in the SQLite rows) followed
/// by the payload (encodeSolution). A value that fails its checksum or does not decode is refused
/// and counted, never served. A put keeps the better of the stored and the new solution
/// (isBetterSolution) with an optimistic WATCH/MULTI/EXEC transaction.
///
/// Outage: every command is bounded by command_timeout_ms and every connection attempt by
/// connect_timeout_ms. A failure drops the connection; until the backoff (reconnect_min_ms,
/// doubling up to reconnect_max_ms) has passed, calls fail at once without touching the network:
/// a get answers a miss (counted in read_errors), a put throws (counted in write_errors; the
/// cache keeps the solution in memory). The next call after the backoff reconnects.

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "server/config.h"
#include "server/second_level_store.h"

struct redisContext;
struct redisReply;

namespace wj::server {

/// Version of the key layout and value framing; bumping it orphans every older entry.
inline constexpr int kRedisSchemaVersion = 1;

/// The Redis key of `key` under `prefix`.
std::string redisKeyOf(std::string_view prefix, const CacheKey& key);
/// The value stored for `solution` under `key` (checksum, then payload).
std::string encodeRedisValue(const CacheKey& key, const CachedSolution& solution);
/// The solution of a value read under `key`; nullopt if it is short, fails its checksum or does
/// not decode.
std::optional<CachedSolution> decodeRedisValue(const CacheKey& key, std::string_view value);

/// One Redis connection behind a mutex (commands are serialised; a get is one round trip, a put
/// four). Thread-safe. Never throws from get() or forEachNewest().
class RedisStore final : public SecondLevelStore {
 public:
  /// Connects at once (bounded by connect_timeout_ms); an unreachable Redis is not an error: the
  /// store starts unavailable and reconnects with backoff.
  explicit RedisStore(RedisConfig config);
  ~RedisStore() override;
  RedisStore(const RedisStore&) = delete;
  RedisStore& operator=(const RedisStore&) = delete;

  void put(const CacheKey& key, const CachedSolution& solution) override;
  std::optional<CachedSolution> get(const CacheKey& key) override;
  /// Preloads at most min(limit, preload_entries) entries found by SCAN, newest
  /// (created_unix_ms) first.
  void forEachNewest(
      std::int64_t limit,
      const std::function<void(const CacheKey&, const CachedSolution&)>& visit) override;
  /// Nothing to do: durability is Redis's own (its RDB/AOF configuration).
  void checkpoint() override {}
  StoreCounters counters() const override;
  std::string_view backend() const override { return "redis"; }
  std::string describe() const override;
  const RedisConfig& config() const { return config_; }

 private:
  struct ContextDeleter {
    void operator()(redisContext* c) const;
  };
  struct ReplyDeleter {
    void operator()(redisReply* r) const;
  };
  using Reply = std::unique_ptr<redisReply, ReplyDeleter>;
  using Clock = std::chrono::steady_clock;

  /// A connection, connecting if the backoff allows; false if there is none. Holds mu_.
  bool ensureConnectedLocked(std::string& why);
  /// Sends one command and reads its reply; on an I/O failure drops the connection and returns
  /// null with `why`. Holds mu_.
  Reply commandLocked(const std::vector<std::string_view>& args, std::string& why);
  /// Sends several commands in one write and reads their replies (all or none). Holds mu_.
  std::vector<Reply> pipelineLocked(const std::vector<std::vector<std::string_view>>& commands,
                                    std::string& why);
  void dropLocked(const std::string& why);
  /// One put attempt; true if done (written or skipped), false if the transaction lost a race.
  bool tryPutLocked(const std::string& rkey, const CacheKey& key, const CachedSolution& solution,
                    const std::string& value, std::string& why, bool& failed);
  void setAvailable(bool available);

  RedisConfig config_;
  std::string pattern_;  ///< SCAN pattern of this prefix and schema
  std::mutex mu_;        ///< guards the connection and the backoff
  std::unique_ptr<redisContext, ContextDeleter> ctx_;
  Clock::time_point next_attempt_{};
  std::chrono::milliseconds backoff_{0};
  bool lost_ = false;               ///< a connection failed since the last successful connect
  mutable std::mutex counters_mu_;  ///< never held during I/O
  StoreCounters counters_;
};

}  // namespace wj::server
