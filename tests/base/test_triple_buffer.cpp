#include <doctest/doctest.h>

#include <atomic>
#include <thread>

#include "base/triple_buffer.hpp"

using namespace scalpel;

TEST_CASE("the triple buffer hands the newest value over") {
  TripleBuffer<int> b(7);
  CHECK_FALSE(b.update());
  CHECK(b.read() == 7);
  b.publish(1);
  b.publish(2);
  CHECK(b.update());
  CHECK(b.read() == 2);
  CHECK_FALSE(b.update());
  CHECK(b.read() == 2);
}

TEST_CASE("the triple buffer never tears a value across threads") {
  struct Pair {
    long a = 0, b = 0;
  };
  TripleBuffer<Pair> buf;
  constexpr long kCount = 200000;
  std::thread writer([&] {
    for (long i = 1; i <= kCount; ++i) buf.publish({i, -i});
  });
  long last = 0;
  bool torn = false, backwards = false;
  while (last < kCount) {
    if (!buf.update()) continue;
    const Pair p = buf.read();
    torn |= p.a != -p.b;
    backwards |= p.a < last;
    last = p.a;
  }
  writer.join();
  CHECK_FALSE(torn);
  CHECK_FALSE(backwards);
}
