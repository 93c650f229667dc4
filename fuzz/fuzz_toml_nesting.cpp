// Fuzzes the nesting of drive profiles (TOML): the input is a program that builds a
// profile text, so that deep and long structures, which random bytes rarely make, are the common
// case. Each byte is one step:
//   0-31   open an array            32-63   open an inline table (a key first)
//   64-95  a dotted key part        96-127  close the innermost array or table
//   128-159 a string with brackets and dots in it (they are text, not nesting)
//   160-191 a comment with brackets  192-223 a table header of (byte % 40) dotted parts
//   224-255 a newline and a new key
// parse_profile() must not crash (the stack: toml++ recurses on nesting), and a refusal must
// name the file.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "drive/profile.hpp"
#include "fuzz/fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace drivetap;
  std::string text = "a = ";
  std::vector<char> open;  // ']' or '}' to close
  for (std::size_t i = 0; i < size; ++i) {
    const std::uint8_t op = data[i];
    if (op < 32) {
      text += '[';
      open.push_back(']');
    } else if (op < 64) {
      text += "{k = ";
      open.push_back('}');
    } else if (op < 96) {
      text += ".p" + std::to_string(op % 10);
    } else if (op < 128) {
      if (!open.empty()) {
        text += open.back();
        open.pop_back();
      }
      text += ", ";
    } else if (op < 160) {
      text += op % 2 ? "\"[{.}]\", " : "'''[[.]]''', ";
    } else if (op < 192) {
      text += "# [[[ ... {{{\n";
    } else if (op < 224) {
      text += "\n[t";
      for (int k = 0; k < op % 40; ++k) text += ".t";
      text += "]\n";
    } else {
      text += "\nb" + std::to_string(i) + " = ";
    }
  }
  while (!open.empty()) {
    text += open.back();
    open.pop_back();
  }
  ProfileError error;
  const auto profile = parse_profile(text, "fuzz.toml", &error);
  if (!profile && error.text().rfind("fuzz.toml", 0) != 0)
    fuzz::contract_broken("a refused profile without its file name");
  return 0;
}
