#include "haptics/recorder.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

namespace scalpel {

namespace {

std::uint64_t drain(ToolQueue& q, const SampleSink& write) {
  std::uint64_t n = 0;
  ToolSample s;
  while (q.pop(s)) {
    write(s);
    ++n;
  }
  return n;
}

}  // namespace

RecordingResult record_session(Device& device, ForceChannel& forces, const RecordingOptions& options,
                               const SampleSink& write, const FlushSink& flush,
                               const std::atomic<bool>& stop) {
  ToolQueue queue(options.queue_capacity);
  HapticLoop loop(device, queue, forces, options.loop);
  RecordingResult r;
  const double rate = options.loop.rate;

  if (options.virtual_clock) {
    const auto total = options.duration > 0.0
                           ? static_cast<std::uint64_t>(std::llround(options.duration * rate))
                           : UINT64_MAX;
    const auto per_flush =
        std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(options.flush_interval * rate)));
    std::uint64_t cycles = 0, since_flush = 0;
    while (cycles < total && !stop.load(std::memory_order_acquire)) {
      const std::uint64_t chunk =
          std::min<std::uint64_t>({total - cycles, per_flush - since_flush, queue.capacity()});
      const std::uint64_t not_ok_before = loop.stats().device_not_ok;
      const std::size_t ran = loop.run_cycles(static_cast<std::size_t>(chunk));
      cycles += ran;
      since_flush += ran;
      r.samples += drain(queue, write);
      if (since_flush >= per_flush) {
        flush();
        ++r.flushes;
        since_flush = 0;
      }
      // A replay that ended (or a device that stopped giving poses) ends an open-ended session.
      if (options.duration <= 0.0 && ran > 0 && loop.stats().device_not_ok - not_ok_before == ran) break;
    }
  } else {
    loop.start();
    r.warning = loop.warning();
    const auto t0 = std::chrono::steady_clock::now();
    const auto drain_period = std::chrono::duration<double>(options.drain_interval);
    auto next_flush = t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                               std::chrono::duration<double>(options.flush_interval));
    auto next_drain = t0;
    try {
      while (!stop.load(std::memory_order_acquire)) {
        const auto now = std::chrono::steady_clock::now();
        if (options.duration > 0.0 && std::chrono::duration<double>(now - t0).count() >= options.duration)
          break;
        r.samples += drain(queue, write);
        if (now >= next_flush) {
          flush();
          ++r.flushes;
          next_flush += std::chrono::duration_cast<std::chrono::steady_clock::duration>(
              std::chrono::duration<double>(options.flush_interval));
        }
        next_drain += std::chrono::duration_cast<std::chrono::steady_clock::duration>(drain_period);
        std::this_thread::sleep_until(next_drain);
      }
    } catch (...) {
      loop.stop();
      throw;
    }
    loop.stop();
    r.samples += drain(queue, write);
  }
  flush();
  ++r.flushes;
  r.loop = loop.stats();
  r.device = device.counters();
  return r;
}

}  // namespace scalpel
