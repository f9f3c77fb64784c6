// A live session (docs/threads.md): the haptic loop on the real clock in its own thread, the
// simulation in a second thread at the visual rate draining the same queue, and after every
// simulation frame a snapshot of the tissue and the session's figures published for a renderer
// through a triple buffer. None of the three threads waits on another.
//
// Frame k takes every sample the loop has sent by its start, and ends at tissue time
// k / visual_rate: the blade follows the hand at once, and when frames take longer than the visual
// period the tissue runs slower than real time rather than skipping steps. The recording notes the
// frame of every sample, so it replays headless to the same mesh, bit for bit (`scalpelsim replay`
// plays a log with `playback: verbatim` sample by sample, by those frames).
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "base/spsc_ring.hpp"
#include "base/triple_buffer.hpp"
#include "devices/device.hpp"
#include "devices/playback_device.hpp"
#include "devices/pose_log.hpp"
#include "haptics/force_model.hpp"
#include "haptics/haptic_loop.hpp"
#include "haptics/tool_queue.hpp"
#include "sim/scenario.hpp"
#include "sim/snapshot.hpp"
#include "sim/task_score.hpp"

namespace scalpel {

class Simulation;

// The figures of a session after one simulation frame, for the trainee's overlay.
struct SessionStatus {
  double time = 0.0;                // [s] tissue time at the end of the frame
  double frame_seconds = 0.0;       // [s] the simulation's compute time for the frame: cuts and tissue
  double frame_seconds_p99 = 0.0;   // [s] over the last 256 frames
  double haptic_rate = 0.0;         // [Hz] measured since the session started
  double haptic_jitter = 0.0;       // [s] RMS of (period - 1 / rate)
  double haptic_error_max = 0.0;    // [s] largest |period - 1 / rate|
  double hand_force = 0.0;          // [N] the force rendered on the hand at the frame's last sample
  bool device_ok = true;            // the device gave a pose at the frame's last cycle
  std::uint64_t device_not_ok = 0;  // cycles without a pose since the start
  bool paused = false;
  bool playback_ended = false;  // a played-back log has run out
  bool has_task = false;
  TaskScore task;
  ToolTracePoint tip;        // the tip at the frame's last sample: in the tissue, its depth
  std::size_t recorded = 0;  // samples written to the recording of this attempt
  // Moves of pieces asked for by request_piece() that the simulation has taken (or dropped at a
  // reset), since the start; the last move's refusal (sim/simulation.hpp), empty when done. While
  // paused, they wait.
  std::uint64_t pieces_taken = 0;
  std::string piece_refusal;
};

struct SessionFrame {
  FrameSnapshot snapshot;
  SessionStatus status;
};

struct SessionOptions {
  std::filesystem::path record;  // pose log to write; empty: none. Each attempt (a reset starts
                                 // one) gets its own file, opened at its first sample.
  std::string device_name = "device";
  bool wireframe_edges = false;  // fill the snapshot's edges from the start
};

class Session {
 public:
  // The session keeps `device`; `playback` is it when it plays back a log (for pause and restart).
  // Builds the simulation (the scenario's mesh and tissue); throws as Simulation does.
  Session(Scenario scenario, Device& device, PlaybackDevice* playback, SessionOptions options);
  ~Session();  // stop()
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // Starts the haptic and simulation threads. Throws std::system_error when they cannot start.
  void start();
  // Stops both threads and flushes the recording; idempotent. Never throws.
  void stop();

  // Render thread: takes the newest frame; true when it is newer than the last one taken.
  bool update() { return frames_.update(); }
  [[nodiscard]] const SessionFrame& frame() const { return frames_.read(); }

  [[nodiscard]] double visual_rate() const { return scenario_.simulation.visual_rate; }  // [Hz]
  // Called on the simulation thread after each published frame (a renderer's wake-up); set it
  // before start() or after stop().
  void set_on_publish(std::function<void()> f) { on_publish_ = std::move(f); }

  // Any thread.
  void request_reset() { reset_requests_.fetch_add(1, std::memory_order_release); }
  void set_paused(bool paused);
  [[nodiscard]] bool paused() const { return paused_.load(std::memory_order_relaxed); }
  void set_wireframe_edges(bool on) { edges_.store(on, std::memory_order_relaxed); }
  // One thread only (the renderer's): a move, undo or deletion of a piece of rigid tissue
  // (Simulation::queue_move), applied at the end of the next frame and recorded with it
  // (sim/piece_events.hpp). False when too many wait already.
  bool request_piece(const PieceMove& move) { return piece_requests_.push(move); }
  // Empty while the simulation runs; why it stopped when it failed (a bad step, a full disk).
  [[nodiscard]] std::string error() const;
  [[nodiscard]] bool failed() const { return failed_.load(std::memory_order_acquire); }
  [[nodiscard]] const std::string& haptic_warning() const { return loop_->warning(); }
  // The recordings written, one per attempt (valid after stop()).
  [[nodiscard]] std::vector<std::filesystem::path> recordings() const;
  // Measured haptic periods [s] (valid after stop()).
  [[nodiscard]] std::vector<double> haptic_periods() const { return loop_->periods(); }
  // The simulation of the current attempt (read it after stop()).
  [[nodiscard]] const Simulation& simulation() const { return *sim_; }
  // The simulation's compute time per frame [s] (the frame's cut steps and tissue step), every
  // frame of every attempt (valid after stop()).
  [[nodiscard]] const std::vector<double>& frame_seconds() const { return frame_seconds_; }

 private:
  void sim_main() noexcept;
  void run_frames();
  void begin_attempt();
  void publish_frame(double frame_seconds);
  void record(const ToolSample& s, std::uint64_t frame);
  void record_piece(const PieceMove& move, std::uint64_t frame);
  void open_recording();
  void finish_recording();
  void drop_queued();  // samples the attempt does not take (paused, or from before a reset)

  Scenario scenario_;
  Device& device_;
  PlaybackDevice* playback_;
  SessionOptions options_;
  ToolQueue queue_;
  ForceChannel forces_;
  std::unique_ptr<HapticLoop> loop_;
  std::unique_ptr<Simulation> sim_;
  TripleBuffer<SessionFrame> frames_;
  SpscRing<PieceMove> piece_requests_{16};  // renderer -> simulation

  std::atomic<std::uint64_t> reset_requests_{0};
  std::atomic<bool> paused_{false}, edges_{false}, stop_{false}, failed_{false};
  std::thread sim_thread_;
  bool started_ = false;

  // Simulation thread only (and after stop()).
  std::uint64_t resets_done_ = 0;
  std::unique_ptr<PoseLogWriter> writer_;
  std::vector<std::filesystem::path> recordings_;
  std::vector<double> frame_seconds_;
  std::vector<double> attempt_seconds_;  // this attempt's, for the overlay
  std::uint64_t attempt_frames_ = 0;
  std::string error_;  // guarded by failed_: written before it is set
  std::uint64_t last_not_ok_ = 0;
  std::uint64_t popped_ = 0;  // samples taken from the queue
  std::uint64_t pieces_taken_ = 0;
  std::function<void()> on_publish_;
};

}  // namespace scalpel
