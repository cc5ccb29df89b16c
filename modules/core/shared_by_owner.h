#pragma once
// A value computed once per owning object and key, and shared while anyone
// holds it: several users of one object (a mesh's surfaces, its coverage)
// take one result instead of each computing its own. The cache holds weak
// references only, so neither the owner nor the value is kept alive by it;
// an owner is recognised by its control block, not its address, so a new
// object at a freed one's address never matches an old entry.

#include <memory>
#include <mutex>
#include <utility>
#include <vector>

namespace palpa {

/// Owner: the object the value is computed from; Value: the result; Key:
/// anything else the value depends on (compared with ==). Thread-safe; the
/// lock is held while looking up, not while computing (two threads asking
/// at once may both compute; each gets a valid result). Not for the haptic
/// thread: it allocates and locks.
template <class Owner, class Value, class Key>
class SharedByOwner {
 public:
  /// The value held for (owner, key), or make() (returning a Value) run now
  /// and remembered while its result is held. Entries whose owner or value
  /// is gone are dropped.
  template <class Make>
  std::shared_ptr<const Value> get(const std::shared_ptr<const Owner>& owner, const Key& key, Make&& make) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      std::erase_if(entries_, [](const Entry& e) { return e.owner.expired() || e.value.expired(); });
      for (const Entry& e : entries_) {
        const bool same_owner = !e.owner.owner_before(owner) && !owner.owner_before(e.owner);
        if (same_owner && e.key == key)
          if (auto value = e.value.lock()) return value;
      }
    }
    auto value = std::make_shared<const Value>(std::forward<Make>(make)());
    std::lock_guard<std::mutex> lock(mutex_);
    entries_.push_back({owner, key, value});
    return value;
  }

 private:
  struct Entry {
    std::weak_ptr<const Owner> owner;
    Key key;
    std::weak_ptr<const Value> value;
  };
  std::mutex mutex_;
  std::vector<Entry> entries_;
};

}  // namespace palpa
