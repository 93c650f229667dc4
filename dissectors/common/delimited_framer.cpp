// Start/end-character framer for the ASCII protocols (layout in delimited_framer.hpp).
#include "dissectors/common/delimited_framer.hpp"

#include <algorithm>
#include <limits>

namespace drivetap {

std::unique_ptr<Framer> make_delimited_framer(ChannelId channel, const FramerSettings& settings,
                                              std::uint8_t start, std::uint8_t end,
                                              std::size_t max_length) {
  DelimitedFramerOptions o;
  o.start = start;
  o.end = end;
  o.max_length = max_length;
  o.inter_character_timeout = std::max<TimeNs>(1 * kNsPerSecond, settings.timing.t35);
  o.character_time = settings.timing.character_time;
  return std::make_unique<DelimitedFramer>(channel, o);
}

void DelimitedFramer::close(FrameKind kind, FrameClose why, FrameBatch& out) {
  if (pending_.empty()) return;
  if (kind == FrameKind::telegram && pending_.size() < options_.min_length) kind = FrameKind::noise;
  Frame& f = out.add(kind, channel_, why);
  f.events.swap(pending_);  // pending_ continues in the storage of the frame that was there
  stamp_frame_timing(f, options_.character_time, &emitted_end_, &have_emitted_);
  in_frame_ = false;
}

void DelimitedFramer::push_byte(const ByteEvent& e, FrameBatch& out) {
  if (!pending_.empty() && e.time - last_end_ > options_.inter_character_timeout)
    close(in_frame_ ? FrameKind::telegram : FrameKind::noise, FrameClose::silence, out);
  if (e.byte == options_.start) {
    // Resynchronise: whatever came before the start character is closed first.
    close(in_frame_ ? FrameKind::telegram : FrameKind::noise, FrameClose::content, out);
    in_frame_ = true;
  }
  pending_.push_back(e);
  last_end_ = e.time + options_.character_time;
  if (in_frame_ && e.byte == options_.end) {
    close(FrameKind::telegram, FrameClose::content, out);
  } else if (pending_.size() >= options_.max_length) {
    close(in_frame_ ? FrameKind::telegram : FrameKind::noise, FrameClose::content, out);
  }
}

TimeNs DelimitedFramer::next_deadline() const {
  if (pending_.empty()) return std::numeric_limits<TimeNs>::max();
  return last_end_ + options_.inter_character_timeout + 1;
}

void DelimitedFramer::advance(TimeNs now, FrameBatch& out) {
  if (!pending_.empty() && now - last_end_ > options_.inter_character_timeout)
    close(in_frame_ ? FrameKind::telegram : FrameKind::noise, FrameClose::silence, out);
}

void DelimitedFramer::finish(FrameBatch& out) {
  close(in_frame_ ? FrameKind::telegram : FrameKind::noise, FrameClose::end_of_input, out);
}

}  // namespace drivetap
