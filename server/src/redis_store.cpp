#include "server/redis_store.h"

#include <hiredis/hiredis.h>
#include <spdlog/spdlog.h>
#include <sys/time.h>

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace wj::server {

namespace {

timeval toTimeval(int ms) {
  timeval tv{};
  tv.tv_sec = ms / 1000;
  tv.tv_usec = (ms % 1000) * 1000;
  return tv;
}

std::string_view replyString(const redisReply* r) {
  return {r->str, r->len};
}

bool isStatus(const redisReply* r, std::string_view text) {
  return r && r->type == REDIS_REPLY_STATUS && replyString(r) == text;
}

std::optional<std::string> unhex(std::string_view hex) {
  if (hex.size() % 2 != 0) return std::nullopt;
  std::string out;
  out.reserve(hex.size() / 2);
  const auto nibble = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
  };
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    const int hi = nibble(hex[i]), lo = nibble(hex[i + 1]);
    if (hi < 0 || lo < 0) return std::nullopt;
    out.push_back(static_cast<char>(hi * 16 + lo));
  }
  return out;
}

}  // namespace

void RedisStore::ContextDeleter::operator()(redisContext* c) const {
  redisFree(c);
}
void RedisStore::ReplyDeleter::operator()(redisReply* r) const {
  freeReplyObject(r);
}

std::string redisKeyOf(std::string_view prefix, const CacheKey& key) {
  return std::string(prefix) + ":plan:v" + std::to_string(kRedisSchemaVersion) + ":" + key.hex();
}

std::string encodeRedisValue(const CacheKey& key, const CachedSolution& solution) {
  const std::string payload = encodeSolution(solution);
  const std::uint32_t crc = rowChecksum(key.bytes(), payload);
  std::string value;
  value.reserve(4 + payload.size());
  for (int i = 0; i < 4; ++i) value.push_back(static_cast<char>((crc >> (8 * i)) & 0xffu));
  return value + payload;
}

std::optional<CachedSolution> decodeRedisValue(const CacheKey& key, std::string_view value) {
  if (value.size() <= 4) return std::nullopt;
  std::uint32_t crc = 0;
  for (int i = 0; i < 4; ++i)
    crc |=
        static_cast<std::uint32_t>(static_cast<unsigned char>(value[static_cast<std::size_t>(i)]))
        << (8 * i);
  const std::string_view payload = value.substr(4);
  if (rowChecksum(key.bytes(), payload) != crc) return std::nullopt;
  return decodeSolution(payload);
}

//==============================================================================================
RedisStore::RedisStore(RedisConfig config)
    : config_(std::move(config)),
      pattern_(config_.key_prefix + ":plan:v" + std::to_string(kRedisSchemaVersion) + ":*") {
  std::lock_guard lock(mu_);
  std::string why;
  if (!ensureConnectedLocked(why))
    spdlog::warn(
        "redis store {}: not reachable at start ({}); answering from the local cache "
        "and reconnecting with backoff",
        describe(), why);
}

RedisStore::~RedisStore() = default;

std::string RedisStore::describe() const {
  return "redis " + config_.host + ":" + std::to_string(config_.port) + " db " +
         std::to_string(config_.db) + " keys " + pattern_;
}

void RedisStore::setAvailable(bool available) {
  std::lock_guard c(counters_mu_);
  counters_.available = available;
}

void RedisStore::dropLocked(const std::string& why) {
  if (ctx_) spdlog::warn("redis store: connection lost ({}); using the local cache", why);
  ctx_.reset();
  lost_ = true;
  backoff_ = backoff_.count() == 0
                 ? std::chrono::milliseconds(config_.reconnect_min_ms)
                 : std::min(backoff_ * 2, std::chrono::milliseconds(config_.reconnect_max_ms));
  next_attempt_ = Clock::now() + backoff_;
  setAvailable(false);
}

bool RedisStore::ensureConnectedLocked(std::string& why) {
  if (ctx_) return true;
  if (Clock::now() < next_attempt_) {
    why = "unavailable, next reconnection in " +
          std::to_string(
              std::chrono::duration_cast<std::chrono::milliseconds>(next_attempt_ - Clock::now())
                  .count()) +
          " ms";
    return false;
  }
  redisContext* raw = redisConnectWithTimeout(config_.host.c_str(), config_.port,
                                              toTimeval(config_.connect_timeout_ms));
  std::unique_ptr<redisContext, ContextDeleter> c(raw);
  if (!c || c->err) {
    why = c ? std::string("connect: ") + c->errstr : "connect: out of memory";
    dropLocked(why);
    return false;
  }
  if (redisSetTimeout(c.get(), toTimeval(config_.command_timeout_ms)) != REDIS_OK) {
    why = "cannot set the command timeout";
    dropLocked(why);
    return false;
  }
  ctx_ = std::move(c);
  if (config_.db != 0) {
    const std::string db = std::to_string(config_.db);
    Reply r = commandLocked({"SELECT", db}, why);
    if (!r) return false;
    if (!isStatus(r.get(), "OK")) {
      why = "SELECT " + db + " refused: " + std::string(replyString(r.get()));
      ctx_.reset();
      dropLocked(why);
      return false;
    }
  }
  backoff_ = std::chrono::milliseconds(0);
  if (lost_) {
    std::lock_guard cl(counters_mu_);
    ++counters_.reconnects;
    spdlog::info("redis store: reconnected to {}", describe());
  }
  lost_ = false;
  setAvailable(true);
  return true;
}

