// A set kept as a sorted vector, for scratch that is filled and cleared every step: clear() keeps
// the storage, so once it has grown a step allocates nothing. Same order and uniqueness as
// std::set with operator<; insertion is linear in the size, which suits the tens to hundreds of
// keys one step touches. Unlike std::set, an insert or erase invalidates every iterator.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace scalpel {

template <class T>
class FlatSet {
 public:
  using const_iterator = typename std::vector<T>::const_iterator;

  // Returns whether the key was new.
  bool insert(const T& key) {
    const auto it = std::lower_bound(keys_.begin(), keys_.end(), key);
    if (it != keys_.end() && !(key < *it)) return false;
    keys_.insert(it, key);
    return true;
  }
  template <class It>
  void insert(It first, It last) {
    for (; first != last; ++first) insert(*first);
  }
  // Returns whether the key was there.
  bool erase(const T& key) {
    const auto it = std::lower_bound(keys_.begin(), keys_.end(), key);
    if (it == keys_.end() || key < *it) return false;
    keys_.erase(it);
    return true;
  }
  [[nodiscard]] bool contains(const T& key) const {
    return std::binary_search(keys_.begin(), keys_.end(), key);
  }
  void clear() { keys_.clear(); }
  [[nodiscard]] bool empty() const { return keys_.empty(); }
  [[nodiscard]] std::size_t size() const { return keys_.size(); }
  [[nodiscard]] const_iterator begin() const { return keys_.begin(); }
  [[nodiscard]] const_iterator end() const { return keys_.end(); }

 private:
  std::vector<T> keys_;
};

}  // namespace scalpel
