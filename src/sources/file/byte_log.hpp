// Byte log reader: drivetap's plain-text capture format (docs/formats.md "The byte log").
//
//   # comment                     (a '#' token also starts a comment at the end of a line)
//   #! serial 9600 8N1            header: line settings (before the first byte)
//   <time> <channel> <hex bytes...>
//
// time: decimal seconds (up to 9 fractional digits) at the start bit of the line's first byte;
// the line's bytes follow back to back at the character time. Bytes are 2-digit tokens or even-
// length runs ("02 03 00" or "020300"); a 2-digit token may carry UART marks after '!':
// f framing, p parity, b break, o overrun ("00!fb"). Streamed line by line: constant memory.
#pragma once

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "core/anomaly.hpp"
#include "core/byte_event.hpp"
#include "core/serial_config.hpp"
#include "sources/source.hpp"

namespace drivetap {

class ByteLogReader final : public ByteSource {
 public:
  // `in` stays owned by the caller. `name` is used in error messages.
  ByteLogReader(std::FILE* in, std::string name, ChannelTable& channels);
  ~ByteLogReader();
  ByteLogReader(const ByteLogReader&) = delete;
  ByteLogReader& operator=(const ByteLogReader&) = delete;

  // Reads the comment and header lines before the first data line. Returns false on error.
  bool read_header() override;
  [[nodiscard]] const std::optional<SerialConfig>& header_serial() const { return header_serial_; }
  [[nodiscard]] RunSettings settings() const override {
    RunSettings r;
    r.serial = header_serial_;
    return r;
  }
  // The character time that spaces the bytes of one line (from the effective line settings).
  void set_character_time(TimeNs t) override { character_time_ = t; }

  // Next byte; false at end of input or on error (then error() is non-empty).
  bool next(ByteEvent& out) override;
  [[nodiscard]] const std::string& error() const override { return error_; }
  // Findings about the file itself (timestamps going backwards), to hand to the pipeline.
  std::vector<Anomaly> take_findings() override;

  // True when `head` (the first bytes of a file) looks like a byte log.
  static bool sniff(std::string_view head);

 private:
  bool read_line();        // next raw line into line_; false at EOF or error
  bool parse_data_line();  // fills queue_ from line_
  bool fail(std::size_t column, const std::string& reason);

  std::FILE* in_;
  std::string name_;
  ChannelTable& channels_;
  std::optional<SerialConfig> header_serial_;
  TimeNs character_time_ = 0;
  // Lines are cut from this buffer (read in blocks; it grows only while one line outgrows it, up
  // to the line length limit, so a file with no newline cannot take memory without bound).
  std::vector<char> buffer_;
  std::size_t buffer_pos_ = 0;  // start of the next line
  std::size_t buffer_end_ = 0;  // end of what was read
  bool at_eof_ = false;
  std::string_view line_;
  bool line_ended_ = true;  // the line had its '\n' (only a file's last line may lack it)
  std::uint64_t line_number_ = 0;
  bool have_pending_line_ = false;  // read_header() stopped at a data line
  std::vector<ByteEvent> queue_;
  std::size_t queue_pos_ = 0;
  std::vector<TimeNs> last_line_time_;  // per channel
  std::vector<Anomaly> findings_;
  std::string error_;
};

}  // namespace drivetap
