// The haptic servo loop (docs/threads.md). Each cycle: read the device, render the force from the
// newest force model the simulation published, send it, and push the tool sample (with that force)
// to the SPSC queue for the simulation. The cycle never blocks, allocates or throws.
//
// Two clocks run the same cycle:
// - real: start() runs a thread paced by absolute deadlines (clock_nanosleep, TIMER_ABSTIME, on
//   CLOCK_MONOTONIC) at real-time priority (SCHED_FIFO) where the system allows it; warning() says
//   when it does not. Period and jitter are measured.
// - virtual: run_cycles(n) runs n cycles in the calling thread at t_k = k / rate exactly, without
//   sleeping: a headless replay steps rate / visual_rate cycles, then one simulation frame, and so
//   on in one thread, which makes it bit-deterministic.
//
// A full queue (the simulation fell behind):
// - virtual clock: no sample is ever dropped or merged. run_cycles stops early, holding the sample
//   that did not fit, and returns the cycles run; the caller drains the queue and calls again.
// - real clock: the loop cannot wait. The sample that did not fit is held; while the queue stays full
//   every newer sample replaces it (merged_samples counts them), and the held sample is pushed as soon
//   as there is room. The simulation then sweeps the blade in one straight step from the last sample
//   it had to the held one: the path between them is covered as one longer sweep (its curvature is
//   lost, never a piece of the path), and merged_sweeps counts such sweeps; the sample times show the
//   gap.
//
// Thread ownership: the device's read/write_force and the queue's producer side belong to the haptic
// thread (the thread of start(), or the caller of run_cycles); the device's maintain() to the
// maintenance thread start() also runs. stats() may be read from any thread.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "devices/device.hpp"
#include "haptics/force_model.hpp"
#include "haptics/tool_queue.hpp"

namespace scalpel {

struct HapticLoopConfig {
  double rate = 1000.0;            // [Hz]
  double max_force = 0.0;          // [N] 0: the device's limit
  double max_force_rate = 0.0;     // [N/s] 0: the device's limit
  double stall_timeout = 0.1;      // [s] without a new force model before the force goes to zero
  bool realtime_priority = true;   // ask for SCHED_FIFO
  int priority = 80;               // SCHED_FIFO priority
  std::size_t period_log = 0;      // measured periods kept for percentiles (real clock; 0: none)
  double maintain_interval = 0.1;  // [s] between calls of the device's maintain()
};

struct HapticStats {
  std::uint64_t cycles = 0;
  std::uint64_t samples_pushed = 0;
  std::uint64_t merged_samples = 0;  // samples replaced by a newer one while the queue was full
  std::uint64_t merged_sweeps = 0;   // pushed samples standing for more than one cycle
  std::uint64_t device_not_ok = 0;   // cycles without a current pose (unplugged, fault, ended)
  std::uint64_t stalls = 0;          // times the simulation stalled (force went to zero)
  std::uint64_t overruns = 0;        // cycles that started a whole period late (deadline reset)
  double period_mean = 0.0;          // [s] measured (real clock)
  double period_error_rms = 0.0;     // [s] jitter: RMS of (period - 1/rate)
  double period_error_max = 0.0;     // [s] largest |period - 1/rate|
};

class HapticLoop {
 public:
  // The loop keeps references to device, queue and forces: they must outlive it.
  HapticLoop(Device& device, ToolQueue& queue, ForceChannel& forces, HapticLoopConfig config = {});
  ~HapticLoop();
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  enum class OnFullQueue : std::uint8_t {
    Stop,   // stop early, hold the sample that did not fit (no sample is ever dropped or merged)
    Merge,  // as the real clock does (for tests of the merge policy)
  };
  // Virtual clock. Runs up to n cycles; returns how many ran (fewer when the queue is full and
  // on_full is Stop).
  std::size_t run_cycles(std::size_t n, OnFullQueue on_full = OnFullQueue::Stop);
  // Virtual time of the next cycle [s].
  [[nodiscard]] double virtual_time() const { return static_cast<double>(cycle_) / config_.rate; }

  // Real clock. start() throws std::logic_error when already running or after run_cycles, and
  // std::system_error when a thread cannot be created.
  void start();
  void stop();
  [[nodiscard]] bool running() const { return running_.load(std::memory_order_acquire); }
  // Empty, or why the loop runs without real-time priority (set by start()).
  [[nodiscard]] const std::string& warning() const { return warning_; }

  [[nodiscard]] HapticStats stats() const;
  // Measured periods [s] of the last run (at most config.period_log); call when not running.
  [[nodiscard]] std::vector<double> periods() const;
  [[nodiscard]] const HapticLoopConfig& config() const { return config_; }

 private:
  enum class Push : std::uint8_t { Done, Held };
  Push cycle(double t, bool merge_when_full) noexcept;
  void thread_main() noexcept;
  void maintain_main();

  Device& device_;
  ToolQueue& queue_;
  ForceChannel& forces_;
  const HapticLoopConfig config_;

  // Haptic thread only.
  ForceRenderer renderer_;
  ForceModel model_;
  bool has_model_ = false;
  double model_seen_t_ = 0.0;  // [s] loop time the newest model arrived
  bool stalled_ = false;
  ToolSample held_;  // the sample that did not fit in the queue
  bool has_held_ = false;
  std::uint64_t held_span_ = 0;  // cycles the held sample stands for
  std::uint64_t cycle_ = 0;      // virtual clock: cycles run
  bool used_virtual_ = false;
  std::vector<double> period_log_;  // pre-sized; haptic thread writes while running
  std::size_t period_count_ = 0;

  // Written by the haptic thread, read anywhere.
  struct Counters {
    std::atomic<std::uint64_t> cycles{0}, pushed{0}, merged{0}, merged_sweeps{0}, not_ok{0}, stalls{0},
        overruns{0}, periods{0};
    std::atomic<double> period_sum{0.0}, error_sq_sum{0.0}, error_max{0.0};
  } counters_;

  std::atomic<bool> running_{false};
  std::string warning_;
  std::thread thread_;
  std::thread maintainer_;
  std::mutex maintain_mutex_;
  std::condition_variable maintain_cv_;
};

}  // namespace scalpel
