#include "haptics/haptic_loop.hpp"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace scalpel {

namespace {

constexpr auto kRelaxed = std::memory_order_relaxed;

ForceLimits limits_for(const Device& d, const HapticLoopConfig& c) {
  return {c.max_force > 0.0 ? c.max_force : d.max_force(),
          c.max_force_rate > 0.0 ? c.max_force_rate : d.max_force_rate()};
}

std::int64_t to_ns(const timespec& ts) {
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

timespec from_ns(std::int64_t ns) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(ns % 1'000'000'000);
  return ts;
}

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return to_ns(ts);
}

}  // namespace

HapticLoop::HapticLoop(Device& device, ToolQueue& queue, ForceChannel& forces, HapticLoopConfig config)
    : device_(device),
      queue_(queue),
      forces_(forces),
      config_(config),
      renderer_(limits_for(device, config), config.rate) {
  if (!(config_.rate > 0.0) || !std::isfinite(config_.rate))
    throw std::invalid_argument("HapticLoop: rate must be positive");
  period_log_.resize(config_.period_log);
}

HapticLoop::~HapticLoop() {
  stop();
}

HapticLoop::Push HapticLoop::cycle(double t, bool merge_when_full) noexcept {
  ToolSample s;
  const DeviceStatus status = device_.read(t, s);
  if (status != DeviceStatus::Ok) {
    counters_.not_ok.fetch_add(1, kRelaxed);
    renderer_.reset_motion();
  }

  if (forces_.update()) {
    const ForceModel& m = forces_.read();
    if (!has_model_ || m.sequence != model_.sequence) {
      model_ = m;
      has_model_ = true;
      model_seen_t_ = t;
    }
  }
  const bool stalled = has_model_ && t - model_seen_t_ > config_.stall_timeout;
  if (stalled && !stalled_) counters_.stalls.fetch_add(1, kRelaxed);
  stalled_ = stalled;

  const Eigen::Vector3d f =
      renderer_.render(s.position, has_model_ ? &model_ : nullptr, status == DeviceStatus::Ok && !stalled);
  device_.write_force(f);
  s.force = f;
  counters_.cycles.fetch_add(1, kRelaxed);
  if (status != DeviceStatus::Ok) return Push::Done;  // a frozen tool adds no sweep

  // The held sample goes first, so the order of samples is kept.
  if (has_held_ && queue_.push(held_)) {
    has_held_ = false;
    counters_.pushed.fetch_add(1, kRelaxed);
    if (held_span_ > 1) counters_.merged_sweeps.fetch_add(1, kRelaxed);
  }
  if (!has_held_) {
    if (queue_.push(s)) {
      counters_.pushed.fetch_add(1, kRelaxed);
      return Push::Done;
    }
    held_ = s;
    has_held_ = true;
    held_span_ = 1;
    return Push::Held;
  }
  if (!merge_when_full) return Push::Held;  // not reached: run_cycles(Stop) pushes the held sample first
  held_ = s;  // merge: the newest pose stands for the cycles since the last pushed one
  ++held_span_;
  counters_.merged.fetch_add(1, kRelaxed);
  return Push::Held;
}

std::size_t HapticLoop::run_cycles(std::size_t n, OnFullQueue on_full) {
  if (running()) throw std::logic_error("HapticLoop::run_cycles: the real-time thread is running");
  used_virtual_ = true;
  std::size_t done = 0;
  while (done < n) {
    const bool merge = on_full == OnFullQueue::Merge;
    if (has_held_ && !merge) {
      if (!queue_.push(held_)) break;  // still full: the caller drains the queue first
      has_held_ = false;
      counters_.pushed.fetch_add(1, kRelaxed);
    }
    const double t = static_cast<double>(cycle_) / config_.rate;
    ++cycle_;
    ++done;
    if (cycle(t, merge) == Push::Held && !merge) break;
  }
  return done;
}

