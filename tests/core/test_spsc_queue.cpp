// SPSC queue: FIFO order, bounded capacity without blocking, and every item
// delivered exactly once in order across threads.

#include "core/spsc_queue.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <thread>

namespace palpa {
namespace {

TEST(SpscQueue, CapacityIsRoundedUpToAPowerOfTwo) {
  EXPECT_EQ(SpscQueue<int>(1).capacity(), 2u);
  EXPECT_EQ(SpscQueue<int>(5).capacity(), 8u);
  EXPECT_EQ(SpscQueue<int>(1024).capacity(), 1024u);
}

TEST(SpscQueue, RefusesAbsurdCapacities) {
  EXPECT_THROW(SpscQueue<int>(0), std::invalid_argument);
  EXPECT_THROW(SpscQueue<int>(std::size_t{1} << 31), std::invalid_argument);
}

TEST(SpscQueue, FifoAndFullWithoutBlocking) {
  SpscQueue<int> q(4);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(q.push(i));
  EXPECT_FALSE(q.push(99));  // full: refused, nothing overwritten
  EXPECT_EQ(q.size(), 4u);
  int v = -1;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(q.pop(v));
    EXPECT_EQ(v, i);
  }
  EXPECT_FALSE(q.pop(v));
  EXPECT_TRUE(q.push(5));  // wraps around
  ASSERT_TRUE(q.pop(v));
  EXPECT_EQ(v, 5);
}

TEST(SpscQueue, ThreadedDeliveryIsCompleteAndOrdered) {
  SpscQueue<std::uint64_t> q(1024);
  constexpr std::uint64_t kItems = 3'000'000;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kItems;)
      if (q.push(i)) ++i;
  });
  std::uint64_t expected = 0, v = 0, wrong = 0;
  while (expected < kItems)
    if (q.pop(v)) wrong += (v != expected++);
  producer.join();
  EXPECT_EQ(wrong, 0u);
  EXPECT_FALSE(q.pop(v));
}

}  // namespace
}  // namespace palpa
