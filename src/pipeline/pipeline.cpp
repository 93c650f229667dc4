// Pipeline wiring of the stages (PROTOCOLS.md §1-§2, §7).
#include "pipeline/pipeline.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>

namespace drivetap {

struct Pipeline::ChannelState {
  ChannelState(ChannelId id, const ProtocolDecoder& d, const FramerSettings& s)
      : decoder(&d), framer(d.make_framer(id, s)) {}
  const ProtocolDecoder* decoder;
  std::unique_ptr<Framer> framer;
  TimeNs last_end = std::numeric_limits<TimeNs>::min();
  std::uint32_t last_frame_origin = 0;       // packet the previous frame ended in
  std::uint32_t reported_merged_origin = 0;  // packet already reported as holding several frames
  std::uint64_t last_frame_number = 0;
};

Pipeline::Pipeline(PipelineOptions options, const ChannelTable& channels, Sink& sink)
    : options_(options),
      channels_(channels),
      sink_(sink),
      pairer_(PairerOptions{options.reply_timeout, options.timing.character_time, 64}),
      earliest_deadline_(std::numeric_limits<TimeNs>::max()) {}

Pipeline::~Pipeline() = default;

Pipeline::ChannelState& Pipeline::state_for(ChannelId id) {
  while (states_.size() <= id) {
    const FramerSettings s{options_.timing, options_.max_hold};
    states_.push_back(std::make_unique<ChannelState>(static_cast<ChannelId>(states_.size()),
                                                     *decoder_for(options_.protocol), s));
  }
  return *states_[id];
}

void Pipeline::advance_all(TimeNs now) {
  if (now < earliest_deadline_) return;
  earliest_deadline_ = std::numeric_limits<TimeNs>::max();
  for (auto& s : states_) {
    s->framer->advance(now, ready_);
    earliest_deadline_ = std::min(earliest_deadline_, s->framer->next_deadline());
  }
  handle_frames();
}

void Pipeline::push(const ByteEvent& in) {
  ByteEvent e = in;
  ChannelState& st = state_for(e.channel);
  // Bytes on one wire cannot overlap: a byte stamped inside its predecessor starts after it.
  if (e.time < st.last_end) e.time = st.last_end;
  st.last_end = e.time + options_.timing.character_time;
  advance_all(e.time);
  st.framer->push(e, ready_);
  earliest_deadline_ = std::min(earliest_deadline_, st.framer->next_deadline());
  if (!ready_.empty()) handle_frames();
}

void Pipeline::report(const Anomaly& anomaly) {
  emit_anomaly(anomaly);
}

void Pipeline::emit_anomaly(const Anomaly& a) {
  stats_.count_anomaly(a);
  sink_.on_anomaly(a);
}

void Pipeline::handle_frames() {
  if (ready_.empty()) return;
  // Frames closed together (several channels) go out in order of their first byte.
  std::stable_sort(ready_.begin(), ready_.end(),
                   [](const Frame& a, const Frame& b) { return a.start() < b.start(); });
  std::vector<Frame> batch;
  batch.swap(ready_);
  for (Frame& f : batch) handle_frame(f);
}

Direction Pipeline::decide_direction(const ProtocolDecoder& decoder, const Frame& frame,
                                     std::span<const std::uint8_t> bytes, int address, int function,
                                     std::size_t link) const {
  switch (channels_.at(frame.channel).role) {
    case ChannelRole::master:
      return Direction::request;
    case ChannelRole::slave:
      return Direction::response;
    case ChannelRole::bus:
      break;
  }
  if (bytes.size() < 2) return Direction::unknown;
  if (decoder.always_response(bytes)) return Direction::response;
  const DirectionFit fit = decoder.direction_fit(bytes);
  if (fit.request != fit.response) return fit.request ? Direction::request : Direction::response;
  // Both layouts fit (echo replies, acknowledgements of the same size) or neither does: order
  // decides — a reply is what a pending request of the same station and function awaits.
  if (pairer_.awaiting_reply(link, address, function, frame.start())) return Direction::response;
  if (fit.request) return Direction::request;
  if (!decoder.recognisable(bytes)) return Direction::unknown;
  return Direction::request;
}

void Pipeline::check_packetization(const Frame& frame) {
  // Only sources with packets (origin != 0) are checked: a good capture tool puts exactly one
  // frame in each packet; drivetap re-frames anyway and says where the tool did not.
  const std::uint32_t first = frame.events.front().origin;
  const std::uint32_t last = frame.events.back().origin;
  if (first == 0) return;
  ChannelState& st = state_for(frame.channel);
  const char* what = frame.kind == FrameKind::noise ? "noise record" : "frame";
  if (first != last) {
    emit_anomaly({AnomalyKind::packet_split_frame, frame.start(), frame.channel, frame.number,
                  fmt::format("{} #{} spans packets {}..{}", what, frame.number, first, last)});
  }
  if (first == st.last_frame_origin && st.reported_merged_origin != first) {
    emit_anomaly({AnomalyKind::packet_merged_frames, frame.start(), frame.channel, frame.number,
                  fmt::format("packet {} holds more than one frame (#{} and #{})", first,
                              st.last_frame_number, frame.number)});
    st.reported_merged_origin = first;
  }
  st.last_frame_origin = last;
  st.last_frame_number = frame.number;
}

void Pipeline::handle_frame(Frame& frame) {
  frame.number = ++frame_counter_;
  const std::size_t link = channels_.link_index(frame.channel);
  if (frame.kind == FrameKind::noise) {
    pairer_.expire(frame.start(), transactions_);
    emit_transactions(transactions_);
    stats_.count_noise(frame);
    sink_.on_noise(frame);
    std::string hex;
    for (std::size_t i = 0; i < frame.events.size() && i < 16; ++i)
      hex += fmt::format("{}{:02X}", i ? " " : "", frame.events[i].byte);
    if (frame.events.size() > 16) hex += " ...";
    emit_anomaly({AnomalyKind::noise, frame.start(), frame.channel, frame.number,
                  fmt::format("{} byte{} outside any frame: {}", frame.size(),
                              frame.size() == 1 ? "" : "s", hex)});
    std::vector<Anomaly> uart;
    append_uart_anomalies(frame.events, frame.number, uart);
    for (const Anomaly& a : uart) emit_anomaly(a);
    check_packetization(frame);
    return;
  }
  pairer_.expire(frame.start(), transactions_);
  emit_transactions(transactions_);

  const ProtocolDecoder& decoder = *state_for(frame.channel).decoder;
  const std::vector<std::uint8_t> bytes = frame.bytes();
  const ProtocolDecoder::PairingKeys keys = decoder.pairing_keys(bytes);
  const Direction dir = decide_direction(decoder, frame, bytes, keys.address, keys.function, link);
  Message m = decoder.dissect(std::move(frame), dir, options_.timing);
  pairer_.add(link, m, transactions_);
  for (Anomaly& a : m.anomalies) a.frame_number = m.frame.number;
  stats_.count_frame(m);
  sink_.on_frame(m);
  for (const Anomaly& a : m.anomalies) emit_anomaly(a);
  check_packetization(m.frame);
  emit_transactions(transactions_);
}

void Pipeline::emit_transactions(std::vector<Transaction>& transactions) {
  for (const Transaction& t : transactions) {
    stats_.count_transaction(t);
    sink_.on_transaction(t);
    if (t.outcome == Outcome::timeout) {
      emit_anomaly({AnomalyKind::unanswered_request, t.request_time, t.channel, t.request_number,
                    fmt::format("request #{} to address {}{}: {}", t.request_number, t.address,
                                t.function < 0 ? "" : fmt::format(" function {:02X}", t.function),
                                t.detail)});
    } else if (t.outcome == Outcome::unsolicited) {
      emit_anomaly({AnomalyKind::unsolicited_response, t.response_time, t.channel,
                    t.response_number,
                    fmt::format("reply #{} from address {}{}: {}", t.response_number, t.address,
                                t.function < 0 ? "" : fmt::format(" function {:02X}", t.function),
                                t.detail)});
    }
  }
  transactions.clear();
}

void Pipeline::finish() {
  if (finished_) return;
  finished_ = true;
  for (auto& s : states_) s->framer->finish(ready_);
  handle_frames();
  pairer_.finish(transactions_);
  emit_transactions(transactions_);
  sink_.on_summary(stats_);
}

}  // namespace drivetap