void HapticLoop::start() {
  if (running()) throw std::logic_error("HapticLoop::start: already running");
  if (used_virtual_) throw std::logic_error("HapticLoop::start: this loop runs on the virtual clock");
  warning_.clear();
  period_count_ = 0;
  running_.store(true, std::memory_order_release);
  thread_ = std::thread([this] { thread_main(); });
  if (config_.realtime_priority) {
    sched_param sp{};
    sp.sched_priority =
        std::clamp(config_.priority, sched_get_priority_min(SCHED_FIFO), sched_get_priority_max(SCHED_FIFO));
    const int err = pthread_setschedparam(thread_.native_handle(), SCHED_FIFO, &sp);
    if (err != 0)
      warning_ = std::string("haptic loop: no real-time priority (SCHED_FIFO ") +
                 std::to_string(sp.sched_priority) + ": " + std::strerror(err) +
                 "); running at normal priority, the period may jitter under load "
                 "(grant CAP_SYS_NICE or an rtprio limit to fix)";
  }
  try {
    maintainer_ = std::thread([this] { maintain_main(); });
  } catch (...) {
    stop();
    throw;
  }
}

void HapticLoop::stop() {
  {
    std::lock_guard<std::mutex> lock(maintain_mutex_);
    running_.store(false, std::memory_order_release);
  }
  maintain_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (maintainer_.joinable()) maintainer_.join();
}

void HapticLoop::maintain_main() {
  const auto interval = std::chrono::duration<double>(config_.maintain_interval);
  std::unique_lock<std::mutex> lock(maintain_mutex_);
  while (running_.load(std::memory_order_acquire)) {
    lock.unlock();
    device_.maintain();
    lock.lock();
    maintain_cv_.wait_for(lock, interval, [this] { return !running_.load(std::memory_order_acquire); });
  }
}

void HapticLoop::thread_main() noexcept {
  const auto period_ns = static_cast<std::int64_t>(std::llround(1e9 / config_.rate));
  const double nominal = 1.0 / config_.rate;
  const std::int64_t start = now_ns();
  std::int64_t deadline = start;
  std::int64_t last_wake = start;
  bool first = true;
  double sum = 0.0, sq = 0.0, emax = 0.0;
  std::uint64_t count = 0;
  while (running_.load(std::memory_order_acquire)) {
    const std::int64_t wake = now_ns();
    if (!first) {
      const double period = static_cast<double>(wake - last_wake) * 1e-9;
      const double e = period - nominal;
      sum += period;
      sq += e * e;
      emax = std::max(emax, std::abs(e));
      ++count;
      if (period_count_ < period_log_.size()) period_log_[period_count_++] = period;
      counters_.periods.store(count, kRelaxed);
      counters_.period_sum.store(sum, kRelaxed);
      counters_.error_sq_sum.store(sq, kRelaxed);
      counters_.error_max.store(emax, kRelaxed);
    }
    first = false;
    last_wake = wake;
    (void)cycle(static_cast<double>(wake - start) * 1e-9, true);

    deadline += period_ns;
    const std::int64_t after = now_ns();
    if (after - deadline > period_ns) {
      // More than a whole period late: start afresh rather than run a burst of catch-up cycles.
      counters_.overruns.fetch_add(1, kRelaxed);
      deadline = after;
    }
    const timespec ts = from_ns(deadline);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
  }
}

HapticStats HapticLoop::stats() const {
  HapticStats s;
  s.cycles = counters_.cycles.load(kRelaxed);
  s.samples_pushed = counters_.pushed.load(kRelaxed);
  s.merged_samples = counters_.merged.load(kRelaxed);
  s.merged_sweeps = counters_.merged_sweeps.load(kRelaxed);
  s.device_not_ok = counters_.not_ok.load(kRelaxed);
  s.stalls = counters_.stalls.load(kRelaxed);
  s.overruns = counters_.overruns.load(kRelaxed);
  const std::uint64_t n = counters_.periods.load(kRelaxed);
  if (n > 0) {
    s.period_mean = counters_.period_sum.load(kRelaxed) / static_cast<double>(n);
    s.period_error_rms = std::sqrt(counters_.error_sq_sum.load(kRelaxed) / static_cast<double>(n));
    s.period_error_max = counters_.error_max.load(kRelaxed);
  }
  return s;
}

std::vector<double> HapticLoop::periods() const {
  if (running()) return {};
  return {period_log_.begin(), period_log_.begin() + static_cast<std::ptrdiff_t>(period_count_)};
}

}  // namespace scalpel
