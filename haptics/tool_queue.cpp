#include "haptics/tool_queue.hpp"

namespace scalpel {

ToolQueue::ToolQueue(std::size_t capacity) : queue_(capacity), capacity_(capacity) {}

bool ToolQueue::push(const ToolSample& s) {
  if (queue_.try_enqueue(s)) return true;
  rejected_.fetch_add(1, std::memory_order_relaxed);
  return false;
}

bool ToolQueue::pop(ToolSample& out) {
  return queue_.try_dequeue(out);
}

}  // namespace scalpel
