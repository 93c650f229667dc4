// Text sink: one annotated line per frame, -V field trees, and the closing summary. Lines are
// gathered in a buffer and written in blocks (to a terminal, line by line); flush() writes what
// is buffered.
#pragma once

#include <cstdio>
#include <span>
#include <string>

#include "core/byte_event.hpp"
#include "core/line_buffer.hpp"
#include "core/serial_config.hpp"
#include "sinks/line_writer.hpp"
#include "sinks/sink.hpp"
#include "sinks/time_format.hpp"

namespace drivetap {

struct TextSinkOptions {
  bool verbose = false;   // -V: field tree with byte offsets under each frame
  bool show_time = true;  // false for `decode`, whose times are synthetic
  bool summary = true;
  bool frames = true;  // false: only the closing summary (e.g. with -w -)
  TimeFormat time_format = TimeFormat::relative;  // -t
  bool color = false;                             // --color: findings, checksums, events
  bool hex_dump = false;  // -x: each frame's bytes in full, offset, hex and ASCII lines (tshark's)
  // The capture's clock (origin, wall clock or not), which may be settled after the sink is made,
  // before its first record; nullptr: times shown as they are.
  const TimeReference* clock = nullptr;
};

// On cache lines of its own: the helpers of a ThreadedSink, one per thread, each write theirs for
// every record, and are made one after the other on the heap.
class alignas(kCacheLineBytes) TextSink final : public LineFormattingSink {
 public:
  TextSink(std::FILE* out, const ChannelTable& channels, TextSinkOptions options);
  void on_frame(const Message& message) override;
  void on_noise(const Frame& noise) override;
  void on_anomaly(const Anomaly& anomaly) override;
  void on_summary(const Stats& stats) override;
  void on_event(const BusEvent& event) override;
  void follow(std::uint64_t number) override { last_frame_number_ = number; }
  // The field tree is shown only with -V; transactions not at all: paired replies carry their
  // latency on the frame line, timeouts and unsolicited replies arrive as anomalies.
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n;
    n.fields = options_.verbose;
    n.transactions = false;
    n.drive_values = false;  // the annotation's text is all it shows of a drive
    return n;
  }

 private:
  // append_text_prefix() of a record of `channel`, its time in the -t format.
  std::string prefix(std::uint64_t number, TimeNs time, ChannelId channel) const;
  template <class Out>
  void append_prefix(Out& out, std::uint64_t number, TimeNs time, ChannelId channel) const;
  // -V: the frame's bytes and field tree with byte offsets.
  void write_field_tree(const Message& m);
  // The reference of the time column: the capture's clock and the previous record shown.
  [[nodiscard]] TimeReference time_reference() const;
  // A frame or noise record was shown at `time` (for -t d and dd).
  void note_record_time(TimeNs time) { previous_record_time_ = time; }

  const ChannelTable& channels_;
  TextSinkOptions options_;
  std::uint64_t last_frame_number_ = 0;
  TimeNs previous_record_time_ = -1;
};

// The start of every text line, appended to `out` (std::string or LineBuffer): the record's
// number right-aligned in 5 columns ("-" for none), its time in seconds with 6 decimals in 14
// (when `show_time`), the channel's name left-aligned in 3, each followed by a space:
// "   12       1.234567 bus ".
template <class Out>
void append_text_prefix(Out& out, std::uint64_t number, TimeNs time, bool show_time,
                        std::string_view channel);

// A noise record or -V frame shows at most this many bytes of hex, then how many more there are;
// -x gives them all.
inline constexpr std::size_t kShownHexBytes = 64;
// `bytes` as hex, cut after kShownHexBytes: "01 02 ... 3F … (+1234 bytes)".
std::string shown_hex(std::span<const std::uint8_t> bytes);
// tshark's -x dump of `bytes`: per 16 bytes, "0010  " (offset), the bytes in hex, and the bytes
// in ASCII ('.' for what does not print), each line led by `indent` and ended by '\n'.
std::string hex_dump(std::span<const std::uint8_t> bytes, std::string_view indent);

// The decode of a frame in one line, without number/time/channel: shared with the JSON
// `summary` key so both sinks say the same thing.
std::string frame_summary(const Message& message, bool with_latency = true);
// Out: std::string or LineBuffer (instantiated for both).
template <class Out>
void append_frame_summary(Out& out, const Message& message, bool with_latency = true);

}  // namespace drivetap
