#include "sim/session.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>

#include "sim/piece_events.hpp"
#include "sim/quantile.hpp"
#include "sim/simulation.hpp"

namespace scalpel {

namespace {

using Clock = std::chrono::steady_clock;

// The file of attempt n (from 1): the given path, then <stem>.2<ext>, <stem>.3<ext>, ...
std::filesystem::path attempt_path(const std::filesystem::path& path, std::size_t n) {
  if (n <= 1) return path;
  std::filesystem::path p = path;
  p.replace_filename(path.stem().string() + "." + std::to_string(n) + path.extension().string());
  return p;
}

constexpr std::size_t kFrameWindow = 256;  // frames of the overlay's p99
// A tool that moved less than this while paused resumes as it is, without a clutch.
constexpr double kClutchDistance = 1e-6;  // [m]
constexpr double kClutchAngle = 1e-6;     // [rad]

}  // namespace

Session::Session(Scenario scenario, Device& device, PlaybackDevice* playback, SessionOptions options)
    : scenario_(std::move(scenario)),
      device_(device),
      playback_(playback),
      options_(std::move(options)),
      queue_(static_cast<std::size_t>(scenario_.device.queue_capacity)) {
  HapticLoopConfig config;
  config.rate = scenario_.device.rate;
  config.period_log = static_cast<std::size_t>(config.rate * 600);  // ten minutes
  loop_ = std::make_unique<HapticLoop>(device_, queue_, forces_, config);
  edges_.store(options_.wireframe_edges);
  begin_attempt();
  publish_frame(0.0);  // the uncut tissue, before the first frame
}

Session::~Session() {
  stop();
}

void Session::start() {
  if (started_) return;
  loop_->start();
  try {
    sim_thread_ = std::thread([this] { sim_main(); });
  } catch (...) {
    loop_->stop();
    throw;
  }
  started_ = true;
}

void Session::stop() {
  stop_.store(true, std::memory_order_release);
  if (sim_thread_.joinable()) sim_thread_.join();
  loop_->stop();
  try {
    finish_recording();  // the simulation thread has finished it, unless it never started
  } catch (const std::exception& e) {
    if (!failed_.load()) {
      error_ = e.what();
      failed_.store(true, std::memory_order_release);
    }
  }
}

void Session::set_paused(bool paused) {
  paused_.store(paused, std::memory_order_relaxed);
  if (playback_) playback_->set_paused(paused);
}

std::string Session::error() const {
  return failed_.load(std::memory_order_acquire) ? error_ : std::string();
}

std::vector<std::filesystem::path> Session::recordings() const {
  return recordings_;
}

void Session::begin_attempt() {
  sim_ = std::make_unique<Simulation>(scenario_);
  finish_recording();
  attempt_frames_ = 0;
  attempt_seconds_.clear();
}

void Session::record(const ToolSample& s, std::uint64_t frame) {
  if (options_.record.empty()) return;
  open_recording();
  writer_->write(s, frame);
}

void Session::record_piece(const PieceMove& move, std::uint64_t frame) {
  if (options_.record.empty()) return;
  open_recording();
  writer_->write_trailer(kPieceEventKey, format_piece_event({frame, move}));
}

void Session::open_recording() {
  if (!writer_) {
    // Opened at the attempt's first sample (or move of a piece): an attempt without either leaves no
    // file.
    const std::filesystem::path path = attempt_path(options_.record, recordings_.size() + 1);
    char rate[32];
    std::snprintf(rate, sizeof rate, "%g Hz", scenario_.device.rate);
    // verbatim: replayed sample by sample, in the frames that took them (docs/formats.md).
    writer_ = std::make_unique<PoseLogWriter>(path.string(),
                                              PoseLogMetadata{{"device", options_.device_name},
                                                              {"scenario", scenario_.name},
                                                              {"rate", rate},
                                                              {"playback", "verbatim"}},
                                              true, true);
    recordings_.push_back(path);
  }
}

void Session::finish_recording() {
  if (!writer_) return;
  // The frames the attempt ran, also those after its last sample: a replay runs them all.
  writer_->write_trailer("frames", std::to_string(attempt_frames_));
  writer_->flush();
  writer_.reset();
}

void Session::publish_frame(double frame_seconds) {
  SessionFrame& f = frames_.back();
  sim_->snapshot(f.snapshot, edges_.load(std::memory_order_relaxed));
  f.snapshot.frame = attempt_frames_;
  SessionStatus& s = f.status;
  s.time = sim_->time();
  s.frame_seconds = frame_seconds;
  const auto n = static_cast<std::ptrdiff_t>(std::min(attempt_seconds_.size(), kFrameWindow));
  s.frame_seconds_p99 = quantile({attempt_seconds_.end() - n, attempt_seconds_.end()}, 0.99);
  const HapticStats hs = loop_->stats();
  s.haptic_rate = hs.period_mean > 0 ? 1.0 / hs.period_mean : 0.0;
  s.haptic_jitter = hs.period_error_rms;
  s.haptic_error_max = hs.period_error_max;
  s.device_ok = hs.device_not_ok == last_not_ok_;  // no cycle without a pose since the last frame
  s.device_not_ok = last_not_ok_ = hs.device_not_ok;
  s.hand_force = sim_->samples() > 0 ? sim_->last_sample().force.norm() : 0.0;
  s.paused = paused();
  // Ended for the trainee when the simulation has also taken every pose the device sent.
  s.playback_ended =
      playback_ && playback_->position() >= playback_->duration() && hs.samples_pushed == popped_;
  const std::optional<TaskScore> score = sim_->task_score();
  s.has_task = score.has_value();
  if (score) s.task = *score;
  s.tip = sim_->scorer().last();
  s.recorded = writer_ ? writer_->samples_written() : 0;
  s.pieces_taken = pieces_taken_;
  const auto& moves = sim_->moves();
  s.piece_refusal = moves.empty() ? std::string() : moves.back().refused;
  frames_.publish();
  if (on_publish_) on_publish_();
}

void Session::drop_queued() {
  for (ToolSample drop; queue_.pop(drop);) ++popped_;
}

void Session::sim_main() noexcept {
  try {
    run_frames();
  } catch (const std::exception& e) {
    error_ = e.what();
    failed_.store(true, std::memory_order_release);
  } catch (...) {
    error_ = "the simulation stopped on an unknown error";
    failed_.store(true, std::memory_order_release);
  }
  try {
    finish_recording();
  } catch (const std::exception& e) {
    if (!failed_.load()) {
      error_ = e.what();
      failed_.store(true, std::memory_order_release);
    }
  }
}

void Session::run_frames() {
  const double visual_rate = scenario_.simulation.visual_rate;
  const double period = 1.0 / scenario_.device.rate;
  const auto frame_duration =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / visual_rate));

  std::uint64_t k = 0;    // frames of this attempt
  double origin = 0.0;    // loop time of session time 0
  double last_t = 0.0;    // session time of the last sample taken
  bool anchored = false;  // origin set: from the first sample, and again after a pause
  // The clutch: device poses are taken to the simulation by x -> R x + t. A pause re-engages it
  // so the tool resumes where it stood, wherever the hand has gone meanwhile (a hand-held device
  // keeps moving; the mouse and a playback hold still, and then it stays as it was).
  Eigen::Quaterniond clutch_r = Eigen::Quaterniond::Identity();
  Vec3 clutch_t = Vec3::Zero();
  bool clutched = false;  // R, t are not the identity
  bool has_last = false;  // a sample of this attempt was taken: the clutch has a pose to resume at
  ToolSample last;
  std::size_t since_flush = 0;
  auto deadline = Clock::now() + frame_duration;

  while (!stop_.load(std::memory_order_acquire)) {
    const std::uint64_t resets = reset_requests_.load(std::memory_order_acquire);
    if (resets != resets_done_) {
      if (playback_) {
        // Wait (briefly) until the device plays from the start, then drop what it sent before.
        const std::uint64_t request = playback_->restart();
        const auto until = Clock::now() + std::chrono::milliseconds(200);
        while (playback_->restarts() < request && Clock::now() < until)
          std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
      drop_queued();
      for (PieceMove drop; piece_requests_.pop(drop);) ++pieces_taken_;  // moves of the attempt before
      resets_done_ = resets;
      begin_attempt();
      k = 0;
      last_t = 0.0;
      anchored = false;
      has_last = clutched = false;
      clutch_r = Eigen::Quaterniond::Identity();
      clutch_t = Vec3::Zero();
      publish_frame(0.0);
      deadline = Clock::now() + frame_duration;
      continue;
    }
    if (paused()) {
      // Nothing moves; what the device sends meanwhile is not part of the attempt.
      drop_queued();
      anchored = false;
      publish_frame(0.0);
      std::this_thread::sleep_for(frame_duration);
      deadline = Clock::now() + frame_duration;
      continue;
    }

    std::this_thread::sleep_until(deadline);
    const auto start = Clock::now();
    ++k;
    // The frame takes every sample the loop had sent when it started: the blade is where the hand
    // is, even when frames take longer than 1 / visual_rate. The tissue steps once a frame, so it
    // then runs slower than real time instead of taking steps it cannot afford.
    const std::uint64_t sent = loop_->stats().samples_pushed;
    ToolSample s;
    while (popped_ < sent && queue_.pop(s)) {
      ++popped_;
      if (!anchored) {
        // Session time goes on from the last sample, one haptic period later, and the tool from
        // its last pose.
        origin = s.t - (last_t + period);
        anchored = true;
        const Vec3 p = clutch_r * s.position + clutch_t;
        const Eigen::Quaterniond q = clutch_r * s.orientation;
        if (has_last && ((p - last.position).norm() > kClutchDistance ||
                         q.angularDistance(last.orientation) > kClutchAngle)) {
          const Eigen::Quaterniond turn = (last.orientation * q.inverse()).normalized();
          clutch_r = (turn * clutch_r).normalized();
          clutch_t = turn * (clutch_t - p) + last.position;
          clutched = true;
        }
      }
      if (clutched) {
        s.position = clutch_r * s.position + clutch_t;
        s.orientation = (clutch_r * s.orientation).normalized();
      }
      s.t -= origin;
      last_t = s.t;
      record(s, k);
      sim_->on_sample(s);
      last = s;
      has_last = true;
    }
    // The trainee's moves of pieces, applied at the end of this frame and recorded with it.
    for (PieceMove m; piece_requests_.pop(m);) {
      ++pieces_taken_;
      sim_->queue_move(m);
      record_piece(m, k);
    }
    sim_->end_frame(static_cast<double>(k) / visual_rate, forces_);
    attempt_frames_ = k;
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();  // cuts and tissue
    frame_seconds_.push_back(seconds);
    attempt_seconds_.push_back(seconds);
    publish_frame(seconds);
    if (writer_ && ++since_flush * frame_duration >= std::chrono::milliseconds(100)) {
      writer_->flush();  // a killed session keeps all but the last 0.1 s
      since_flush = 0;
    }
    deadline += frame_duration;
    const auto now = Clock::now();
    if (now > deadline) deadline = now;  // behind: the next frame starts at once, none is skipped
  }
}

}  // namespace scalpel
