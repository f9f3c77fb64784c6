#include "fem/parallel.hpp"

#include <stdexcept>
#include <utility>

namespace scalpel::parallel {

namespace {

void pause() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

// Polls done() for at most kSpin; true if it held.
template <class Done>
bool spin_until(Done done) {
  const auto start = std::chrono::steady_clock::now();
  for (unsigned i = 1;; ++i) {
    if (done()) return true;
    pause();
    if (i % 64 == 0 && std::chrono::steady_clock::now() - start > kSpin) return done();
  }
}

}  // namespace

Team::Team(int threads) : segments_(static_cast<std::size_t>(std::max(threads, 1))) {
  const int workers = std::max(threads, 1) - 1;
  workers_.reserve(static_cast<std::size_t>(workers));
  for (int w = 1; w <= workers; ++w) workers_.emplace_back([this, w] { work(w); });
}

Team::~Team() {
  stop_.store(true, std::memory_order_seq_cst);
  generation_.fetch_add(1, std::memory_order_seq_cst);
  generation_.notify_all();
  for (std::thread& t : workers_) t.join();
}

// A job's fields and segments are written before its generation is published (release). A thread
// that read the fields of generation g after job g + 2 overwrote them finds the segments at g + 1
// or later, so its claims on g fail; a claim on g that succeeds means job g is not done, so job
// g + 2 has not been posted and the fields it read are g's.
void Team::dispatch(std::size_t chunks, Call call, void* context) {
  if (chunks > UINT32_MAX) throw std::length_error("parallel::Team: more than 2^32 - 1 chunks in one loop");
  const auto n = static_cast<std::uint32_t>(chunks);
  const auto size = static_cast<std::uint64_t>(segments_.size());
  const std::uint32_t generation = generation_.load(std::memory_order_relaxed) + 1;
  Job& job = jobs_[generation % 2];
  job.call.store(call, std::memory_order_relaxed);
  job.context.store(context, std::memory_order_relaxed);
  job.chunks.store(n, std::memory_order_relaxed);
  done_.store(0, std::memory_order_relaxed);
  failed_.store(false, std::memory_order_relaxed);
  error_ = nullptr;
  for (std::uint64_t s = 0; s < size; ++s)
    segments_[s].next.store((static_cast<std::uint64_t>(generation) << 32) | (s * n / size),
                            std::memory_order_relaxed);
  // Sleeping workers are woken; a worker about to sleep sees the new generation (both seq_cst).
  generation_.store(generation, std::memory_order_seq_cst);
  if (sleeping_workers_.load(std::memory_order_seq_cst) > 0) generation_.notify_all();

  claim(0, generation, call, context, n);
  // Only chunks another thread holds are left: spin, then sleep until the last one returns.
  if (!spin_until([&] { return done_.load(std::memory_order_acquire) == n; })) {
    caller_sleeping_.store(true, std::memory_order_seq_cst);
    for (std::uint32_t d; (d = done_.load(std::memory_order_seq_cst)) != n;)
      done_.wait(d, std::memory_order_seq_cst);
    caller_sleeping_.store(false, std::memory_order_relaxed);
  }
  if (failed_.load(std::memory_order_acquire)) std::rethrow_exception(error_);
}

// A job of no chunks carries the background call to the workers (woken by its generation); the
// first that sees it takes it.
void Team::post_background(Call call, void* context) {
  const std::uint32_t generation = generation_.load(std::memory_order_relaxed) + 1;
  Job& job = jobs_[generation % 2];
  job.chunks.store(0, std::memory_order_relaxed);
  for (Segment& segment : segments_)
    segment.next.store(static_cast<std::uint64_t>(generation) << 32, std::memory_order_relaxed);
  background_error_ = nullptr;
  background_done_.store(false, std::memory_order_relaxed);
  background_context_.store(context, std::memory_order_relaxed);
  background_.store(call, std::memory_order_release);  // with the context and the caller's state
  generation_.store(generation, std::memory_order_seq_cst);
  if (sleeping_workers_.load(std::memory_order_seq_cst) > 0) generation_.notify_all();
}

std::exception_ptr Team::join_background() {
  if (!spin_until([&] { return background_done_.load(std::memory_order_acquire); }))
    while (!background_done_.load(std::memory_order_seq_cst))
      background_done_.wait(false, std::memory_order_seq_cst);
  return std::exchange(background_error_, nullptr);
}

void Team::claim(int self, std::uint32_t generation, Call call, void* context, std::uint32_t chunks) {
  const auto size = static_cast<std::uint64_t>(segments_.size());
  std::uint32_t ran = 0;
  bool current = true;  // the job is still the one of `generation`
  for (std::uint64_t k = 0; k < size && current; ++k) {
    const std::uint64_t s = (static_cast<std::uint64_t>(self) + k) % size;
    const auto end = static_cast<std::uint32_t>((s + 1) * chunks / size);
    std::atomic<std::uint64_t>& next = segments_[s].next;
    std::uint64_t t = next.load(std::memory_order_acquire);
    for (;;) {
      if (static_cast<std::uint32_t>(t >> 32) != generation) {
        current = false;
        break;
      }
      const auto c = static_cast<std::uint32_t>(t);
      if (c >= end) break;
      if (!next.compare_exchange_weak(t, t + 1, std::memory_order_acq_rel, std::memory_order_acquire))
        continue;  // t now holds the segment's current value
      try {
        call(context, c);
      } catch (...) {
        if (!failed_.exchange(true, std::memory_order_relaxed)) error_ = std::current_exception();
      }
      ++ran;
      t = next.load(std::memory_order_acquire);
    }
  }
  // A thread that ran chunks of this job reports them before the caller can post another, so the
  // report always counts for the job it ran. The last one wakes the caller if it sleeps (seq_cst
  // against its flag and its check).
  if (ran > 0 && done_.fetch_add(ran, std::memory_order_seq_cst) + ran == chunks &&
      caller_sleeping_.load(std::memory_order_seq_cst))
    done_.notify_one();
}

void Team::work(int self) {
  std::uint32_t seen = 0;
  for (;;) {
    if (!spin_until([&] { return generation_.load(std::memory_order_acquire) != seen; })) {
      sleeping_workers_.fetch_add(1, std::memory_order_seq_cst);
      while (generation_.load(std::memory_order_seq_cst) == seen)
        generation_.wait(seen, std::memory_order_seq_cst);
      sleeping_workers_.fetch_sub(1, std::memory_order_relaxed);
    }
    // The generation first: the destructor sets stop_ before it posts its generation, so a worker
    // that takes that generation for a job sees stop_ (and does not wait for a job after it).
    seen = generation_.load(std::memory_order_acquire);
    if (stop_.load(std::memory_order_acquire)) return;
    const Job& job = jobs_[seen % 2];
    claim(self, seen, job.call.load(std::memory_order_relaxed), job.context.load(std::memory_order_relaxed),
          job.chunks.load(std::memory_order_relaxed));
    // run_beside(): the call is stored before the generation that announced it, so found here at
    // the latest after that generation's (empty) job; the caller waits for it, so at most one is
    // pending. Taken with acquire: the context and the caller's state are visible.
    if (background_.load(std::memory_order_relaxed) != nullptr) {
      if (const Call call = background_.exchange(nullptr, std::memory_order_acquire)) {
        try {
          call(background_context_.load(std::memory_order_relaxed), 0);
        } catch (...) {
          background_error_ = std::current_exception();
        }
        background_done_.store(true, std::memory_order_seq_cst);
        background_done_.notify_one();
      }
    }
  }
}

}  // namespace scalpel::parallel
