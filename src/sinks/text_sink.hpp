// Text sink: one annotated line per frame, -V field trees, and the closing summary. Lines are
// gathered in a buffer and written in blocks (to a terminal, line by line); flush() writes what
// is buffered.
#pragma once

#include <cstdio>
#include <string>

#include "core/byte_event.hpp"
#include "core/line_buffer.hpp"
#include "core/serial_config.hpp"
#include "sinks/sink.hpp"

namespace drivetap {

struct TextSinkOptions {
  bool verbose = false;   // -V: field tree with byte offsets under each frame
  bool show_time = true;  // false for `decode`, whose times are synthetic
  bool summary = true;
  bool frames = true;  // false: only the closing summary (e.g. with -w -)
};

class TextSink final : public Sink {
 public:
  TextSink(std::FILE* out, const ChannelTable& channels, TextSinkOptions options);
  void on_frame(const Message& message) override;
  void on_noise(const Frame& noise) override;
  void on_anomaly(const Anomaly& anomaly) override;
  void on_transaction(const Transaction& transaction) override;
  void on_summary(const Stats& stats) override;
  void on_event(const BusEvent& event) override;
  bool flush() override;
  // The field tree is shown only with -V.
  [[nodiscard]] bool wants_fields() const override { return options_.verbose; }
  [[nodiscard]] bool wants_transactions() const override { return false; }  // see on_transaction

 private:
  // Appends `line` and a newline to the output buffer.
  void write(std::string_view line);
  // Ends the line being built at the end of the output buffer; writes the buffer out once it
  // holds kWriteAt bytes (one fwrite per some 600 frame lines, not one or two per line).
  void end_line();
  // Writes the buffered lines to the file.
  void write_out();
  // "   12   1.234567 bus " (number, time, channel), appended to `s`.
  template <class Out>
  void append_prefix(Out& s, std::uint64_t number, TimeNs time, ChannelId channel) const;
  std::string prefix(std::uint64_t number, TimeNs time, ChannelId channel) const;

  static constexpr std::size_t kWriteAt = 64 * 1024;
  std::FILE* out_;
  const ChannelTable& channels_;
  TextSinkOptions options_;
  std::uint64_t last_frame_number_ = 0;
  WriteStatus status_;
  // A terminal gets each line as it is made (someone is watching); files and pipes get blocks.
  bool to_terminal_ = false;
  LineBuffer buffer_;  // whole lines not written yet (flush() writes them)
  mutable LineBuffer seconds_;  // scratch for the time column
};

// The decode of a frame in one line, without number/time/channel: shared with the JSON
// `summary` key so both sinks say the same thing.
std::string frame_summary(const Message& message, bool with_latency = true);
// Out: std::string or LineBuffer (instantiated for both).
template <class Out>
void append_frame_summary(Out& out, const Message& message, bool with_latency = true);

}  // namespace drivetap
