#include <doctest/doctest.h>

#include <array>
#include <cstdint>
#include <thread>

#include "base/spsc_ring.hpp"

using namespace scalpel;

TEST_CASE("the SPSC ring holds exactly its capacity and keeps order across the wrap") {
  SpscRing<int> ring(3);
  CHECK(ring.capacity() == 3);
  int v = 0;
  CHECK(ring.front() == nullptr);
  for (int k = 0; k < 3; ++k) CHECK(ring.push(k));
  CHECK_FALSE(ring.push(3));
  CHECK(ring.size_approx() == 3);
  for (int round = 0; round < 10; ++round) {  // wraps around several times
    REQUIRE(ring.front() != nullptr);
    CHECK(*ring.front() == round);
    REQUIRE(ring.pop(v));
    CHECK(v == round);
    CHECK(ring.push(round + 3));
  }
  for (int k = 10; k < 13; ++k) {
    REQUIRE(ring.pop(v));
    CHECK(v == k);
  }
  CHECK_FALSE(ring.pop(v));
  CHECK(ring.size_approx() == 0);
}

// Under ThreadSanitizer (the tsan preset) this checks the hand-over of each slot: the consumer
// reads a slot the producer wrote just before, and the producer rewrites slots the consumer has
// just released.
TEST_CASE("the SPSC ring hands every element over between two threads, whole and in order") {
  struct Packet {
    std::uint64_t sequence = 0;
    std::array<std::uint64_t, 6> payload{};  // every word repeats the sequence: a torn copy shows
  };
  SpscRing<Packet> ring(8);  // small, so the producer keeps meeting a full ring
  constexpr std::uint64_t kCount = 20000;
  std::uint64_t full = 0;
  std::thread producer([&] {
    for (std::uint64_t i = 1; i <= kCount;) {
      Packet p;
      p.sequence = i;
      p.payload.fill(i);
      if (ring.push(p)) {
        ++i;
      } else {
        ++full;
        std::this_thread::yield();  // on a busy machine the consumer may need this core
      }
    }
  });
  std::uint64_t expected = 1, out_of_order = 0, torn = 0, peeked_wrong = 0;
  while (expected <= kCount) {
    const Packet* front = ring.front();
    if (!front) {
      std::this_thread::yield();
      continue;
    }
    const std::uint64_t seen = front->sequence;
    Packet p;
    REQUIRE(ring.pop(p));
    peeked_wrong += seen != p.sequence ? 1 : 0;
    out_of_order += p.sequence != expected ? 1 : 0;
    for (const std::uint64_t w : p.payload) torn += w != p.sequence ? 1 : 0;
    expected = p.sequence + 1;
  }
  producer.join();
  Packet rest;
  CHECK_FALSE(ring.pop(rest));
  CHECK(out_of_order == 0);
  CHECK(torn == 0);
  CHECK(peeked_wrong == 0);
  MESSAGE("the producer met a full ring " << full << " times");
}
