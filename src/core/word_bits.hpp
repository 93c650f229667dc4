// Bit tables of control and status words (docs/design.md "Words"): one table per word, declared by
// the dissector whose protocol carries the word. Its frame line reads the table, and so does the
// drive level, through a profile's `bits = "<table id>"`, so every output names a bit the same way.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace drivetap {

// What bit `bit` means when 0 and when 1; an empty meaning is not shown.
struct BitName {
  int bit = 0;
  std::string_view when_clear;
  std::string_view when_set;
};

// One word's bits, in bit order; `id` is the name a profile gives it ("danfoss_fc.ctw").
struct WordBits {
  std::string_view id;
  std::string_view name;  // "FC profile control word (CTW)"
  std::span<const BitName> bits;
};

// The meanings `raw` has under `bits` (BitName or a profile's RegisterBit), ", "-separated, in
// the table's order. The one rendering of a word's bits: the frame line and the `=` line use it.
// `Out`: a std::string or a LineBuffer (anything with += of text and of ", ").
template <class Out, class Bits>
void append_bit_names(Out& out, const Bits& bits, std::uint32_t raw) {
  bool first = true;
  for (const auto& b : bits) {
    const auto& name = ((raw >> b.bit) & 1) ? b.when_set : b.when_clear;
    if (name.empty()) continue;
    if (!first) out += ", ";
    out += name;
    first = false;
  }
}

}  // namespace drivetap
