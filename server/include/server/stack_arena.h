#pragma once
// A protobuf arena whose first block lives inside this object (on the caller's stack): messages
// of ordinary size built or parsed on it cost no heap allocation.
#include <google/protobuf/arena.h>

#include <cstddef>

namespace wj::server {

template <std::size_t Bytes>
class StackArena {
 public:
  StackArena() : arena_(options(block_)) {}
  StackArena(const StackArena&) = delete;
  StackArena& operator=(const StackArena&) = delete;

  google::protobuf::Arena* get() { return &arena_; }

 private:
  static google::protobuf::ArenaOptions options(char* block) {
    google::protobuf::ArenaOptions o;
    o.initial_block = block;
    o.initial_block_size = Bytes;
    return o;
  }

  alignas(std::max_align_t) char block_[Bytes];  // before arena_: it is constructed first
  google::protobuf::Arena arena_;
};

}  // namespace wj::server
