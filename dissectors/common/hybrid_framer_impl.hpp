// Hybrid framer's member definitions: silence proposes boundaries, length rules and checksums
// confirm them (docs/protocols.md §1; algorithm in hybrid_framer.hpp). Included only by the sources
// that instantiate HybridFramer<Rules> (rtu_framer.cpp, fc_dissector.cpp).
#pragma once

#include "dissectors/common/hybrid_framer.hpp"

#include <algorithm>
#include <span>

namespace drivetap {

template <class Rules>
HybridFramer<Rules>::HybridFramer(ChannelId channel, HybridFramerOptions options,
                                  const Rules& rules)
    : channel_(channel), options_(options), rules_(rules) {}

template <class Rules>
void HybridFramer<Rules>::push_byte(const ByteEvent& event, FrameBatch& out) {
  if (!pending_.empty() || have_emitted_) {
    const TimeNs gap = event.time - last_end_;
    if (gap > options_.timing.t35) {
      if (!processed_since_last_byte_) process(Mode::silence, event.time, out);
      if (!pending_.empty()) hard_.push_back(pending_.size());
    }
  }
  if (pending_.empty()) {
    pending_run_.start(event.time, options_.timing.character_time);
    pending_run_whole_ = true;
  } else {
    pending_run_.add(event.time, pending_.size(), options_.timing.character_time);
  }
  pending_.push_back(event);
  last_end_ = std::max(last_end_, event.time + options_.timing.character_time);
  processed_since_last_byte_ = false;
  if (pending_.size() >= options_.pressure_bytes) process(Mode::pressure, event.time, out);
}

template <class Rules>
std::size_t HybridFramer<Rules>::push(std::span<const ByteEvent> events, FrameBatch& out) {
  if (events.size() == 1) {
    push_byte(events[0], out);
    return 1;
  }
  // Room for the longest run at once (the buffer only grows), so the scan stores each byte as it
  // passes it.
  if (run_bytes_.size() < events.size()) run_bytes_.resize(events.size());
  const std::span<std::uint8_t> bytes(run_bytes_);
  const std::size_t frames_before = out.size();
  std::size_t i = 0;
  // Every pass pushes at least the byte at i: evenly spaced, unmarked bytes (a byte log's line, a
  // packet) as one run, which push(run) appends in bulk where push() of each would only append.
  // A pass that closed frames is the last: they were closed by the byte at i - 1, or by the
  // silence before the byte at i.
  while (i < events.size() && out.size() == frames_before) {
    TimeNs step = 0;
    const std::size_t n = scan_uniform_run(
        events.subspan(i), &step, [bytes](std::size_t k, std::uint8_t b) { bytes[k] = b; });
    if (n == 1) {
      push_byte(events[i++], out);
      continue;
    }
    const ByteRun run{bytes.first(n),    events[i].time,   step,
                      events[i].channel, events[i].origin, {}};
    if (i + n < events.size()) {
      // What push() of the run's first byte does before anything else: after a silence, close
      // what is pending. Then the run may be a whole frame of its own.
      if (!pending_.empty() && !processed_since_last_byte_ &&
          run.first - last_end_ > options_.timing.t35) {
        process(Mode::silence, run.first, out);
        processed_since_last_byte_ = true;  // push() of the first byte must not process again
        if (out.size() != frames_before) {
          push_byte(events[i], out);  // the byte whose silence closed them
          return i + 1;
        }
      }
      // The run's frame is the one the silence before the next byte closes; push() of that byte
      // then only starts the next frame (the next call's first, which may take it whole).
      if (push_whole(run, events[i + n].time, out)) return i + n;
    }
    i += push(run, out);
  }
  return i;
}

template <class Rules>
bool HybridFramer<Rules>::take_whole(const ByteRun& run, TimeNs next_time, WholeFrame* taken,
                                     const TelegramPrecheck* precheck) {
  const TimeNs character_time = options_.timing.character_time;
  const TimeNs t35 = options_.timing.t35;
  const std::size_t n = run.size();
  // Nothing pending, and a run that push(run) would append in bulk (evenly spaced, no silence
  // inside, no UART marks, below the pressure mark) long enough to be a frame: pushing it and
  // then the byte at next_time, after a silence, has process() find it all that is pending, and
  // emit it whole when its predicted length is all of it with a good checksum (rule 1 at the
  // first position), closed by that silence. Anything else takes the usual way.
  if (!pending_.empty() || n < rules_.min_frame() || n + 1 >= options_.pressure_bytes ||
      run.step < 0 || run.step - character_time > t35 || !run.flags.empty())
    return false;
  const TimeNs end = std::max(last_end_, run.time(n - 1) + character_time);
  if (next_time - end <= t35) return false;
  // The check of the bytes, made ahead on the read-ahead thread when the run carries it.
  std::uint32_t checksum = 0;
  if (precheck) {
    if (!precheck->whole_frame) return false;
    checksum = precheck->checksum;
  } else if (!is_good_hybrid_frame(rules_, run.bytes, &checksum)) {
    return false;
  }
  taken->checksum_kind = rules_.checksum_kind();  // computed over exactly the frame's bytes
  taken->checksum = checksum;
  // The run's timing as push(run) would have kept it (not timing_of(): no second look).
  ByteRunTiming timing;
  timing.start(run.first, character_time);
  timing.add_stretch(run.first + run.step, run.step, 1, n - 1, character_time);
  taken->timing = stamp_timing(run.first, timing, &emitted_end_, &have_emitted_);
  last_end_ = end;
  processed_since_last_byte_ = true;  // nothing is pending: nothing to process at the silence
  return true;
}

template <class Rules>
bool HybridFramer<Rules>::push_whole(const ByteRun& run, TimeNs next_time, FrameBatch& out) {
  WholeFrame taken;
  if (!take_whole(run, next_time, &taken)) return false;
  add_whole_frame(out, channel_, run, taken);
  return true;
}

template <class Rules>
std::size_t HybridFramer<Rules>::push(const ByteRun& run, FrameBatch& out) {
  const std::size_t n = run.size();
  // Bytes further apart than t3.5 are silences inside the run, and bytes going back in time are
  // no run to append in bulk: those go byte by byte.
  if (n > 1 && (run.step < 0 || run.step - options_.timing.character_time > options_.timing.t35))
    return push_each(n, out, [&](std::size_t i) { push_byte(run.event(i), out); });
  const std::size_t frames_before = out.size();
  // The first byte goes the single-byte way when a silence > t3.5 comes before it (it may close
  // something); otherwise push() would only append it, as the rest.
  std::size_t i = 0;
  if (n > 0 && (!pending_.empty() || have_emitted_) &&
      run.first - last_end_ > options_.timing.t35) {
    push_byte(run.event(0), out);
    i = 1;
  }
  // Every pass takes at least one byte: in bulk up to the pressure mark, at the mark the
  // single-byte way (it closes what pressure closes, and then push() stops).
  while (i < n && out.size() == frames_before) {
    const std::size_t take = std::min(room_before_pressure(), n - i);
    if (take == 0) {
      push_byte(run.event(i), out);
      ++i;
      continue;
    }
    append_quietly(run, i, take);
    i += take;
  }
  return i;
}

template <class Rules>
inline void HybridFramer<Rules>::append_quietly(const ByteRun& run, std::size_t from,
                                                std::size_t count) {
  const TimeNs character_time = options_.timing.character_time;
  const ByteRun part = run.part(from, count);
  if (pending_.empty()) {
    pending_run_.start(part.first, character_time);
    pending_run_.add_stretch(part.first + part.step, part.step, 1, count - 1, character_time);
    pending_run_whole_ = true;
  } else {
    pending_run_.add_stretch(part.first, part.step, pending_.size(), count, character_time);
  }
  pending_.append_run(part);
  // step >= 0 (push(run)): the last byte ends last.
  last_end_ = std::max(last_end_, part.time(count - 1) + character_time);
  processed_since_last_byte_ = false;
}

template <class Rules>
TimeNs HybridFramer<Rules>::next_deadline() const {
  if (pending_.empty()) return std::numeric_limits<TimeNs>::max();
  if (!processed_since_last_byte_) return last_end_ + options_.timing.t35 + 1;
  return pending_.front_time() + options_.max_hold + 1;
}

template <class Rules>
void HybridFramer<Rules>::advance(TimeNs now, FrameBatch& out) {
  if (pending_.empty()) return;
  if (!processed_since_last_byte_) {
    if (now - last_end_ > options_.timing.t35) {
      process(Mode::silence, now, out);
      processed_since_last_byte_ = true;
    }
    return;
  }
  if (now - pending_.front_time() > options_.max_hold) process(Mode::flush, now, out);
}

template <class Rules>
void HybridFramer<Rules>::finish(FrameBatch& out) {
  if (!pending_.empty()) process(Mode::end_of_input, last_end_, out);
}

template <class Rules>
bool HybridFramer<Rules>::checksum_matches(std::size_t p, std::size_t len) const {
  if (len < rules_.min_frame() || p + len > pending_.size()) return false;
  return rules_.checksum_matches(pending_.bytes().subspan(p, len));
}

template <class Rules>
void HybridFramer<Rules>::predicted_lengths(std::size_t p, std::size_t n, std::size_t out[2],
                                            bool* needs_more) const {
  predicted_lengths_in(pending_.bytes().subspan(p, n - p), out, needs_more);
}

template <class Rules>
void HybridFramer<Rules>::predicted_lengths_in(std::span<const std::uint8_t> from,
                                               std::size_t out[2], bool* needs_more) const {
  out[0] = out[1] = 0;
  *needs_more = false;
  std::size_t candidates[2] = {0, 0};
  rules_.predicted_lengths(from, candidates, needs_more);
  int i = 0;
  for (std::size_t len : candidates) {
    if (len == 0 || len > rules_.max_frame()) continue;
    if (i == 0 || len != out[0]) out[i++] = len;
    if (len > from.size()) *needs_more = true;
  }
}

template <class Rules>
std::size_t HybridFramer<Rules>::good_frame_at(std::size_t p, std::size_t limit) const {
  return good_frame_in(pending_.bytes().subspan(p, limit - p));
}

template <class Rules>
std::size_t HybridFramer<Rules>::good_frame_in(std::span<const std::uint8_t> from) const {
  std::size_t lengths[2];
  bool needs_more = false;
  predicted_lengths_in(from, lengths, &needs_more);
  // A length that ends where the bytes end (a frame between two silences, the usual case) is
  // tried first: a reply's checksum is otherwise computed over the request's length first.
  if (lengths[1] != 0 && lengths[1] == from.size()) std::swap(lengths[0], lengths[1]);
  for (std::size_t len : lengths)
    if (len >= rules_.min_frame() && len <= from.size() && rules_.checksum_matches(from.first(len)))
      return len;
  return 0;
}

template <class Rules>
std::size_t HybridFramer<Rules>::first_good_start(std::size_t from, std::size_t to) const {
  const std::size_t n = pending_.size();
  for (std::size_t q = from; q < to; ++q)
    if (good_frame_at(q, n) != 0) return q;
  return to;
}

template <class Rules>
std::size_t HybridFramer<Rules>::next_hard_boundary(std::size_t p) const {
  auto it = std::upper_bound(hard_.begin(), hard_.end(), p);
  return it == hard_.end() ? pending_.size() : *it;
}

template <class Rules>
TimeNs HybridFramer<Rules>::silence_before(std::size_t index) const {
  if (index == 0 || index >= pending_.size()) return 0;
  return pending_.time(index) - (pending_.time(index - 1) + options_.timing.character_time);
}

template <class Rules>
bool HybridFramer<Rules>::is_hard_boundary(std::size_t index) const {
  return std::binary_search(hard_.begin(), hard_.end(), index);
}

template <class Rules>
bool HybridFramer<Rules>::looks_like_frame_start(std::size_t p) const {
  return rules_.looks_like_frame_start(pending_.bytes().subspan(p));
}

template <class Rules>
void HybridFramer<Rules>::emit(std::size_t p, std::size_t len, FrameKind kind, FrameClose close,
                               FrameBatch& out) {
  Frame& f = out.add(kind, channel_, close);
  const bool all_pending = p == 0 && len == pending_.size();
  // pending_run_ is the timing of exactly these bytes unless some were dropped before them.
  const bool timing_kept = all_pending && pending_run_whole_;
  if (all_pending) {
    // The frame is everything pending (the common case: one frame between two silences): it
    // takes pending_'s storage, and pending_ continues in the old frame's, saving a copy per byte.
    f.events.swap(pending_);
    // The run's timing goes with it; push() starts the next one (a byte appended in bulk to an
    // emptied buffer, after a pressure close, leaves the timing to be computed from the events).
    pending_run_whole_ = false;
    // Without old storage of some size, room for a typical frame at once rather than a doubling
    // series of allocations as its bytes arrive.
    if (pending_.capacity() < kPendingReserve) pending_.reserve(kPendingReserve);
  } else {
    f.events.append_range(pending_, p, len);
  }
  if (timing_kept)
    stamp_frame_timing(f, pending_run_, &emitted_end_, &have_emitted_);
  else
    stamp_frame_timing(f, options_.timing.character_time, &emitted_end_, &have_emitted_);
}

template <class Rules>
void HybridFramer<Rules>::process(Mode mode, TimeNs now, FrameBatch& out) {
  const std::size_t n = pending_.size();
  const bool end_is_boundary = mode != Mode::pressure;
  const bool may_hold = mode == Mode::silence || mode == Mode::pressure;
  const FrameClose end_close =
      mode == Mode::end_of_input ? FrameClose::end_of_input : FrameClose::silence;
  auto close_at = [&](std::size_t end) {
    if (end == n) return end_close;
    return is_hard_boundary(end) ? FrameClose::silence : FrameClose::content;
  };
  auto mostly_uart_errors = [&](std::size_t p, std::size_t end) {
    std::size_t flagged = 0;
    for (std::size_t i = p; i < end; ++i) flagged += pending_.flags(i) != 0;
    return flagged * 2 > end - p;
  };

  std::size_t p = 0;
  // Every iteration either advances p by at least one byte or leaves the loop.
  while (p < n) {
    const std::size_t chunk_end = next_hard_boundary(p);
    const bool chunk_closed = chunk_end < n || end_is_boundary;

    // 1. Predicted length with a good CRC (may span silences: split deliveries).
    if (const std::size_t len = good_frame_at(p, n); len != 0) {
      emit(p, len, FrameKind::telegram, close_at(p + len), out);
      p += len;
      continue;
    }
    // 2. The whole timing chunk has a good CRC (variable or unknown layout).
    if (chunk_closed && checksum_matches(p, chunk_end - p)) {
      emit(p, chunk_end - p, FrameKind::telegram, close_at(chunk_end), out);
      p = chunk_end;
      continue;
    }
    std::size_t lengths[2];
    bool needs_more = false;
    predicted_lengths(p, n, lengths, &needs_more);
    // 3. An incomplete frame at the end: wait for the rest (split by adapter latency). Also when
    //    one layout ends right at the silence: its checksum failed (rule 1), and the other
    //    layout's longer frame may be what the rest of the read completes (a reply cut where a
    //    request would end). Silence proposes, content decides: a bad frame of the layout that
    //    fits is still cut there (rule 4) when the rest does not make a good one.
    if (may_hold && needs_more && chunk_end == n && n - p < rules_.max_frame() &&
        looks_like_frame_start(p) && now - pending_.time(p) <= options_.max_hold &&
        first_good_start(p + 1, n) == n) {
      break;
    }
    // 3b. Unknown layout inside a burst: the first checksum match that a good frame follows.
    if (lengths[0] == 0 && lengths[1] == 0 && !needs_more && looks_like_frame_start(p)) {
      const std::size_t found = rules_.scan_unknown_layout(
          pending_.bytes().subspan(p, chunk_end - p),
          [&](std::size_t len) { return p + len == chunk_end || good_frame_at(p + len, n) != 0; });
      if (found != 0 && (p + found < chunk_end || chunk_closed)) {
        emit(p, found, FrameKind::telegram, close_at(p + found), out);
        p += found;
        continue;
      }
    }
    // 4. Predicted length with a bad CRC, confirmed by a silence (> t1.5 counts: a gap that long
    //    inside a frame is itself a fault) or a good frame right after.
    std::size_t confirmed = 0;
    for (std::size_t len : lengths) {
      if (len == 0 || p + len > chunk_end) continue;
      if ((p + len == chunk_end && chunk_closed) || silence_before(p + len) > options_.timing.t15 ||
          good_frame_at(p + len, n) != 0) {
        confirmed = len;
        break;
      }
    }
    // A good frame starting inside the would-be bad one is stronger evidence (noise before it).
    if (confirmed != 0 && looks_like_frame_start(p) &&
        first_good_start(p + 1, p + confirmed) == p + confirmed) {
      emit(p, confirmed, FrameKind::telegram, close_at(p + confirmed), out);
      p += confirmed;
      continue;
    }
    // 5. Bytes before the next good frame inside this chunk are noise.
    if (const std::size_t q = first_good_start(p + 1, chunk_end); q < chunk_end) {
      emit(p, q - p, FrameKind::noise, FrameClose::content, out);
      p = q;
      continue;
    }
    // 6. Nothing good in the chunk.
    if (!chunk_closed) {
      // Under pressure without silence: give up on all but one frame's worth of bytes.
      if (n - p > rules_.max_frame()) {
        emit(p, n - rules_.max_frame() - p, FrameKind::noise, FrameClose::content, out);
        p = n - rules_.max_frame();
      }
      break;
    }
    const bool telegram = chunk_end - p >= rules_.min_frame() && !mostly_uart_errors(p, chunk_end);
    emit(p, chunk_end - p, telegram ? FrameKind::telegram : FrameKind::noise, close_at(chunk_end),
         out);
    p = chunk_end;
  }

  // Drop what was emitted; shift the boundary marks.
  if (p > 0) {
    // emit() took all of pending_ when its last frame covered it (pending_ is then empty).
    const bool all = pending_.empty() || p == pending_.size();
    if (!pending_.empty()) {
      pending_.erase_front(p);
      pending_run_whole_ = false;  // pending_run_ also covers the bytes just dropped
    }
    if (all) {
      hard_.clear();  // every mark is at or before p
    } else {
      std::vector<std::size_t> kept;
      for (std::size_t h : hard_)
        if (h > p) kept.push_back(h - p);
      hard_ = std::move(kept);
    }
  }
}

}  // namespace drivetap
