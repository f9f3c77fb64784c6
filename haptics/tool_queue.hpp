// The lock-free single-producer single-consumer queue of tool samples between the haptic thread
// (producer) and the simulation thread (consumer), docs/threads.md.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

#include "base/spsc_ring.hpp"
#include "devices/tool_sample.hpp"

namespace scalpel {

class ToolQueue {
 public:
  // Holds exactly `capacity` samples, sized once; push never allocates.
  explicit ToolQueue(std::size_t capacity);

  // Producer thread only. Returns false, and counts the sample, when the queue is full.
  bool push(const ToolSample& s);
  // Consumer thread only.
  bool pop(ToolSample& out);

  [[nodiscard]] std::size_t capacity() const { return ring_.capacity(); }
  [[nodiscard]] std::size_t size_approx() const { return ring_.size_approx(); }
  [[nodiscard]] std::uint64_t rejected() const { return rejected_.load(std::memory_order_relaxed); }

 private:
  SpscRing<ToolSample> ring_;
  std::atomic<std::uint64_t> rejected_{0};  // written by the producer, read by anyone
};

}  // namespace scalpel
