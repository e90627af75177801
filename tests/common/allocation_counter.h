#pragma once
/// @file Counts the heap allocations of a test binary: replaces the global operator new (and
/// its deletes) with ones that count. Include it in exactly one source file of a binary, which
/// then is the binary's only one that may define these operators.

#include <atomic>
#include <cstdlib>
#include <new>

namespace wj::test {

/// Calls of the global operator new (single and array) since the program started.
inline std::atomic<long>& allocationCounter() {
  static std::atomic<long> count{0};
  return count;
}

inline long allocations() {
  return allocationCounter().load(std::memory_order_relaxed);
}

}  // namespace wj::test

void* operator new(std::size_t size) {
  wj::test::allocationCounter().fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  wj::test::allocationCounter().fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}
