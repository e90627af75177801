#include "server/hot_responses.h"

namespace wj::server {

std::shared_ptr<const HotResponses::Response> HotResponses::find(const std::string& key,
                                                                 const std::string& stamp) {
  std::lock_guard lock(mu_);
  const auto it = index_.find(key);
  if (it == index_.end()) return nullptr;
  if (it->second->stamp != stamp) {
    eraseLocked(it->second);  // built from an entry the cache no longer holds
    return nullptr;
  }
  lru_.splice(lru_.begin(), lru_, it->second);
  return it->second->response;
}

void HotResponses::put(const std::string& key, std::string stamp,
                       std::shared_ptr<const Response> response) {
  if (!enabled() || !response) return;
  const std::size_t size = response->ByteSizeLong() + key.size() + stamp.size();
  if (size > max_bytes_) return;
  std::lock_guard lock(mu_);
  if (const auto it = index_.find(key); it != index_.end()) eraseLocked(it->second);
  lru_.push_front(Entry{key, std::move(stamp), std::move(response), size});
  index_.emplace(key, lru_.begin());
  bytes_ += size;
  while (bytes_ > max_bytes_) eraseLocked(std::prev(lru_.end()));
}

void HotResponses::eraseLocked(std::list<Entry>::iterator it) {
  bytes_ -= it->bytes;
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
