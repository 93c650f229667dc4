// Untrusted text made safe to print: names and strings taken from input files (pcapng if_name,
// byte-log channel columns, logic probe names, profile strings) reach terminals, text lines and
// JSON, where a newline would forge an output line, an ESC sequence would drive the terminal and
// a stray byte >= 0x80 would make the JSON invalid UTF-8.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace drivetap {

// `text` with every byte that is not part of printable, valid UTF-8 (control characters, C1
// controls, DEL, malformed or overlong sequences, surrogates) written as `\xNN`, and a backslash
// as `\\` so that the escapes cannot be forged (unless `escape_backslash` is false: a message of
// drivetap's own that quotes a name). Printable UTF-8 passes unchanged.
std::string printable(std::string_view text, bool escape_backslash = true);

// printable(text) bounded to about `max_bytes`: a longer result keeps its start, cut at a
// character boundary, then "…" and a hash of the whole original ("#1a2b3c4d"), so that two long
// names that begin alike stay apart.
std::string printable_bounded(std::string_view text, std::size_t max_bytes);

// Length of the well-formed UTF-8 character at text[i] (1 for ASCII), or 0 when the bytes there
// are malformed, overlong, a surrogate or beyond U+10FFFF, or (unless allow_c1) a C1 control.
std::size_t utf8_length(std::string_view text, std::size_t i, bool allow_c1);

}  // namespace drivetap
