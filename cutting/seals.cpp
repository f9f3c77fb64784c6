// Seals between the promoted and the still cut part of a stroke (paper section 6).
#include "cutting/seals.hpp"

#include <iterator>

#include "cutting/cut_engine_internal.hpp"

namespace scalpel {

bool Seals::held(const Key& outer) const {
  bool any = false;
  cut_internal::for_tets_around(units_, outer, [&](std::uint32_t) { any = true; });
  return any;
}

bool Seals::sealed(const Key& key) const {
  for (auto it = seals_.lower_bound({key, Key{}}); it != seals_.end() && it->first == key; ++it)
    if (held(it->second)) return true;
  return false;
}

bool Seals::recorded(const Key& key) const {
  const auto it = seals_.lower_bound({key, Key{}});
  return it != seals_.end() && it->first == key;
}

void Seals::lift_released() {
  std::erase_if(seals_, [&](const auto& s) { return !held(s.second); });
}

}  // namespace scalpel
