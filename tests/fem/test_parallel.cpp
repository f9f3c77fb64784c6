#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <numeric>
#include <stdexcept>
#include <thread>
#include <vector>

#include "fem/parallel.hpp"

using namespace scalpel;

namespace {

// Calls of each chunk of one run.
struct Tally {
  std::vector<std::atomic<int>> calls;
  explicit Tally(std::size_t n) : calls(n) {}
};

// Computes for about `d` on this thread: long enough for idle workers to fall asleep.
void busy_for(std::chrono::microseconds d) {
  const auto end = std::chrono::steady_clock::now() + d;
  volatile double x = 1;
  while (std::chrono::steady_clock::now() < end) x = x * 1.0000001;
}

}  // namespace

TEST_CASE("parallel team: every chunk runs exactly once, for 1 to 4 threads") {
  for (const int threads : {1, 2, 3, 4}) {
    parallel::Team team(threads);
    CHECK(team.size() == threads);
    for (const std::size_t n : {0u, 1u, 2u, 3u, 7u, 64u, 1000u}) {
      Tally tally(n);
      team.run(n, [&](std::size_t c) { tally.calls[c].fetch_add(1); });
      for (std::size_t c = 0; c < n; ++c) CHECK(tally.calls[c].load() == 1);
    }
  }
}

TEST_CASE("parallel team: thousands of short jobs in a row, and jobs after the workers slept") {
  parallel::Team team(2);
  std::vector<std::uint64_t> out(40);
  std::uint64_t expected = 0, got = 0;
  for (std::uint64_t job = 0; job < 20000; ++job) {
    team.run(out.size(), [&](std::size_t c) { out[c] = job * 1000 + c; });
    for (std::size_t c = 0; c < out.size(); ++c) {
      expected += job * 1000 + c;
      got += out[c];
    }
    // Now and then the workers run out of spin and sleep; the next job must wake them.
    if (job % 2000 == 0) busy_for(std::chrono::microseconds(2000));
  }
  CHECK(got == expected);
}

TEST_CASE("parallel team: jobs of changing sizes on more threads than cores") {
  // Preempted workers that wake in the middle of a later job must neither run a chunk twice nor
  // count one for the wrong job (a miscount would leave run() waiting for ever).
  parallel::Team team(5);
  std::vector<int> hits(300);
  for (int job = 0; job < 100000; ++job) {
    const std::size_t n = 1 + static_cast<std::size_t>((job * 7919) % 300);
    team.run(n, [&](std::size_t c) { ++hits[c]; });
    for (std::size_t c = 0; c < n; ++c) REQUIRE(hits[c] == 1);
    std::fill(hits.begin(), hits.begin() + static_cast<std::ptrdiff_t>(n), 0);
  }
}

TEST_CASE("parallel team: teams destroyed just after their last job, thousands of times") {
  // A worker that has just woken for the last job when the team is destroyed must still stop: it
  // once took the destructor's generation for a job and waited for the next one for ever. The
  // window is a few instructions wide, so this catches it only now and then (a hang: the test's
  // timeout); the order it relies on is in Team::work().
  std::atomic<int> calls{0};
  for (int i = 0; i < 3000; ++i) {
    parallel::Team team(3);
    team.run(2, [&](std::size_t) { calls.fetch_add(1); });
  }
  CHECK(calls.load() == 6000);
}

TEST_CASE("parallel team: the workers take part in a long job") {
  // A chunk that waits until another thread has started a chunk can only finish if a worker runs
  // one: with one thread the job would never end, so the test is bounded by the first chunk's wait.
  parallel::Team team(2);
  std::atomic<int> started{0};
  std::vector<std::thread::id> by(2);
  team.run(2, [&](std::size_t c) {
    by[c] = std::this_thread::get_id();
    started.fetch_add(1);
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (started.load() < 2 && std::chrono::steady_clock::now() < give_up) std::this_thread::yield();
  });
  CHECK(started.load() == 2);
  CHECK(by[0] != by[1]);
}

