// Byte log writer: drivetap's plain-text capture format (docs/formats.md "The byte log"), the
// inverse of sources/file/byte_log.hpp's reader, buffered for large outputs.
//
//   # comment
//   #! serial 19200 8E1
//   <time> <channel> <hex bytes...>   [# comment]
//
// One line per record: its first byte's time, then the bytes, which the reader lays out back to
// back at the character time; UART marks as "!p", "!f", "!b", "!o" after a byte.
#pragma once

#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <string_view>

#include "core/serial_config.hpp"
#include "core/time.hpp"

namespace drivetap {

class ByteLogWriter {
 public:
  // `out` stays owned by the caller, who closes it after flush().
  explicit ByteLogWriter(std::FILE* out) : out_(out) {}
  ByteLogWriter(const ByteLogWriter&) = delete;
  ByteLogWriter& operator=(const ByteLogWriter&) = delete;

  // "# text" lines (one per line of `text`) and the "#! serial" header: before the first line.
  void comment(std::string_view text);
  void header(const SerialConfig& serial);
  // One line; `flags` empty or one UartFlag set per byte; `note` becomes a trailing comment.
  void line(TimeNs time, std::string_view channel, std::span<const std::uint8_t> bytes,
            std::span<const std::uint8_t> flags = {}, std::string_view note = {});
  // Writes what is buffered; false when a write failed (disk full, closed pipe).
  bool flush();

 private:
  void spill();
  std::FILE* out_;
  std::string buffer_;
  bool failed_ = false;
};

}  // namespace drivetap
