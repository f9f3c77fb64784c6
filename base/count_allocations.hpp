// Counts the heap allocations of an executable: include this header in exactly one of its source
// files, and every replaceable operator new (plain, array, nothrow and aligned) adds one to
// heap_allocations(). For the benchmarks and tests of code that must not allocate. The memory comes
// from malloc and goes back to free: AddressSanitizer still sees every allocation and leak, but not
// a new freed by the wrong delete in such an executable.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <new>

namespace scalpel {

namespace count_allocations_detail {
inline std::atomic<std::size_t> allocations{0};

inline void* allocate(std::size_t size, std::size_t alignment) noexcept {
  allocations.fetch_add(1, std::memory_order_relaxed);
  if (size == 0) size = 1;
  if (alignment <= alignof(std::max_align_t)) return std::malloc(size);
  if (size > static_cast<std::size_t>(-1) - alignment) return nullptr;
  return std::aligned_alloc(alignment, (size + alignment - 1) / alignment * alignment);  // a multiple
}

inline void* allocate_or_throw(std::size_t size, std::size_t alignment) {
  if (void* p = allocate(size, alignment)) return p;
  throw std::bad_alloc();
}
}  // namespace count_allocations_detail

// Heap allocations by operator new in this process so far.
inline std::size_t heap_allocations() {
  return count_allocations_detail::allocations.load(std::memory_order_relaxed);
}

}  // namespace scalpel

void* operator new(std::size_t size) {
  return scalpel::count_allocations_detail::allocate_or_throw(size, 0);
}
void* operator new[](std::size_t size) {
  return scalpel::count_allocations_detail::allocate_or_throw(size, 0);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  return scalpel::count_allocations_detail::allocate(size, 0);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  return scalpel::count_allocations_detail::allocate(size, 0);
}
void* operator new(std::size_t size, std::align_val_t alignment) {
  return scalpel::count_allocations_detail::allocate_or_throw(size, static_cast<std::size_t>(alignment));
}
void* operator new[](std::size_t size, std::align_val_t alignment) {
  return scalpel::count_allocations_detail::allocate_or_throw(size, static_cast<std::size_t>(alignment));
}
void* operator new(std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  return scalpel::count_allocations_detail::allocate(size, static_cast<std::size_t>(alignment));
}
void* operator new[](std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  return scalpel::count_allocations_detail::allocate(size, static_cast<std::size_t>(alignment));
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
void operator delete(void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  std::free(p);
}
