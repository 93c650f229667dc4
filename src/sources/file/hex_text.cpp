// Hex text input for `drivetap decode`.
#include "sources/file/hex_text.hpp"

#include <fmt/format.h>

namespace drivetap {

std::optional<std::vector<std::vector<std::uint8_t>>> parse_hex_frames(std::string_view text,
                                                                       std::string* error) {
  std::vector<std::vector<std::uint8_t>> frames;
  // Per frame: whether a comma ended it (a C array's commas separate bytes, not frames).
  std::vector<bool> comma_after;
  std::vector<std::uint8_t> current;
  int high = -1;  // pending high nibble
  std::size_t high_pos = 0;
  bool in_braces = false;    // inside { } or [ ]: one frame, commas between its bytes
  bool after_digit = false;  // the previous character completed a byte ("02h")
  auto end_frame = [&](bool by_comma) {
    if (high >= 0) {
      *error = fmt::format("odd number of hex digits: '{}' at position {} has no partner",
                           text[high_pos], high_pos + 1);
      return false;
    }
    if (!current.empty()) {
      frames.push_back(std::move(current));
      comma_after.push_back(by_comma);
    }
    current.clear();
    return true;
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    const bool completed = after_digit;
    after_digit = false;
    if (c == '{' || c == '[' || c == '}' || c == ']') {
      if (!end_frame(false)) return std::nullopt;
      in_braces = c == '{' || c == '[';
      continue;
    }
    if (c == ',' && in_braces) continue;
    if (c == '|' || c == ',' || c == ';' || c == '\n') {
      if (!end_frame(c == ',')) return std::nullopt;
      continue;
    }
    if (c == ' ' || c == '\t' || c == '\r' || c == '-') continue;
    if ((c == 'h' || c == 'H') && completed) continue;  // Intel's suffix: 02h
    if (c == '0' && i + 1 < text.size() && (text[i + 1] == 'x' || text[i + 1] == 'X') && high < 0) {
      ++i;
      continue;
    }
    int v = -1;
    if (c >= '0' && c <= '9') v = c - '0';
    if (c >= 'a' && c <= 'f') v = c - 'a' + 10;
    if (c >= 'A' && c <= 'F') v = c - 'A' + 10;
    if (v < 0) {
      *error = fmt::format("'{}' at position {} is not a hex digit", c, i + 1);
      return std::nullopt;
    }
    if (high < 0) {
      high = v;
      high_pos = i;
    } else {
      current.push_back(static_cast<std::uint8_t>((high << 4) | v));
      high = -1;
      after_digit = true;
    }
  }
  if (!end_frame(false)) return std::nullopt;
  if (frames.empty()) {
    *error = "no hex bytes given";
    return std::nullopt;
  }
  // Bytes one to a comma ("0x02,0x03,0x00"): one frame, as a C array writes it. A frame of one
  // byte is no telegram, so no text of frames reads otherwise.
  std::vector<std::vector<std::uint8_t>> merged;
  bool previous_single = false;  // the frame before k had one byte
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const bool single = frames[k].size() == 1;
    if (k > 0 && comma_after[k - 1] && previous_single && single)
      merged.back().push_back(frames[k].front());
    else
      merged.push_back(std::move(frames[k]));
    previous_single = single;
  }
  return merged;
}

std::optional<std::vector<std::uint8_t>> parse_text_frame(std::string_view text,
                                                          std::string_view terminator,
                                                          std::string* error) {
  std::vector<std::uint8_t> out;
  // Each pass consumes one character or one escape sequence.
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c != '\\') {
      out.push_back(static_cast<std::uint8_t>(c));
      continue;
    }
    if (i + 1 >= text.size()) {
      *error = fmt::format("lone '\\' at position {}", i + 1);
      return std::nullopt;
    }
    const char e = text[++i];
    // The one-character escapes: what follows the '\\', and the byte it stands for.
    static constexpr std::string_view kEscaped = "rnt\\";
    static constexpr std::string_view kEscapedBytes = "\r\n\t\\";
    if (const std::size_t k = kEscaped.find(e); k != std::string_view::npos) {
      out.push_back(static_cast<std::uint8_t>(kEscapedBytes[k]));
      continue;
    }
    switch (e) {
      case 'x': {
        auto digit = [](char d) {
          return d >= '0' && d <= '9'   ? d - '0'
                 : d >= 'a' && d <= 'f' ? d - 'a' + 10
                 : d >= 'A' && d <= 'F' ? d - 'A' + 10
                                        : -1;
        };
        if (i + 2 >= text.size() || digit(text[i + 1]) < 0 || digit(text[i + 2]) < 0) {
          *error = fmt::format("bad escape at position {}: \\x needs two hex digits", i);
          return std::nullopt;
        }
        out.push_back(static_cast<std::uint8_t>(digit(text[i + 1]) * 16 + digit(text[i + 2])));
        i += 2;
        break;
      }
      default:
        *error = fmt::format("unknown escape '\\{}' at position {}", e, i);
        return std::nullopt;
    }
  }
  const std::string_view have(reinterpret_cast<const char*>(out.data()), out.size());
  if (!have.ends_with(terminator.substr(terminator.size() - 1)))
    out.insert(out.end(), terminator.begin(), terminator.end());
  return out;
}

char decode_text_kind(std::string_view text) {
  const std::size_t first = text.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return 0;
  return text[first] == ':' || text[first] == '~' ? text[first] : 'x';
}

std::optional<std::vector<std::vector<std::uint8_t>>> parse_decode_text(std::string_view text,
                                                                        char kind,
                                                                        std::string* error) {
  if (kind == 'x') return parse_hex_frames(text, error);
  auto frame = parse_text_frame(text.substr(text.find(kind)), kind == ':' ? "\r\n" : "\r", error);
  if (!frame) return std::nullopt;
  return std::vector<std::vector<std::uint8_t>>{std::move(*frame)};
}

void synthesize_events(const std::vector<std::vector<std::uint8_t>>& frames, ChannelId channel,
                       TimeNs character_time, TimeNs gap, TimeNs* clock,
                       std::vector<ByteEvent>& out) {
  for (const auto& frame : frames) {
    for (const std::uint8_t b : frame) {
      out.push_back({*clock, b, 0, channel});
      *clock += character_time;
    }
    *clock += gap;
  }
}

}  // namespace drivetap
