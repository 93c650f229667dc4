// Framer for ASCII protocols delimited by a start and an end character: Modbus ASCII
// (':' ... CR LF, docs/protocols.md §3) and the Easydrive protocol ('~' ... CR, §5).
//
//   noise ... | start | body ... | end |  noise ... | start | body ...
//
// A start character always begins a new frame (resynchronisation): an unfinished frame before it
// is closed as cut. A frame also closes when it reaches the maximum length or when a silence
// longer than the inter-character timeout interrupts it. Bytes outside frames are noise records.
#pragma once

#include <cstdint>
#include <vector>

#include <memory>

#include "core/framer.hpp"
#include "core/protocol.hpp"

namespace drivetap {

struct DelimitedFramerOptions {
  std::uint8_t start = ':';
  std::uint8_t end = '\n';
  std::size_t max_length = 513;
  std::size_t min_length = 2;  // a cut "frame" shorter than this (a lone start character) is noise
  TimeNs inter_character_timeout = 1 * kNsPerSecond;  // Modbus ASCII's default
  TimeNs character_time = 0;
};

// A delimited framer for an ASCII protocol: the Modbus ASCII inter-character timeout (1 s, or t3.5
// when longer) and the line's character time.
std::unique_ptr<Framer> make_delimited_framer(ChannelId channel, const FramerSettings& settings,
                                              std::uint8_t start, std::uint8_t end,
                                              std::size_t max_length);

class DelimitedFramer final : public Framer {
 public:
  DelimitedFramer(ChannelId channel, DelimitedFramerOptions options)
      : channel_(channel), options_(options) {}
  using Framer::push;
  std::size_t push(std::span<const ByteEvent> events, FrameBatch& out) override {
    return push_each(events.size(), out, [&](std::size_t i) { push_byte(events[i], out); });
  }
  void advance(TimeNs now, FrameBatch& out) override;
  void finish(FrameBatch& out) override;
  [[nodiscard]] TimeNs next_deadline() const override;

 private:
  void push_byte(const ByteEvent& event, FrameBatch& out);
  void close(FrameKind kind, FrameClose why, FrameBatch& out);

  ChannelId channel_;
  DelimitedFramerOptions options_;
  ByteEvents pending_;
  bool in_frame_ = false;
  TimeNs last_end_ = 0;
  TimeNs emitted_end_ = 0;
  bool have_emitted_ = false;
};

}  // namespace drivetap
