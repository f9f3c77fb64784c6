#include "fem/parallel.hpp"

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

Team::Team(int threads) {
  const int workers = std::max(threads, 1) - 1;
  workers_.reserve(static_cast<std::size_t>(workers));
  for (int w = 0; w < workers; ++w) workers_.emplace_back([this] { work(); });
}

Team::~Team() {
  stop_.store(true, std::memory_order_seq_cst);
  generation_.fetch_add(1, std::memory_order_seq_cst);
  generation_.notify_all();
  for (std::thread& t : workers_) t.join();
}

// The fields of a job are written before its ticket is published (release). A thread that read them
// after an older ticket may see a newer job's fields, but then its claim on the older ticket fails:
// the caller writes a job only after every chunk of the last one has returned.
void Team::dispatch(std::size_t chunks, Call call, void* context) {
  const auto n = static_cast<std::uint32_t>(chunks);
  const auto generation = static_cast<std::uint32_t>(ticket_.load(std::memory_order_relaxed) >> 32) + 1;
  call_.store(call, std::memory_order_relaxed);
  context_.store(context, std::memory_order_relaxed);
  chunks_.store(n, std::memory_order_relaxed);
  done_.store(0, std::memory_order_relaxed);
  failed_.store(false, std::memory_order_relaxed);
  error_ = nullptr;
  ticket_.store(static_cast<std::uint64_t>(generation) << 32, std::memory_order_release);
  // Sleeping workers are woken; a worker about to sleep sees the new generation (both seq_cst).
  generation_.store(generation, std::memory_order_seq_cst);
  if (sleeping_workers_.load(std::memory_order_seq_cst) > 0) generation_.notify_all();

  claim(generation, call, context, n);
  // Only chunks another thread holds are left: spin, then sleep until the last one returns.
  if (!spin_until([&] { return done_.load(std::memory_order_acquire) == n; })) {
    caller_sleeping_.store(true, std::memory_order_seq_cst);
    for (std::uint32_t d; (d = done_.load(std::memory_order_seq_cst)) != n;)
      done_.wait(d, std::memory_order_seq_cst);
    caller_sleeping_.store(false, std::memory_order_relaxed);
  }
  if (failed_.load(std::memory_order_acquire)) std::rethrow_exception(error_);
}

// Guided self-scheduling (Polychronopoulos & Kuck, IEEE Trans. Comput. 36, 1987): a claim takes a
// 1 / (2 size) share of the chunks left, so a loop costs a few claims and the last ones are small.
void Team::claim(std::uint32_t generation, Call call, void* context, std::uint32_t chunks) {
  const auto share = static_cast<std::uint32_t>(2 * size());
  std::uint64_t t = ticket_.load(std::memory_order_acquire);
  while (static_cast<std::uint32_t>(t >> 32) == generation && static_cast<std::uint32_t>(t) < chunks) {
    const auto first = static_cast<std::uint32_t>(t);
    const std::uint32_t take = std::max<std::uint32_t>(1, (chunks - first) / share);
    if (!ticket_.compare_exchange_weak(t, t + take, std::memory_order_acq_rel, std::memory_order_acquire))
      continue;  // t now holds the current ticket
    for (std::uint32_t c = first; c < first + take; ++c) {
      try {
        call(context, c);
      } catch (...) {
        if (!failed_.exchange(true, std::memory_order_relaxed)) error_ = std::current_exception();
      }
    }
    // The last chunk wakes the caller if it sleeps (seq_cst against its flag and its check).
    if (done_.fetch_add(take, std::memory_order_seq_cst) + take == chunks &&
        caller_sleeping_.load(std::memory_order_seq_cst))
      done_.notify_one();
    t = ticket_.load(std::memory_order_acquire);
  }
}

void Team::work() {
  std::uint32_t seen = 0;
  for (;;) {
    if (!spin_until([&] { return generation_.load(std::memory_order_acquire) != seen; })) {
      sleeping_workers_.fetch_add(1, std::memory_order_seq_cst);
      while (generation_.load(std::memory_order_seq_cst) == seen)
        generation_.wait(seen, std::memory_order_seq_cst);
      sleeping_workers_.fetch_sub(1, std::memory_order_relaxed);
    }
    if (stop_.load(std::memory_order_acquire)) return;
    seen = generation_.load(std::memory_order_acquire);
    const std::uint64_t t = ticket_.load(std::memory_order_acquire);
    claim(static_cast<std::uint32_t>(t >> 32), call_.load(std::memory_order_relaxed),
          context_.load(std::memory_order_relaxed), chunks_.load(std::memory_order_relaxed));
  }
}

}  // namespace scalpel::parallel
