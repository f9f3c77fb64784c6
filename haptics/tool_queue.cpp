#include "haptics/tool_queue.hpp"

namespace scalpel {

ToolQueue::ToolQueue(std::size_t capacity) : ring_(capacity) {}

bool ToolQueue::push(const ToolSample& s) {
  if (ring_.push(s)) return true;
  rejected_.fetch_add(1, std::memory_order_relaxed);
  return false;
}

bool ToolQueue::pop(ToolSample& out) {
  return ring_.pop(out);
}

}  // namespace scalpel
