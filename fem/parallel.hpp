// Deterministic parallel loops for the tissue solver (docs/tissue.md).
//
// Work is split into chunks of a fixed size, independent of the thread count, and per-chunk partial
// sums are added in chunk order: reductions are bit-identical for any number of threads, and for
// any assignment of chunks to threads.
//
// A Team runs the chunks of a loop on the calling thread and its workers. Each thread claims the
// chunks of its own contiguous segment one at a time (the same rows every loop, as with a static
// schedule: they stay in its core's cache), then those left in the others'. A thread the scheduler
// has taken away (another busy process, the haptic thread) delays a loop by at most the chunk it
// holds: the others take the rest of its segment.
//
// Waiting threads spin for at most kSpin, then sleep on a futex (std::atomic::wait). A step's loops
// follow one another within microseconds, so workers stay awake through a step and sleep between
// steps, and a waiting thread never holds a core that a descheduled one needs for longer than
// kSpin. (OpenMP's default policy spins for about 300 thousand polls: with one more busy process
// on two cores, a tissue step's 95th percentile was 0.16-0.21 s; config/scenarios/README.md.)
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <thread>
#include <type_traits>
#include <vector>

namespace scalpel::parallel {

inline constexpr std::size_t kChunk = 256;
inline constexpr std::chrono::microseconds kSpin{100};

inline std::size_t chunk_count(std::size_t n) {
  return (n + kChunk - 1) / kChunk;
}

class Team {
 public:
  // threads >= 1: the caller and threads - 1 workers, started here.
  explicit Team(int threads);
  ~Team();
  Team(const Team&) = delete;
  Team& operator=(const Team&) = delete;

  [[nodiscard]] int size() const { return static_cast<int>(workers_.size()) + 1; }

  // Calls f(c) once for every c in [0, chunks), on the caller and the workers, and returns when all
  // calls have returned. An exception from f is rethrown here once all calls are done (the first
  // one, if several threw). Does not allocate. Not reentrant: f must not run jobs on this team.
  template <class F>
  void run(std::size_t chunks, F&& f) {
    if (workers_.empty() || chunks <= 1) {
      std::exception_ptr error;
      for (std::size_t c = 0; c < chunks; ++c) {
        try {
          f(c);
        } catch (...) {
          if (!error) error = std::current_exception();
        }
      }
      if (error) std::rethrow_exception(error);
      return;
    }
    using Fn = std::remove_reference_t<F>;
    dispatch(
        chunks, [](void* context, std::size_t c) { (*static_cast<Fn*>(context))(c); },
        const_cast<void*>(static_cast<const void*>(&f)));
  }

  // Runs background() on one worker while the caller runs foreground(), whose loops may run on
  // this team: the worker joins them once background() has returned. Returns when both have; an
  // exception from either is rethrown here (foreground's first). background() must not run jobs
  // on this team, and neither side may call run_beside() on it. Does not allocate. With no
  // worker: background(), then foreground().
  template <class B, class F>
  void run_beside(B&& background, F&& foreground) {
    using Fn = std::remove_reference_t<B>;
    std::exception_ptr background_error;
    if (workers_.empty()) {
      try {
        background();
      } catch (...) {
        background_error = std::current_exception();
      }
    } else {
      post_background([](void* context, std::size_t) { (*static_cast<Fn*>(context))(); },
                      const_cast<void*>(static_cast<const void*>(&background)));
    }
    std::exception_ptr error;
    try {
      foreground();
    } catch (...) {
      error = std::current_exception();
    }
    if (!workers_.empty()) background_error = join_background();
    if (error || background_error) std::rethrow_exception(error ? error : background_error);
  }

 private:
  using Call = void (*)(void*, std::size_t);
  void dispatch(std::size_t chunks, Call call, void* context);
  void work(int self);
  void post_background(Call call, void* context);
  // Waits for the background call to return; its exception, if it threw.
  std::exception_ptr join_background();
  // Thread `self` runs chunks of the job of `generation`: its own segment first, then what is left
  // of the others, until none is left or a newer job is posted.
  void claim(int self, std::uint32_t generation, Call call, void* context, std::uint32_t chunks);

  // Thread s owns the chunks [s n / size, (s + 1) n / size) of a job of n chunks; next holds the
  // job's generation (high half) and the segment's next unclaimed chunk (low half). Each on its
  // own cache line, where only its owner claims unless it has fallen behind.
  struct alignas(64) Segment {
    std::atomic<std::uint64_t> next{0};
  };
  std::vector<Segment> segments_;
  alignas(64) std::atomic<std::uint32_t> done_{0};  // chunks of the current job that have returned
  std::atomic<bool> caller_sleeping_{false};
  // Written by the caller when it posts a job: the job of generation g in jobs_[g % 2], which stays
  // as it is until job g + 1 is done (so until every claim on job g has been made).
  struct Job {
    std::atomic<Call> call{nullptr};
    std::atomic<void*> context{nullptr};
    std::atomic<std::uint32_t> chunks{0};
  };
  alignas(64) std::atomic<std::uint32_t> generation_{0};  // published last; sleeping workers wait on it
  std::array<Job, 2> jobs_;
  std::atomic<int> sleeping_workers_{0};
  std::atomic<bool> failed_{false};
  std::exception_ptr error_;
  std::atomic<bool> stop_{false};
  // run_beside(): the call a worker takes (set until taken), and whether it has returned.
  std::atomic<Call> background_{nullptr};
  std::atomic<void*> background_context_{nullptr};
  alignas(64) std::atomic<bool> background_done_{true};
  std::exception_ptr background_error_;
  std::vector<std::thread> workers_;
};

// f(chunk, begin, end) over [0, n) in chunks of kChunk, on the team.
template <class F>
void for_chunks(Team& team, std::size_t n, F&& f) {
  team.run(chunk_count(n), [&](std::size_t c) {
    const std::size_t begin = c * kChunk;
    f(c, begin, std::min(n, begin + kChunk));
  });
}

// Sum of the first n partials, in order.
inline double sum(const std::vector<double>& partial, std::size_t n) {
  double s = 0;
  for (std::size_t c = 0; c < n; ++c) s += partial[c];
  return s;
}

// Sum of row(i) over [0, n): per chunk in index order into partial[chunk] (sized for chunk_count(n)),
// then the chunks in order. row may also update row i's data.
template <class Row>
double reduce(Team& team, std::size_t n, std::vector<double>& partial, Row&& row) {
  for_chunks(team, n, [&](std::size_t c, std::size_t begin, std::size_t end) {
    double s = 0;
    for (std::size_t i = begin; i < end; ++i) s += row(i);
    partial[c] = s;
  });
  return sum(partial, chunk_count(n));
}

}  // namespace scalpel::parallel
