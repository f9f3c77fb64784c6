// A bounded single-producer single-consumer ring buffer, sized once: push and pop never block,
// allocate or throw. Synchronisation is one release store and one acquire load per operation on
// the two indices (no standalone fences, so ThreadSanitizer sees every hand-over).
#pragma once

#include <atomic>
#include <cstddef>
#include <new>
#include <vector>

namespace scalpel {

template <class T>
class SpscRing {
 public:
  // Holds exactly `capacity` elements (one more slot tells full from empty).
  explicit SpscRing(std::size_t capacity) : slots_(capacity + 1) {}

  // Producer thread only. False when full.
  bool push(const T& value) noexcept {
    const std::size_t t = tail_.load(std::memory_order_relaxed);
    const std::size_t next = t + 1 == slots_.size() ? 0 : t + 1;
    if (next == head_.load(std::memory_order_acquire)) return false;
    slots_[t] = value;
    tail_.store(next, std::memory_order_release);
    return true;
  }

  // Consumer thread only. False when empty.
  bool pop(T& out) noexcept {
    const std::size_t h = head_.load(std::memory_order_relaxed);
    if (h == tail_.load(std::memory_order_acquire)) return false;
    out = slots_[h];
    head_.store(h + 1 == slots_.size() ? 0 : h + 1, std::memory_order_release);
    return true;
  }
  // Consumer thread only: the oldest element, or null when empty; release it with pop().
  [[nodiscard]] const T* front() const noexcept {
    const std::size_t h = head_.load(std::memory_order_relaxed);
    return h == tail_.load(std::memory_order_acquire) ? nullptr : &slots_[h];
  }

  [[nodiscard]] std::size_t capacity() const { return slots_.size() - 1; }
  // Exact from either end's own thread when the other is idle; a snapshot otherwise.
  [[nodiscard]] std::size_t size_approx() const {
    const std::size_t h = head_.load(std::memory_order_acquire), t = tail_.load(std::memory_order_acquire);
    return t >= h ? t - h : t + slots_.size() - h;
  }

 private:
  static constexpr std::size_t kLine = 64;  // [bytes] keeps the two indices on separate cache lines
  std::vector<T> slots_;
  alignas(kLine) std::atomic<std::size_t> head_{0};  // next to pop; written by the consumer
  alignas(kLine) std::atomic<std::size_t> tail_{0};  // next to push; written by the producer
};

}  // namespace scalpel
