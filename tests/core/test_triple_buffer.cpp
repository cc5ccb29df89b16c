// Triple buffer: latest-value semantics, and no torn or out-of-order values
// under a concurrent writer and reader.

#include "core/triple_buffer.h"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <thread>

namespace palpa {
namespace {

struct Payload {
  std::uint64_t id = 0;
  std::array<std::uint64_t, 15> copies{};  // all equal to id when not torn
};

TEST(TripleBuffer, ReaderSeesInitialValueUntilAPublish) {
  TripleBuffer<int> tb(7);
  EXPECT_FALSE(tb.update());
  EXPECT_EQ(tb.read(), 7);
  tb.write(8);
  EXPECT_TRUE(tb.update());
  EXPECT_EQ(tb.read(), 8);
  EXPECT_FALSE(tb.update());  // nothing newer
  EXPECT_EQ(tb.read(), 8);
}

TEST(TripleBuffer, OnlyTheLatestOfSeveralPublishesIsSeen) {
  TripleBuffer<int> tb(0);
  for (int i = 1; i <= 5; ++i) tb.write(i);
  EXPECT_EQ(tb.latest(), 5);
  tb.write(6);
  tb.write(7);
  EXPECT_EQ(tb.latest(), 7);
}

TEST(TripleBuffer, WriteBufferNeverAliasesTheReadBuffer) {
  TripleBuffer<int> tb(0);
  for (int i = 0; i < 20; ++i) {
    tb.write_buffer() = 100 + i;
    EXPECT_NE(&tb.write_buffer(), &tb.read());
    tb.publish();
    tb.update();
    EXPECT_EQ(tb.read(), 100 + i);
    EXPECT_NE(&tb.write_buffer(), &tb.read());
  }
}

TEST(TripleBuffer, ConcurrentValuesAreWholeAndMonotone) {
  TripleBuffer<Payload> tb;
  constexpr std::uint64_t kWrites = 2'000'000;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint64_t i = 1; i <= kWrites; ++i) {
      Payload& p = tb.write_buffer();
      p.id = i;
      p.copies.fill(i);
      tb.publish();
    }
    done.store(true);
  });
  std::uint64_t last = 0, seen = 0, torn = 0, backwards = 0;
  while (true) {
    const bool finished = done.load();
    if (!tb.update()) {
      if (finished) break;
      continue;
    }
    const Payload& p = tb.read();
    for (auto c : p.copies) torn += c != p.id;
    backwards += p.id < last;
    last = p.id;
    ++seen;
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);
  EXPECT_GT(seen, 0u);
  EXPECT_EQ(tb.latest().id, kWrites);
}

}  // namespace
}  // namespace palpa