TEST_CASE("parallel team: run_beside runs the background on a worker, which then joins the foreground") {
  parallel::Team team(2);
  const std::thread::id caller = std::this_thread::get_id();
  std::thread::id background_on;
  std::atomic<bool> background_done{false};
  std::atomic<int> started{0};
  std::vector<std::thread::id> by(2);
  team.run_beside(
      [&] {
        background_on = std::this_thread::get_id();
        background_done.store(true);
      },
      [&] {
        const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (!background_done.load() && std::chrono::steady_clock::now() < give_up)
          std::this_thread::yield();
        // As in the long job above: both chunks can only finish if the worker runs one.
        team.run(2, [&](std::size_t c) {
          by[c] = std::this_thread::get_id();
          started.fetch_add(1);
          while (started.load() < 2 && std::chrono::steady_clock::now() < give_up) std::this_thread::yield();
        });
      });
  CHECK(background_done.load());
  CHECK(background_on != caller);
  CHECK(started.load() == 2);
  CHECK(by[0] != by[1]);
}

TEST_CASE(
    "parallel team: run_beside many times, with the foreground's loops before and after the worker joins") {
  for (const int threads : {1, 2, 3}) {
    parallel::Team team(threads);
    std::vector<int> hits(64);
    for (int round = 0; round < 20000; ++round) {
      int background = 0;
      team.run_beside([&] { ++background; },
                      [&] {
                        for (int job = 0; job < 3; ++job) {
                          const auto n = static_cast<std::size_t>(1 + (round + job) % 64);
                          team.run(n, [&](std::size_t c) { ++hits[c]; });
                          for (std::size_t c = 0; c < n; ++c) REQUIRE(hits[c] == 1);
                          std::fill(hits.begin(), hits.end(), 0);
                        }
                      });
      REQUIRE(background == 1);
    }
  }
}

TEST_CASE("parallel team: run_beside rethrows an exception of either side once both returned") {
  for (const int threads : {1, 2}) {
    parallel::Team team(threads);
    std::atomic<int> ran{0};
    CHECK_THROWS_WITH_AS(team.run_beside([&] { throw std::runtime_error("background"); },
                                         [&] { team.run(8, [&](std::size_t) { ran.fetch_add(1); }); }),
                         "background", std::runtime_error);
    CHECK(ran.load() == 8);
    bool background = false;
    CHECK_THROWS_WITH_AS(
        team.run_beside([&] { background = true; }, [&] { throw std::runtime_error("foreground"); }),
        "foreground", std::runtime_error);
    CHECK(background);
    // The team is usable afterwards.
    std::atomic<int> after{0};
    team.run(10, [&](std::size_t) { after.fetch_add(1); });
    CHECK(after.load() == 10);
  }
}

TEST_CASE("parallel team: an exception from a chunk reaches the caller after every chunk returned") {
  for (const int threads : {1, 2}) {
    parallel::Team team(threads);
    Tally tally(100);
    CHECK_THROWS_WITH_AS(team.run(100,
                                  [&](std::size_t c) {
                                    tally.calls[c].fetch_add(1);
                                    if (c == 37) throw std::runtime_error("chunk 37");
                                  }),
                         "chunk 37", std::runtime_error);
    int total = 0;
    for (std::size_t c = 0; c < 100; ++c) total += tally.calls[c].load();
    CHECK(total == 100);
    // The team is usable afterwards.
    std::atomic<int> after{0};
    team.run(10, [&](std::size_t) { after.fetch_add(1); });
    CHECK(after.load() == 10);
  }
}

TEST_CASE("parallel team: reductions are bit-identical for any thread count") {
  std::vector<double> x(100000);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = 1.0 / static_cast<double>(i + 1);
  std::vector<double> partial(parallel::chunk_count(x.size()));
  std::vector<double> sums;
  for (const int threads : {1, 2, 3}) {
    parallel::Team team(threads);
    for (int repeat = 0; repeat < 20; ++repeat)
      sums.push_back(parallel::reduce(team, x.size(), partial, [&](std::size_t i) { return x[i]; }));
  }
  for (const double s : sums) CHECK(s == sums.front());
  // Not the sum in plain index order: the chunking is what makes it independent of the threads.
  CHECK(sums.front() == doctest::Approx(std::accumulate(x.begin(), x.end(), 0.0)).epsilon(1e-12));
}