RedisStore::Reply RedisStore::commandLocked(const std::vector<std::string_view>& args,
                                            std::string& why) {
  auto replies = pipelineLocked({args}, why);
  if (replies.empty()) return nullptr;
  return std::move(replies.front());
}

std::vector<RedisStore::Reply> RedisStore::pipelineLocked(
    const std::vector<std::vector<std::string_view>>& commands, std::string& why) {
  std::vector<Reply> out;
  if (!ctx_) {
    why = "not connected";
    return out;
  }
  std::vector<const char*> argv;
  std::vector<std::size_t> lens;
  for (const auto& args : commands) {
    argv.clear();
    lens.clear();
    for (const auto& a : args) {
      argv.push_back(a.data());
      lens.push_back(a.size());
    }
    if (redisAppendCommandArgv(ctx_.get(), static_cast<int>(argv.size()), argv.data(),
                               lens.data()) != REDIS_OK) {
      why = ctx_->errstr;
      dropLocked(why);
      return {};
    }
  }
  for (std::size_t i = 0; i < commands.size(); ++i) {
    void* raw = nullptr;
    if (redisGetReply(ctx_.get(), &raw) != REDIS_OK || !raw) {
      // I/O error or timeout: the connection's state is unknown, so it is dropped.
      why = ctx_->err ? std::string(ctx_->errstr) : std::string("no reply");
      if (raw) freeReplyObject(raw);
      dropLocked(why);
      return {};
    }
    out.emplace_back(static_cast<redisReply*>(raw));
  }
  return out;
}

//==============================================================================================
std::optional<CachedSolution> RedisStore::get(const CacheKey& key) {
  const std::string rkey = redisKeyOf(config_.key_prefix, key);
  std::string why;
  Reply r;
  {
    std::lock_guard lock(mu_);
    // A connection that was good may have gone stale (Redis restarted): one fresh attempt.
    for (int attempt = 0; attempt < 2 && !r; ++attempt) {
      const bool had_connection = ctx_ != nullptr;
      if (!ensureConnectedLocked(why)) break;
      r = commandLocked({"GET", rkey}, why);
      if (!had_connection) break;
      if (!r) next_attempt_ = Clock::now();
    }
  }
  if (!r || r->type == REDIS_REPLY_ERROR) {
    std::lock_guard c(counters_mu_);
    ++counters_.read_errors;
    spdlog::debug("redis get {} failed ({}): a miss", rkey,
                  r ? std::string(replyString(r.get())) : why);
    return std::nullopt;
  }
  if (r->type == REDIS_REPLY_NIL) return std::nullopt;
  std::optional<CachedSolution> s;
  if (r->type == REDIS_REPLY_STRING) s = decodeRedisValue(key, replyString(r.get()));
  if (!s) {
    std::lock_guard c(counters_mu_);
    ++counters_.corrupt_rows;
    spdlog::warn("redis store: refused the corrupt value of {} (replaced by the next put)", rkey);
  }
  return s;
}

bool RedisStore::tryPutLocked(const std::string& rkey, const CacheKey& key,
                              const CachedSolution& solution, const std::string& value,
                              std::string& why, bool& failed) {
  failed = true;
  auto watched = pipelineLocked({{"WATCH", rkey}, {"GET", rkey}}, why);
  if (watched.empty()) return true;
  if (!isStatus(watched[0].get(), "OK")) {
    why = "WATCH refused";
    return true;
  }
  const redisReply* current = watched[1].get();
  if (current->type == REDIS_REPLY_STRING) {
    // A corrupt stored value is overwritten below (it was counted when a get refused it).
    const auto stored = decodeRedisValue(key, replyString(current));
    if (stored && !isBetterSolution(solution, *stored)) {
      (void)commandLocked({"UNWATCH"}, why);
      failed = false;
      std::lock_guard c(counters_mu_);
      ++counters_.writes_skipped;
      return true;
    }
  } else if (current->type != REDIS_REPLY_NIL) {
    why = current->type == REDIS_REPLY_ERROR ? std::string(replyString(current))
                                             : std::string("unexpected GET reply");
    (void)commandLocked({"UNWATCH"}, why);
    return true;
  }
  const std::string ttl = std::to_string(config_.ttl_s);
  std::vector<std::string_view> set = {"SET", rkey, value};
  if (config_.ttl_s > 0) {
    set.emplace_back("EX");
    set.emplace_back(ttl);
  }
  auto tx = pipelineLocked({{"MULTI"}, set, {"EXEC"}}, why);
  if (tx.empty()) return true;
  const redisReply* exec = tx[2].get();
  if (exec->type == REDIS_REPLY_NIL) return false;  // the key changed since WATCH: retry
  if (exec->type != REDIS_REPLY_ARRAY || exec->elements != 1 || !isStatus(exec->element[0], "OK")) {
    why = exec->type == REDIS_REPLY_ERROR ? std::string(replyString(exec))
                                          : std::string("the transaction was refused");
    return true;
  }
  failed = false;
  std::lock_guard c(counters_mu_);
  ++counters_.writes;
  return true;
}

