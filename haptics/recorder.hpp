// A recording session: the haptic loop runs the device, and the samples it pushes (pose and the
// force rendered at that cycle) go to a sink, for example a pose log writer. The sink runs on the
// recording thread, never on the haptic thread. Crash safety is the sink's flush: the session calls
// flush every flush_interval, so a killed process leaves everything up to the last flush readable.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

#include "devices/device.hpp"
#include "haptics/force_model.hpp"
#include "haptics/haptic_loop.hpp"

namespace scalpel {

struct RecordingOptions {
  HapticLoopConfig loop;
  bool virtual_clock = false;  // true: run on the virtual clock, as fast as the sink takes it
  std::size_t queue_capacity = 4096;
  double duration = 0.0;          // [s] 0: until stop is requested (or a replayed device ends)
  double flush_interval = 0.1;    // [s] of session time between flushes
  double drain_interval = 0.002;  // [s] real clock: the recording thread's polling period
};

struct RecordingResult {
  std::uint64_t samples = 0;  // samples written to the sink
  std::uint64_t flushes = 0;
  HapticStats loop;
  DeviceCounters device;
  std::string warning;  // the loop's warning (no real-time priority), if any
};

using SampleSink = std::function<void(const ToolSample&)>;
using FlushSink = std::function<void()>;

// Runs a session until `duration`, until `stop` becomes true, or (virtual clock) until the device
// stops giving poses. Ends with a final flush. Exceptions of the sinks propagate (after the loop
// stopped).
RecordingResult record_session(Device& device, ForceChannel& forces, const RecordingOptions& options,
                               const SampleSink& write, const FlushSink& flush,
                               const std::atomic<bool>& stop);

}  // namespace scalpel
