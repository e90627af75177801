#include "server/hot_responses.h"

namespace wj::server {

namespace v1 = wheeljump::planner::v1;

std::string readyBytes(v1::PlanJumpResponse& response) {
  response.clear_request_id();
  if (response.has_stats()) response.mutable_stats()->clear_total_ms();
  return response.SerializeAsString();
}

std::string readySuffix(const std::string& request_id, double total_ms) {
  // Fields at their default are not written (proto3), and the ready bytes hold them at their
  // default: the parsed result is the same either way.
  v1::PlanJumpResponse own;
  own.set_request_id(request_id);
  own.mutable_stats()->set_total_ms(total_ms);
  own.set_ready_response(true);
  return own.SerializeAsString();
}

std::optional<grpc::Slice> HotResponses::find(const std::string& key, std::uint64_t generation) {
  std::lock_guard lock(mu_);
  const auto it = index_.find(key);
  if (it == index_.end()) return std::nullopt;
  if (it->second->generation != generation) {
    eraseLocked(it->second);  // built from an entry the cache no longer holds
    return std::nullopt;
  }
  lru_.splice(lru_.begin(), lru_, it->second);
  return it->second->bytes;
}

void HotResponses::put(const std::string& key, std::uint64_t generation, std::string_view bytes) {
  const std::size_t size = bytes.size() + key.size();
  if (!enabled() || size > max_bytes_) return;
  grpc::Slice slice(bytes.data(), bytes.size());
  std::lock_guard lock(mu_);
  if (const auto it = index_.find(key); it != index_.end()) eraseLocked(it->second);
  lru_.push_front(Entry{key, generation, std::move(slice), size});
  index_.emplace(key, lru_.begin());
  bytes_ += size;
  while (bytes_ > max_bytes_) eraseLocked(std::prev(lru_.end()));
}

void HotResponses::eraseLocked(std::list<Entry>::iterator it) {
  bytes_ -= it->size;
  index_.erase(it->key);
  lru_.erase(it);
}

std::size_t HotResponses::entries() const {
  std::lock_guard lock(mu_);
  return lru_.size();
}

std::size_t HotResponses::bytes() const {
  std::lock_guard lock(mu_);
  return bytes_;
}

}  // namespace wj::server
