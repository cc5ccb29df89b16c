// SharedByOwner (core/shared_by_owner.h): one computation per owning object
// and key while its result is held, by object identity, never keeping
// either alive.

#include "core/shared_by_owner.h"

#include <gtest/gtest.h>

#include <memory>
#include <thread>
#include <vector>

namespace palpa {
namespace {

struct Owner {
  int value = 0;
};

TEST(SharedByOwner, OneComputationPerOwnerAndKeyWhileHeld) {
  SharedByOwner<Owner, int, int> cache;
  int made = 0;
  auto make = [&](int v) { return [&made, v] { ++made; return v; }; };
  const auto a = std::make_shared<const Owner>(Owner{1});
  auto first = cache.get(a, 7, make(10));
  EXPECT_EQ(*first, 10);
  // Held: the same object back, nothing computed.
  EXPECT_EQ(cache.get(a, 7, make(99)).get(), first.get());
  EXPECT_EQ(made, 1);
  // Another key of the same owner: its own value.
  EXPECT_EQ(*cache.get(a, 8, make(20)), 20);
  EXPECT_EQ(made, 2);
  // An equal but distinct owner object: its own value.
  const auto twin = std::make_shared<const Owner>(Owner{1});
  EXPECT_EQ(*cache.get(twin, 7, make(30)), 30);
  EXPECT_EQ(made, 3);
  // Released by everyone: computed again.
  first.reset();
  EXPECT_EQ(*cache.get(a, 7, make(40)), 40);
  EXPECT_EQ(made, 4);
}

TEST(SharedByOwner, KeepsNeitherOwnerNorValueAlive) {
  SharedByOwner<Owner, std::vector<int>, int> cache;
  auto owner = std::make_shared<const Owner>();
  const std::weak_ptr<const Owner> owner_seen = owner;
  auto value = cache.get(owner, 0, [] { return std::vector<int>(100, 1); });
  const std::weak_ptr<const std::vector<int>> value_seen = value;
  owner.reset();
  EXPECT_TRUE(owner_seen.expired());
  value.reset();
  EXPECT_TRUE(value_seen.expired());
  // A new owner (perhaps at the freed address) is not the old one.
  int made = 0;
  const auto next = std::make_shared<const Owner>();
  cache.get(next, 0, [&] {
    ++made;
    return std::vector<int>{};
  });
  EXPECT_EQ(made, 1);
}

TEST(SharedByOwner, ThreadsAskingAtOnceAllGetTheValue) {
  SharedByOwner<Owner, int, int> cache;
  const auto owner = std::make_shared<const Owner>();
  std::vector<std::shared_ptr<const int>> got(8);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < got.size(); ++t)
    threads.emplace_back([&, t] { got[t] = cache.get(owner, 1, [] { return 5; }); });
  for (auto& th : threads) th.join();
  for (const auto& g : got) {
    ASSERT_TRUE(g);
    EXPECT_EQ(*g, 5);
  }
  // Once they are all held, a further ask computes nothing.
  EXPECT_EQ(*cache.get(owner, 1, [] { return -1; }), 5);
}

}  // namespace
}  // namespace palpa
