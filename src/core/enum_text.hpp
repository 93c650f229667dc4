// Enum-to-text by table: the names of an enum's values, listed in enumerator order.
#pragma once

#include <cstddef>

namespace drivetap {

// The name of `e` in `names` (indexed by the enumerator's value), `fallback` for a value
// outside the table. Callers static_assert that the table covers the enum's last value,
// which the switch it replaces had from -Wswitch.
template <class Enum, class Text, std::size_t N>
constexpr Text enum_text(Enum e, const Text (&names)[N], Text fallback) {
  const auto i = static_cast<std::size_t>(e);
  return i < N ? names[i] : fallback;
}

}  // namespace drivetap
