#include "server/hot_responses.h"

#include <google/protobuf/arena.h>

#include "server/stack_arena.h"

namespace wj::server {

namespace v1 = wheeljump::planner::v1;

std::string readyBytes(v1::PlanJumpResponse& response) {
  response.clear_request_id();
  if (response.has_stats()) response.mutable_stats()->clear_total_ms();
  return response.SerializeAsString();
}

grpc::Slice readySuffix(std::string_view request_id, double total_ms) {
  // Fields at their default are not written (proto3), and the ready bytes hold them at their
  // default: the parsed result is the same either way. Built on an arena whose block is on this
  // stack and serialized straight into the slice: one allocation per hot hit (the slice's).
  StackArena<1024> arena;
  auto* own = google::protobuf::Arena::CreateMessage<v1::PlanJumpResponse>(arena.get());
  own->set_request_id(request_id.data(), request_id.size());
  own->mutable_stats()->set_total_ms(total_ms);
  own->set_ready_response(true);
  grpc::Slice slice(own->ByteSizeLong());
  own->SerializeWithCachedSizesToArray(const_cast<std::uint8_t*>(slice.begin()));
  return slice;
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
