// A wait-free triple buffer: one writer publishes whole values, one reader takes the newest.
// Neither side ever blocks, allocates or waits for the other; the reader may see the same value
// twice, never a torn one. The three slots rotate through one atomic index word: the writer owns
// `back`, the reader owns `front`, and `middle` (with a "new" bit) is swapped by both.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>

namespace scalpel {

template <class T>
class TripleBuffer {
 public:
  TripleBuffer() = default;
  explicit TripleBuffer(const T& initial) { slots_.fill(initial); }

  // Writer thread only.
  void publish(const T& value) {
    slots_[back_] = value;
    publish();
  }
  // Writer thread only: the slot the next publish() hands over, to fill in place. It holds an older
  // value (any of the last three published), so a large value reuses its storage.
  T& back() { return slots_[back_]; }
  void publish() {
    // Hand the written slot over as the middle one, marked new; take the old middle as back.
    const std::uint8_t old =
        middle_.exchange(static_cast<std::uint8_t>(back_ | kNew), std::memory_order_acq_rel);
    back_ = old & kIndex;
  }

  // Reader thread only. Returns true when a value newer than the last one read was taken.
  bool update() {
    if (!(middle_.load(std::memory_order_relaxed) & kNew)) return false;
    const std::uint8_t old = middle_.exchange(front_, std::memory_order_acq_rel);
    front_ = old & kIndex;
    return true;
  }
  // Reader thread only: the newest value taken by update().
  [[nodiscard]] const T& read() const { return slots_[front_]; }

 private:
  static constexpr std::uint8_t kIndex = 3, kNew = 4;
  std::array<T, 3> slots_{};
  std::uint8_t back_ = 0;                // writer thread
  std::atomic<std::uint8_t> middle_{1};  // shared
  std::uint8_t front_ = 2;               // reader thread
};

}  // namespace scalpel
