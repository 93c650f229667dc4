// Text sink: one annotated line per frame, -V field trees, and the closing summary. Lines are
// gathered in a buffer and written in blocks (to a terminal, line by line); flush() writes what
// is buffered.
#pragma once

#include <cstdio>
#include <string>

#include "core/byte_event.hpp"
#include "core/line_buffer.hpp"
#include "core/serial_config.hpp"
#include "sinks/line_writer.hpp"
#include "sinks/sink.hpp"

namespace drivetap {

struct TextSinkOptions {
  bool verbose = false;   // -V: field tree with byte offsets under each frame
  bool show_time = true;  // false for `decode`, whose times are synthetic
  bool summary = true;
  bool frames = true;  // false: only the closing summary (e.g. with -w -)
};

// On cache lines of its own: the helpers of a ThreadedSink, one per thread, each write theirs for
// every record, and are made one after the other on the heap.
class alignas(kCacheLineBytes) TextSink final : public FormattingSink {
 public:
  TextSink(std::FILE* out, const ChannelTable& channels, TextSinkOptions options);
  void on_frame(const Message& message) override;
  void on_noise(const Frame& noise) override;
  void on_anomaly(const Anomaly& anomaly) override;
  void on_transaction(const Transaction& transaction) override;
  void on_summary(const Stats& stats) override;
  void on_event(const BusEvent& event) override;
  bool flush() override;
  // Made with no file (nullptr): writes into memory, for a ThreadedSink's helpers
  // (FormattingSink, sink.hpp).
  LineBuffer* formatted() override { return lines_.gathered(); }
  void write_formatted(std::string_view text) override { lines_.write_lines(text); }
  void follow(std::uint64_t number) override { last_frame_number_ = number; }
  // The field tree is shown only with -V; transactions not at all (see on_transaction).
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n;
    n.fields = options_.verbose;
    n.transactions = false;
    return n;
  }

 private:
  // append_text_prefix() of a record of `channel`.
  std::string prefix(std::uint64_t number, TimeNs time, ChannelId channel) const;

  const ChannelTable& channels_;
  TextSinkOptions options_;
  std::uint64_t last_frame_number_ = 0;
  LineWriter lines_;  // lines not written yet (flush() writes them); frame lines are built there
};

// The start of every text line, appended to `out` (std::string or LineBuffer): the record's
// number right-aligned in 5 columns ("-" for none), its time in seconds with 6 decimals in 14
// (when `show_time`), the channel's name left-aligned in 3, each followed by a space:
// "   12       1.234567 bus ".
template <class Out>
void append_text_prefix(Out& out, std::uint64_t number, TimeNs time, bool show_time,
                        std::string_view channel);

// The decode of a frame in one line, without number/time/channel: shared with the JSON
// `summary` key so both sinks say the same thing.
std::string frame_summary(const Message& message, bool with_latency = true);
// Out: std::string or LineBuffer (instantiated for both).
template <class Out>
void append_frame_summary(Out& out, const Message& message, bool with_latency = true);

}  // namespace drivetap
