#pragma once
/// @file The hot tier of cache hits (opt-in, `cache.hot_responses_mb`): the serialized PlanJump
/// responses of cache bins, so that a hit after the first of its bin does no JumpModel
/// construction, no evaluation, no buildPlan, no conversion and no serialization: it is answered
/// on the reactor thread with the ready bytes (shared, not copied) followed by a few bytes of its
/// own (readySuffix: request_id and stats.total_ms, which protobuf's parser merges into the
/// message, as it does for any concatenation of two serialized messages). Bounded in bytes
/// (least recently used out first). Each response is stamped with the generation of the cache
/// entry it was built from (SolutionCache::find) and served only while the cache holds that very
/// entry, so it is invalidated with the cache. Lives in the RPC layer: it holds gRPC slices.
///
/// What it costs (docs/service.md, "Hot tier"): the response is the one regenerated for the
/// bin's first hit, so its trajectory starts up to half a bin away from a later caller's state
/// and its feasibility was checked at that first caller's state, not at the later one's.

#include <grpcpp/support/slice.h>

#include <cstddef>
#include <cstdint>
#include <list>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>

#include "wheeljump/planner/v1/jump_planner.pb.h"

namespace wj::server {

/// The serialized form of `response` without its per-call fields (request_id, stats.total_ms):
/// what the hot tier keeps. `response` is changed (those two fields are cleared).
std::string readyBytes(wheeljump::planner::v1::PlanJumpResponse& response);
/// The serialized per-call fields of a hot answer: parsed after readyBytes(r) (concatenated),
/// they give r with this request_id and stats.total_ms (and ready_response set).
grpc::Slice readySuffix(std::string_view request_id, double total_ms);

class HotResponses {
 public:
  /// At most `max_bytes` of responses (their serialized size); 0 disables the tier.
  explicit HotResponses(std::size_t max_bytes) : max_bytes_(max_bytes) {}
  HotResponses(const HotResponses&) = delete;
  HotResponses& operator=(const HotResponses&) = delete;

  bool enabled() const { return max_bytes_ > 0; }
  /// The ready bytes of `key` if they were built from the cache entry of generation
  /// `generation`; none otherwise (bytes built from another entry are dropped). The slice shares
  /// the stored bytes (reference counted).
  std::optional<grpc::Slice> find(const std::string& key, std::uint64_t generation);
  /// Keeps `bytes` (readyBytes) for `key`, built from the entry of generation `generation`
  /// (replaces older ones); evicts the least recently used beyond the bound. Bytes larger than
  /// the bound are not kept.
  void put(const std::string& key, std::uint64_t generation, std::string_view bytes);

  std::size_t entries() const;
  std::size_t bytes() const;

 private:
  struct Entry {
    std::string key;
    std::uint64_t generation = 0;
    grpc::Slice bytes;
    std::size_t size = 0;
  };
  void eraseLocked(std::list<Entry>::iterator it);

  const std::size_t max_bytes_;
  mutable std::mutex mu_;
  std::list<Entry> lru_;  ///< front: most recently used
  std::unordered_map<std::string, std::list<Entry>::iterator> index_;
  std::size_t bytes_ = 0;
};

}  // namespace wj::server