void RedisStore::put(const CacheKey& key, const CachedSolution& solution) {
  const std::string rkey = redisKeyOf(config_.key_prefix, key);
  const std::string value = encodeRedisValue(key, solution);
  std::string why;
  bool failed = true;
  {
    std::lock_guard lock(mu_);
    bool done = false;
    for (int attempt = 0; attempt < 4 && !done; ++attempt) {
      const bool had_connection = ctx_ != nullptr;
      if (!ensureConnectedLocked(why)) break;
      done = tryPutLocked(rkey, key, solution, value, why, failed);
      // A stale connection (Redis restarted) gets one fresh attempt; a lost race a retry.
      if (done && failed && had_connection && !ctx_ && attempt == 0) {
        next_attempt_ = Clock::now();
        done = false;
      }
    }
    if (!done) why = why.empty() ? "the key kept changing under the transaction" : why;
  }
  if (failed) {
    {
      std::lock_guard c(counters_mu_);
      ++counters_.write_errors;
    }
    throw std::runtime_error("redis put " + rkey + " failed: " + why);
  }
}

void RedisStore::forEachNewest(
    std::int64_t limit, const std::function<void(const CacheKey&, const CachedSolution&)>& visit) {
  limit = std::min(limit, config_.preload_entries);
  if (limit <= 0) return;
  std::vector<std::pair<CacheKey, CachedSolution>> found;
  std::string why;
  {
    std::lock_guard lock(mu_);
    if (!ensureConnectedLocked(why)) return;
    const std::size_t prefix_len = pattern_.size() - 1;
    std::string cursor = "0";
    do {
      Reply scan = commandLocked({"SCAN", cursor, "MATCH", pattern_, "COUNT", "512"}, why);
      if (!scan || scan->type != REDIS_REPLY_ARRAY || scan->elements != 2) break;
      cursor = std::string(replyString(scan->element[0]));
      const redisReply* keys = scan->element[1];
      if (keys->elements == 0) continue;
      std::vector<std::string_view> mget = {"MGET"};
      std::vector<CacheKey> parsed;
      for (std::size_t i = 0; i < keys->elements; ++i) {
        const std::string_view k = replyString(keys->element[i]);
        const auto bytes = k.size() > prefix_len ? unhex(k.substr(prefix_len)) : std::nullopt;
        const auto key = bytes ? CacheKey::fromBytes(*bytes) : std::nullopt;
        if (!key) continue;
        mget.push_back(k);
        parsed.push_back(*key);
      }
      if (parsed.empty()) continue;
      Reply values = commandLocked(mget, why);
      if (!values || values->type != REDIS_REPLY_ARRAY || values->elements != parsed.size()) break;
      for (std::size_t i = 0; i < parsed.size(); ++i) {
        const redisReply* v = values->element[i];
        if (v->type != REDIS_REPLY_STRING) continue;  // expired since the SCAN
        auto s = decodeRedisValue(parsed[i], replyString(v));
        if (!s) {
          std::lock_guard c(counters_mu_);
          ++counters_.corrupt_rows;
          continue;
        }
        found.emplace_back(parsed[i], *s);
      }
    } while (cursor != "0" && static_cast<std::int64_t>(found.size()) < 4 * limit);
  }
  if (!why.empty()) spdlog::warn("redis store: preload stopped early ({})", why);
  std::stable_sort(found.begin(), found.end(), [](const auto& a, const auto& b) {
    return a.second.created_unix_ms > b.second.created_unix_ms;
  });
  if (static_cast<std::int64_t>(found.size()) > limit)
    found.resize(static_cast<std::size_t>(limit));
  {
    std::lock_guard c(counters_mu_);
    counters_.rows_loaded += static_cast<std::int64_t>(found.size());
  }
  for (const auto& [k, s] : found) visit(k, s);
}

StoreCounters RedisStore::counters() const {
  std::lock_guard c(counters_mu_);
  return counters_;
}

}  // namespace wj::server
