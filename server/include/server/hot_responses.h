#pragma once
/// @file The hot tier of cache hits (opt-in, `cache.hot_responses_mb`): ready PlanJump responses
/// of cache bins, so that a hit after the first of its bin does no JumpModel construction, no
/// evaluation, no buildPlan and no conversion, and is answered on the reactor thread with one
/// message copy. Bounded in bytes (least recently used out first). Each response is stamped with
/// the compact cache entry it was built from and served only while the cache still holds that
/// entry, so it is invalidated with the cache. Lives in the RPC layer: it holds protobuf.
///
/// What it costs (docs/service.md, "Hot tier"): the response is the one regenerated for the
/// bin's first hit, so its trajectory starts up to half a bin away from a later caller's state
/// and its feasibility was checked at that first caller's state, not at the later one's.

#include <cstddef>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "wheeljump/planner/v1/jump_planner.pb.h"

namespace wj::server {

class HotResponses {
 public:
  using Response = wheeljump::planner::v1::PlanJumpResponse;

  /// At most `max_bytes` of responses (their ByteSizeLong); 0 disables the tier.
  explicit HotResponses(std::size_t max_bytes) : max_bytes_(max_bytes) {}
  HotResponses(const HotResponses&) = delete;
  HotResponses& operator=(const HotResponses&) = delete;

  bool enabled() const { return max_bytes_ > 0; }
  /// The ready response of `key` if it was built from the entry `stamp`; null otherwise (a
  /// response built from another entry is dropped).
  std::shared_ptr<const Response> find(const std::string& key, const std::string& stamp);
  /// Keeps `response` for `key`, built from the entry `stamp` (replaces an older one); evicts
  /// the least recently used beyond the bound. A response larger than the bound is not kept.
  void put(const std::string& key, std::string stamp, std::shared_ptr<const Response> response);

  std::size_t entries() const;
  std::size_t bytes() const;

 private:
  struct Entry {
    std::string key;
    std::string stamp;
    std::shared_ptr<const Response> response;
    std::size_t bytes = 0;
  };
  void eraseLocked(std::list<Entry>::iterator it);

  const std::size_t max_bytes_;
  mutable std::mutex mu_;
  std::list<Entry> lru_;  ///< front: most recently used
  std::unordered_map<std::string, std::list<Entry>::iterator> index_;
  std::size_t bytes_ = 0;
};

}  // namespace wj::server
