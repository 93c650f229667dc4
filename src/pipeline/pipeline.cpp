// Pipeline wiring of the stages (docs/protocols.md §1-§2, §7).
#include "pipeline/pipeline.hpp"

#include "dissectors/common/plausibility.hpp"
#include "drive/annotate.hpp"
#include "drive/drive_fields.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <limits>

namespace drivetap {

namespace {

constexpr std::size_t kDetectBytes = 2048;     // most bytes held before deciding anyway
constexpr std::size_t kDetectEvery = 128;      // re-evaluate after this many more bytes
constexpr int kDetectGoodFrames = 3;           // never decide on one lucky checksum
constexpr int kRedetectFailures = 8;           // bad telegrams/noise in a row: the bus changed?
constexpr int kMaxRedetectFailures = 8 << 12;  // the back-off's ceiling on a line of noise
// Detection decides at the latest this long after the first byte it holds (on the evidence so
// far): frames of other channels wait for it (docs/reference.md "Order of the output").
constexpr TimeNs kDetectHold = 1 * kNsPerSecond;
// The reorder stage's bounds: a closed frame waits at most this long (bus time, after the latest
// byte seen) or behind this many others for an earlier frame of another channel; past them it is
// handed on, even if an earlier frame comes later (an open frame held longer than its framer's
// own bounds: a line without silence). Memory: the frames of kMaxReorderHold of traffic.
constexpr TimeNs kMaxReorderHold = 2 * kNsPerSecond;
constexpr std::size_t kMaxWaitingFrames = std::size_t{1} << 16;
constexpr TimeNs kNoneHeld = std::numeric_limits<TimeNs>::max();

// A candidate protocol while a channel's protocol is being detected: its framer and its counts so
// far. Each held byte is fed once, so that detection costs a few framings of the held bytes, not
// one per evaluation.
struct DetectionCandidate {
  const ProtocolDecoder* decoder = nullptr;
  std::unique_ptr<Framer> framer;
  int good = 0;  // good checksum and plausible (good_telegram())
  int telegrams = 0;
  // Good request/reply pairs: a good telegram whose layout fits a reply right after a good one of
  // the same station and function whose layout fits a request.
  int pairs = 0;
  bool after_request = false;
  ProtocolDecoder::PairingKeys request_keys;
};

// What a line carries when no drive protocol fits it, in a few words: "56 bytes of printable
// ASCII text", "600 bytes of constant 0x00", "2048 random-looking bytes".
std::string describe_line(std::span<const ByteEvent> held) {
  std::size_t printable = 0, marked = 0;
  bool constant = true;
  for (const ByteEvent& e : held) {
    const std::uint8_t b = e.byte;
    if ((b >= 0x20 && b < 0x7F) || b == '\r' || b == '\n' || b == '\t') ++printable;
    if ((e.flags & kUartErrorFlags) != 0) ++marked;
    if (b != held.front().byte) constant = false;
  }
  std::string what;
  if (constant)
    what = fmt::format(FMT_COMPILE("{} byte{} of constant 0x{:02X}"), held.size(),
                       held.size() == 1 ? "" : "s", held.front().byte);
  else if (printable * 20 >= held.size() * 19)  // text, with the odd line-noise byte
    what = fmt::format(FMT_COMPILE("{} bytes of printable ASCII text"), held.size());
  else
    what = fmt::format(FMT_COMPILE("{} random-looking bytes"), held.size());
  if (marked > 0) what += fmt::format(FMT_COMPILE(" ({} with UART errors or breaks)"), marked);
  return what;
}

}  // namespace

struct Pipeline::ChannelState {
  // With a fixed protocol the framer exists from the start; in "auto" mode the channel first
  // holds its bytes until detect() has chosen the protocol.
  const ProtocolDecoder* decoder = nullptr;
  std::unique_ptr<Framer> framer;
  bool auto_protocol = false;
  std::vector<ByteEvent> held;  // bytes waiting for detection (bounded by kDetectBytes)
  // The first byte taken (held for detection or handed to the framer) that is in no emitted frame
  // yet, or a lower bound of it; kNoneHeld when there is none. No frame of the channel can start
  // earlier: frames of other channels that do wait (the reorder stage).
  TimeNs unframed_from = kNoneHeld;
  // Detection had too little evidence at its deadline (kDetectHold): it goes on listening (to
  // kDetectBytes or the end) but no longer holds the other channels' frames back.
  bool detection_overdue = false;

  // Whether a frame cut by `d` counts towards re-detection: in "auto" mode, when the channel still
  // uses that decoder (a frame that waited in the reorder stage may come after its channel
  // started detecting afresh).
  [[nodiscard]] bool detection_reads(const ProtocolDecoder& d) const {
    return auto_protocol && decoder == &d;
  }
  std::size_t evaluated_at = 0;                // held.size() at the last evaluation
  std::vector<DetectionCandidate> candidates;  // while detecting: one per protocol
  int failures = 0;  // consecutive bad telegrams / noise since the last good one
  // Failures in a row that start detection afresh. Each detection that finds no clear protocol
  // doubles it (a line of noise would otherwise be detected over and over); a clear one resets it.
  int redetect_after = kRedetectFailures;
  bool redetect = false;
  TimeNs last_end = std::numeric_limits<TimeNs>::min();
  std::uint32_t last_frame_origin = 0;       // packet the previous frame ended in
  std::uint32_t reported_merged_origin = 0;  // packet already reported as holding several frames
  std::uint64_t last_frame_number = 0;
  ChannelRole role = ChannelRole::bus;  // the channel's, looked up once
  std::size_t link = 0;                 // the channel's link index, looked up once
  // An IP flow (Channel::ip_flow) on which detection found no drive protocol: its bytes are
  // counted, not decoded (a note in the summary says so).
  bool ip_flow = false;
  bool left_out = false;
  // Detection found no drive protocol on this serial line: its bytes, still cut by silence, are
  // noise records (raw data), never telegrams of a protocol they are not (no pairing, no drive).
  bool no_protocol = false;
  // The source found that this channel's times carry no inter-frame silence (distrust_silences()).
  bool silences_trusted = true;
  std::uint64_t left_out_bytes = 0;
};

Pipeline::Pipeline(PipelineOptions options, const ChannelTable& channels, Sink& sink)
    : options_(options),
      channels_(channels),
      sink_(sink),
      pairer_(
          PairerOptions{options.reply_timeout, options.timing.character_time, 64, options.clocked}),
      earliest_deadline_(std::numeric_limits<TimeNs>::max()),
      binder_(options.auto_candidates) {
  const SinkNeeds needs = sink.needs();
  message_.detail = needs.detail;
  message_.tree = needs.detail && needs.fields;
  message_.info_text = needs.detail && needs.info_text;
  hand_over_transactions_ = needs.transactions;
  defer_drive_info_ = needs.detail && needs.drive_info;
  hand_over_records_ = needs.records;
  hand_over_events_ = needs.events;
  hand_over_drive_values_ = needs.drive_values;
  drive_values_at_hand_over_ = needs.drive_values && needs.drive_values_at_hand_over;
  drive_level_ = !options_.drives.empty() || !options_.auto_candidates.empty();
  untrusted_timing_ = options_.timing;
  untrusted_timing_.silences_trusted = false;
  // With drive profiles, a sink that takes records must write their annotation itself
  // (defer_drive_info_): only the observation is made here. (Without detail, a Message still
  // carries the text an observation makes of an exception reply.)
  whole_telegrams_direct_ =
      (!hand_over_records_ || (needs.deferred_decode && (!drive_level_ || defer_drive_info_))) &&
      options_.max_frames == 0;
  // The sink may read the profiles on its own thread: their lookup tables are built here, before
  // it gets any message (after this they are only read).
  for (const auto& [address, profile] : options_.drives) profile->build_index();
  for (const DriveProfile* profile : options_.auto_candidates) profile->build_index();
}

Pipeline::~Pipeline() = default;

void Pipeline::distrust_silences(ChannelId channel) {
  state_for(channel).silences_trusted = false;
}

Pipeline::ChannelState& Pipeline::state_for(ChannelId id) {
  while (states_.size() <= id) {
    auto st = std::make_unique<ChannelState>();
    const ProtocolDecoder* fixed = decoder_for(options_.protocol);
    if (fixed) {
      st->decoder = fixed;
      st->framer = fixed->make_framer(static_cast<ChannelId>(states_.size()),
                                      {options_.timing, options_.max_hold});
    } else {
      st->auto_protocol = true;
    }
    const auto channel = static_cast<ChannelId>(states_.size());
    if (channel < channels_.size()) {
      st->role = channels_.at(channel).role;
      st->link = channels_.link_index(channel);
      st->ip_flow = channels_.at(channel).ip_flow;
    }
    states_.push_back(std::move(st));
  }
  return *states_[id];
}

void Pipeline::advance_all(TimeNs now) {
  if (now < earliest_deadline_) return;
  earliest_deadline_ = std::numeric_limits<TimeNs>::max();
  for (std::size_t i = 0; i < states_.size(); ++i) {
    ChannelState& s = *states_[i];
    if (!s.framer) {  // detecting: by kDetectHold after its first byte it decides if it can
      if (s.held.empty() || s.detection_overdue) continue;
      const TimeNs due = s.held.front().time + kDetectHold;
      if (now < due) {
        earliest_deadline_ = std::min(earliest_deadline_, due);
        continue;
      }
      detect(s, static_cast<ChannelId>(i), now, false, true);
      if (!s.framer) continue;  // still listening (overdue), or an IP flow left out
    }
    s.framer->advance(now, ready_);
    earliest_deadline_ = std::min(earliest_deadline_, s.framer->next_deadline());
  }
  handle_frames();
}

ByteEvent Pipeline::as_on_the_wire(ByteEvent e, TimeNs last_end) const {
  // With 7 data bits the 8th bit a source may deliver is not data (Modbus ASCII allows 7E1).
  if (options_.serial.data_bits == 7) e.byte &= 0x7F;
  // Bytes on one wire cannot overlap: a byte stamped inside its predecessor starts after it.
  if (e.time < last_end) e.time = last_end;
  return e;
}

void Pipeline::note_taken(ChannelState& st, const ByteEvent& e) {
  st.last_end = e.time + options_.timing.character_time;
  latest_time_ = std::max(latest_time_, e.time);
}

void Pipeline::push(const ByteEvent& in) {
  ChannelState& st = state_for(in.channel);
  const ByteEvent e = as_on_the_wire(in, st.last_end);
  note_taken(st, e);
  advance_all(e.time);
  frame_byte(st, e);
}

void Pipeline::frame_byte(ChannelState& st, const ByteEvent& e) {
  if (st.left_out) {
    ++st.left_out_bytes;
    return;
  }
  if (st.redetect) start_detection(st);
  if (st.unframed_from == kNoneHeld) st.unframed_from = e.time;
  if (!st.framer) {
    if (st.held.empty()) earliest_deadline_ = std::min(earliest_deadline_, e.time + kDetectHold);
    st.held.push_back(e);
    detect(st, e.channel, e.time, false);
    if (!ready_.empty()) handle_frames();
    return;
  }
  st.framer->push(e, ready_);
  earliest_deadline_ = std::min(earliest_deadline_, st.framer->next_deadline());
  if (!ready_.empty()) handle_frames();
}

const ProtocolDecoder* Pipeline::precheck_decoder_of(ChannelId channel) const {
  if (!whole_telegrams_direct_ || hand_over_records_ || channel >= states_.size()) return nullptr;
  const ChannelState& st = *states_[channel];
  return st.framer && !st.redetect ? st.decoder : nullptr;
}

inline TimeNs Pipeline::deadline_of_others(ChannelId channel) const {
  TimeNs earliest = std::numeric_limits<TimeNs>::max();
  for (std::size_t i = 0; i < states_.size(); ++i) {
    if (i == channel) continue;
    const ChannelState& s = *states_[i];
    if (s.framer)
      earliest = std::min(earliest, s.framer->next_deadline());
    else if (!s.held.empty() && !s.detection_overdue)  // (detection's deadline, advance_all())
      earliest = std::min(earliest, s.held.front().time + kDetectHold);
  }
  return earliest;
}

void Pipeline::push_batch(std::span<const ByteEvent> events) {
  std::size_t i = 0;
  // Each pass pushes at least events[i].
  while (i < events.size()) {
    const ChannelId channel = events[i].channel;
    push(events[i++]);  // the byte-by-byte way: it may close frames, detect, re-detect
    ChannelState& st = *states_[channel];
    if (i == events.size() || !st.framer || st.redetect || !ready_.empty()) continue;
    // What follows on the same channel with no silence > t3.5 before it and before any other
    // channel's deadline goes to the framer at once: push() of each would only frame it
    // (advance_all() has nothing due). The framer stops after a byte that closed frames; they
    // are handled, and the next byte goes the byte-by-byte way.
    const TimeNs others = deadline_of_others(channel);
    const std::size_t run_begin = i;
    // The run goes to the framer as given while as_on_the_wire() changes none of its bytes (the
    // usual case); from the first it changes, the run is copied into run_ and adjusted there.
    bool as_given = true;
    TimeNs last_end = st.last_end;
    // Each pass takes one byte into the run, or stops.
    while (i < events.size() && events[i].channel == channel) {
      const ByteEvent e = as_on_the_wire(events[i], last_end);
      if (e.time - last_end > options_.timing.t35 || e.time >= others) break;
      last_end = e.time + options_.timing.character_time;
      if (as_given && (e.time != events[i].time || e.byte != events[i].byte)) {
        as_given = false;
        run_.assign(events.begin() + static_cast<std::ptrdiff_t>(run_begin),
                    events.begin() + static_cast<std::ptrdiff_t>(i));
      }
      if (!as_given) run_.push_back(e);
      ++i;
    }
    if (i == run_begin) continue;
    const std::span<const ByteEvent> run =
        as_given ? events.subspan(run_begin, i - run_begin) : std::span(run_);
    if (st.unframed_from == kNoneHeld) st.unframed_from = run.front().time;
    const std::size_t taken = st.framer->push(run, ready_);
    note_taken(st, run[taken - 1]);  // (times only grow along the run)
    i = run_begin + taken;
    earliest_deadline_ = std::min(earliest_deadline_, st.framer->next_deadline());
    if (!ready_.empty()) handle_frames();
  }
}

void Pipeline::push_runs(const RunBatch& runs) {
  // (A chunk without prechecks, all but --stats's, takes a loop that does not look for them.)
  if (runs.has_prechecks())
    push_runs_as<true>(runs);
  else
    push_runs_as<false>(runs);
}

template <bool Prechecked>
void Pipeline::push_runs_as(const RunBatch& runs) {
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const ByteRun run = runs[k];
    // The next run on the same channel tells whether this one is followed by a silence. Runs of
    // other channels may lie between them (a request and its reply, flagged as two directions)
    // when each starts after that silence: byte by byte, the frame would be closed and handled
    // before their first byte.
    const std::size_t last = std::min(runs.size(), k + 1 + kWholeRunLookAhead);
    std::size_t next = k + 1;
    if (next < last && runs[next].channel != run.channel && run.size() != 0) {
      const TimeNs closed =
          run.time(run.size() - 1) + options_.timing.character_time + options_.timing.t35;
      while (next < last && runs[next].channel != run.channel && runs[next].first > closed) ++next;
    }
    if (next < last && runs[next].channel == run.channel &&
        push_whole(run, runs[next].first, Prechecked ? runs.precheck(k) : nullptr))
      continue;
    push_run(run);
  }
}

inline bool Pipeline::push_whole(const ByteRun& run, TimeNs next_time,
                                 const TelegramPrecheck* precheck) {
  const TimeNs character_time = options_.timing.character_time;
  // push() of each byte would take them as they are: as_on_the_wire() changes none (8 data bits;
  // each starts after the end of the one before).
  if (run.size() < 2 || !run.flags.empty() || options_.serial.data_bits == 7 ||
      run.step < character_time || run.channel >= states_.size())
    return false;
  ChannelState& st = *states_[run.channel];
  if (!st.framer || st.redetect || st.no_protocol || run.first < st.last_end) return false;
  // The first byte as push() takes it, up to framing it: time moves on, which closes what its
  // silence closed (on any channel).
  const ByteEvent first = run.event(0);
  note_taken(st, first);
  advance_all(first.time);
  // The framer may emit the run as the frame that the byte at next_time would close, when no
  // other channel holds bytes (the next byte closes nothing of theirs, as it would not) and
  // nothing asks for the byte-by-byte way.
  if (!st.redetect && st.framer &&
      deadline_of_others(run.channel) == std::numeric_limits<TimeNs>::max()) {
    // A sink that takes no records, or decodes them itself, has the telegram handled here at
    // once, not decoded in detail (ready_ is empty: the frame would be handled alone; frames
    // waiting start earlier and go first, through the reorder stage).
    const bool direct = whole_telegrams_direct_ && ready_.empty() && waiting_.empty();
    // The run's precheck is used only when the channel's decoder made it (TelegramPrecheck).
    if (precheck && precheck->decoder != st.decoder) precheck = nullptr;
    Framer::WholeFrame taken;
    if (st.framer->take_whole(run, next_time, &taken, direct ? precheck : nullptr)) {
      note_taken(st, run.event(run.size() - 1));
      earliest_deadline_ = std::min(earliest_deadline_, st.framer->next_deadline());
      if (direct) {
        TelegramView t;
        t.run = run;
        t.taken = taken;
        t.precheck = precheck;
        flush_events(run.first);
        handle_telegram(t, *st.decoder, st);
      } else {
        add_whole_frame(ready_, run.channel, run, taken);
        handle_frames();
      }
      return true;
    }
  }
  frame_byte(st, first);
  push_rest(run, 1);
  return true;
}

void Pipeline::push_run(const ByteRun& run) {
  if (run.size() == 0) return;
  push(run.event(0));
  push_rest(run, 1);
}

void Pipeline::push_rest(const ByteRun& run, std::size_t i) {
  const TimeNs character_time = options_.timing.character_time;
  // Each pass takes the bytes from i on that close nothing in bulk (perhaps none), then pushes
  // the next byte the byte-by-byte way (it may close frames, detect, re-detect).
  while (i < run.size()) {
    i += take_quietly(run, i, character_time);
    if (i < run.size()) push(run.event(i++));
  }
}

std::size_t Pipeline::take_quietly(const ByteRun& run, std::size_t i, TimeNs character_time) {
  ChannelState& st = *states_[run.channel];
  if (!st.framer || st.redetect || !ready_.empty()) return 0;
  // The bytes from i go to the framer at once while (as push_batch() finds byte by byte) none
  // follows a silence > t3.5, none reaches another channel's deadline, and as_on_the_wire()
  // changes none: bytes at least a character apart (a run's bytes after the first then start
  // after their predecessor's end) and, with 7 data bits, no 8th bit set. The framer stops after
  // a byte that closed frames; they are handled before the rest.
  if (run.step < character_time || run.step - character_time > options_.timing.t35) return 0;
  const ByteRun rest = run.part(i, run.size() - i);
  if (rest.first < st.last_end || rest.first - st.last_end > options_.timing.t35) return 0;
  if (options_.serial.data_bits == 7 &&
      std::any_of(rest.bytes.begin(), rest.bytes.end(), [](std::uint8_t b) { return b > 0x7F; }))
    return 0;
  std::size_t take = rest.size();
  const TimeNs others = deadline_of_others(run.channel);
  if (others <= rest.first) return 0;
  if (others != std::numeric_limits<TimeNs>::max()) {
    // Bytes starting before `others` (step > 0: at least a character time).
    const TimeNs ahead = others - rest.first;
    const TimeNs before = ahead / run.step + (ahead % run.step != 0 ? 1 : 0);
    take = std::min<std::size_t>(take, static_cast<std::size_t>(before));
  }
  if (st.unframed_from == kNoneHeld) st.unframed_from = rest.first;
  const std::size_t taken = st.framer->push(rest.part(0, take), ready_);
  note_taken(st, rest.event(taken - 1));
  earliest_deadline_ = std::min(earliest_deadline_, st.framer->next_deadline());
  if (!ready_.empty()) handle_frames();
  return taken;
}

namespace {

// Feeds `events` to a candidate's framer (and closes it when `close`), counting the telegrams it
// cuts and those whose checksum is good.
void score(DetectionCandidate& c, std::span<const ByteEvent> events, bool close,
           const PipelineOptions& options, FrameBatch& scratch) {
  scratch.clear();
  c.framer->push_all(events, scratch);
  if (close) c.framer->finish(scratch);
  for (Frame& f : scratch) {
    if (f.kind != FrameKind::telegram) continue;
    ++c.telegrams;
    const Message m = c.decoder->dissect(std::move(f), Direction::unknown, options.timing);
    if (m.checksum.verdict != ChecksumVerdict::good || is_implausible(m)) {
      c.after_request = false;
      continue;
    }
    ++c.good;
    const DirectionFit fit = c.decoder->direction_fit(m.bytes);
    const ProtocolDecoder::PairingKeys keys = c.decoder->pairing_keys(m.bytes);
    if (c.after_request && fit.response && keys.address == c.request_keys.address &&
        keys.function == c.request_keys.function) {
      ++c.pairs;
      c.after_request = false;
    } else {
      c.after_request = fit.request;
      c.request_keys = keys;
    }
  }
  scratch.clear();
}

}  // namespace

void Pipeline::start_detection(ChannelState& st) {
  // The bus seems to have changed: close what the current framer holds, then listen afresh.
  st.redetect = false;
  if (st.framer) st.framer->finish(ready_);
  handle_frames();
  st.framer.reset();
  st.decoder = nullptr;
  st.failures = 0;
  st.evaluated_at = 0;
  st.candidates.clear();
  st.detection_overdue = false;
}

void Pipeline::detect(ChannelState& st, ChannelId channel, TimeNs now, bool final, bool deadline) {
  if (st.held.empty()) return;
  if (!final && !deadline && st.held.size() < kDetectBytes &&
      st.held.size() - st.evaluated_at < kDetectEvery)
    return;
  const std::span<const ProtocolDesc* const> weighed =
      options_.detect_protocols.empty()
          ? registered_protocols()
          : std::span<const ProtocolDesc* const>(options_.detect_protocols);
  if (weighed.empty()) return;
  if (st.candidates.empty())
    for (const ProtocolDesc* p : weighed) {
      const ProtocolDecoder* d = p->decoder;
      DetectionCandidate& c = st.candidates.emplace_back();
      c.decoder = d;
      c.framer = d->make_framer(channel, {options_.timing, options_.max_hold});
    }
  // The last chance to decide closes the candidates' framers: their last telegram counts too.
  const bool last_chance = final || st.held.size() >= kDetectBytes;
  const std::span<const ByteEvent> fresh = std::span(st.held).subspan(st.evaluated_at);
  st.evaluated_at = st.held.size();
  const DetectionCandidate* best = nullptr;
  const DetectionCandidate* second = nullptr;
  std::string evidence;
  for (DetectionCandidate& c : st.candidates) {
    score(c, fresh, last_chance, options_, detection_scratch_);
    evidence += fmt::format(FMT_COMPILE("{}{} {}/{}"), evidence.empty() ? "" : ", ",
                            protocol_label(c.decoder->protocol()), c.good, c.telegrams);
    if (!best || c.good > best->good) {
      second = best;
      best = &c;
    } else if (!second || c.good > second->good) {
      second = &c;
    }
  }
  // (With one protocol weighed there is no second: its count is none.)
  const int second_good = second ? second->good : 0;
  const bool clear = best->good >= kDetectGoodFrames && best->good > 2 * second_good;
  // Several good telegrams (checksum and plausibility) decide, never one lucky checksum; on a
  // line that carries both directions, high confidence also wants a request answered.
  // A master or slave channel carries one direction of its link: its request and the other
  // channel's reply are the pair a shared bus shows on one channel.
  const int min_good = st.role == ChannelRole::bus ? options_.detect_min_good
                                                   : std::min(1, options_.detect_min_good);
  const bool found = clear || (best->good >= min_good && best->good > second_good);
  if (!clear && !last_chance) {
    // At the deadline the evidence so far decides if it can; else listening goes on (a flow
    // polled once a second has one telegram by then) without holding up the other channels.
    if (!deadline) return;
    if (!found) {
      st.detection_overdue = true;
      return;
    }
  }
  const bool both_ways = st.role == ChannelRole::bus && options_.detect_min_good > 1;
  const char* confidence =
      !found ? "none"
      : clear && best->good * 5 >= best->telegrams * 4 && (!both_ways || best->pairs > 0)
          ? "high"
          : "medium";
  st.redetect_after =
      clear ? kRedetectFailures : std::min(st.redetect_after * 2, kMaxRedetectFailures);
  st.candidates.clear();
  st.detection_overdue = false;
  BusEvent ev;
  ev.time = st.held.front().time;
  ev.channel = channel;
  ev.kind = EventKind::protocol_detected;
  ev.confidence = confidence;
  if (found) {
    ev.protocol = best->decoder->protocol();
    ev.detail = fmt::format(
        "protocol {} (confidence {}; good telegrams, checksum and plausibility, in the first {} "
        "bytes: {})",
        protocol_label(ev.protocol), confidence, st.held.size(), evidence);
  } else {
    // No drive protocol: say what the line carries. An IP flow then stays out of the decode; a
    // serial line is still cut by silence, its pieces shown as data (noise records).
    // Too few good telegrams is no protocol either (never one lucky telegram), said as such.
    ev.protocol = Protocol::unknown;
    ev.carries =
        best->good > 0
            ? fmt::format("{} bytes with only {} good {} telegram{} (too few to decide)",
                          st.held.size(), best->good, protocol_label(best->decoder->protocol()),
                          best->good == 1 ? "" : "s")
            : describe_line(st.held);
    ev.detail =
        fmt::format("no drive protocol: {} (good telegrams, checksum and plausibility: {}){}",
                    ev.carries, evidence, st.ip_flow ? "; the flow is left out of the decode" : "");
  }
  // Handed on just before the channel's first frame (which starts at ev.time), in time order with
  // the frames of other channels.
  // (Events of one time go in channel order, as frames do.)
  pending_events_.insert(std::upper_bound(pending_events_.begin(), pending_events_.end(), ev,
                                          [](const BusEvent& a, const BusEvent& b) {
                                            return a.time != b.time ? a.time < b.time
                                                                    : a.channel < b.channel;
                                          }),
                         std::move(ev));
  if (!found && st.ip_flow) {
    st.left_out = true;
    st.left_out_bytes += st.held.size();
    st.held.clear();
    st.unframed_from = kNoneHeld;  // holds nothing back any more
    return;
  }
  const ProtocolDecoder* chosen = found ? best->decoder : decoder_for(default_protocol());
  st.no_protocol = !found;
  st.decoder = chosen;
  st.framer = chosen->make_framer(channel, {options_.timing, options_.max_hold});
  std::vector<ByteEvent> held;
  held.swap(st.held);
  st.framer->push_all(held, ready_);
  // Time has moved on while the bytes were held: let silence close what it closed meanwhile. Up
  // to `now`, what this channel's byte or the clock says, not the latest byte of any channel: a
  // source that gives a packet at a time (pcapng) has another channel's packet ahead already.
  st.framer->advance(now, ready_);
  earliest_deadline_ = std::min(earliest_deadline_, st.framer->next_deadline());
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
  // Frames closed together (several channels) go out in order of their first byte. One
  // channel's come in order already: checking is cheaper than a stable sort's buffer and moves.
  // (Frames that start together, as on the two wires of one pair, go in channel order: the same
  // order whatever closed them first, so a pcapng written and read back gives the same output.)
  const auto earlier = [](const Frame& a, const Frame& b) {
    return a.start() != b.start() ? a.start() < b.start() : a.channel < b.channel;
  };
  if (!std::is_sorted(ready_.begin(), ready_.end(), earlier))
    std::stable_sort(ready_.begin(), ready_.end(), earlier);
  for (const Frame& f : ready_) note_framed(f);
  const TimeNs watermark = output_watermark();
  // (A frame that starts where another channel still holds bytes waits too: the other may close
  // one that starts with it and goes first, in channel order.)
  if (!waiting_.empty() || ready_.back().start() >= watermark) {
    // Another channel may still close an earlier frame: these wait for it (the reorder stage).
    for (Frame& f : ready_) waiting_.push(f, states_[f.channel]->decoder);
    ready_.clear();
    release_waiting(watermark);
    return;
  }
  // Nested calls (none today) would get a batch of their own rather than clobber this one.
  FrameBatch nested;
  FrameBatch& batch = in_batch_ ? nested : batch_;
  const bool outer = !in_batch_;
  in_batch_ = true;
  batch.swap(ready_);
  for (Frame& f : batch) handle_in_order(f, *states_[f.channel]->decoder);
  // The frames keep their storage (a telegram's slot holds the previous one of message_) for
  // the frames the framers build in them next.
  batch.clear();
  if (outer) in_batch_ = false;
}

void Pipeline::note_framed(const Frame& frame) {
  ChannelState& st = *states_[frame.channel];
  // A framer with nothing pending holds no byte; otherwise what it holds follows this frame.
  st.unframed_from = st.framer && st.framer->next_deadline() != std::numeric_limits<TimeNs>::max()
                         ? frame.events.back_time() + 1
                         : kNoneHeld;
}

TimeNs Pipeline::output_watermark() const {
  TimeNs earliest = kNoneHeld;
  for (const auto& s : states_)
    if (!s->detection_overdue) earliest = std::min(earliest, s->unframed_from);
  return earliest;
}

void Pipeline::release_waiting(TimeNs watermark) {
  while (!waiting_.empty()) {
    FrameQueue::Slot& slot = waiting_.front();
    const TimeNs start = slot.frame.start();
    if (start >= watermark && waiting_.size() <= kMaxWaitingFrames &&
        latest_time_ - start <= kMaxReorderHold)
      break;
    handle_in_order(slot.frame, *slot.decoder);
    waiting_.pop();
  }
  if (waiting_.empty()) flush_events(watermark);
}

void Pipeline::handle_in_order(Frame& frame, const ProtocolDecoder& decoder) {
  // (Past --count's limit the frames are dropped: `capture -c N` gets exactly N.)
  if (options_.max_frames > 0 && stats_.frames >= options_.max_frames) return;
  flush_events(frame.start());
  handle_frame(frame, decoder);
}

void Pipeline::flush_some_events(TimeNs until) {
  std::size_t n = 0;
  while (n < pending_events_.size() && pending_events_[n].time <= until)
    sink_.on_event(pending_events_[n++]);
  pending_events_.erase(pending_events_.begin(),
                        pending_events_.begin() + static_cast<std::ptrdiff_t>(n));
}

inline Direction Pipeline::decide_direction(const ProtocolDecoder& decoder, TimeNs start,
                                            std::span<const std::uint8_t> bytes, int address,
                                            int function, std::size_t link, ChannelRole role,
                                            const TelegramPrecheck* precheck) const {
  switch (role) {
    case ChannelRole::master:
      return Direction::request;
    case ChannelRole::slave:
      return Direction::response;
    case ChannelRole::bus:
      break;
  }
  if (bytes.size() < 2) return Direction::unknown;
  if (precheck ? precheck->always_response : decoder.always_response(bytes))
    return Direction::response;
  const DirectionFit fit = precheck ? precheck->fit : decoder.direction_fit(bytes);
  if (fit.request != fit.response) return fit.request ? Direction::request : Direction::response;
  // Both layouts fit (echo replies, acknowledgements of the same size) or neither does: order
  // decides — a reply is what a pending request of the same station and function awaits, and
  // could answer.
  if (const std::span<const std::uint8_t> awaited =
          pairer_.awaited_request(link, address, function, start);
      !awaited.empty() && decoder.could_answer(bytes, awaited))
    return Direction::response;
  if (fit.request) return Direction::request;
  if (!decoder.recognisable(bytes)) return Direction::unknown;
  return Direction::request;
}

void Pipeline::check_drive_timing(const TelegramHead& m, const DriveProfile& p,
                                  const FramingTiming& timing, std::vector<Anomaly>& found,
                                  bool described) {
  if (m.bytes.empty() || !options_.clocked) return;  // (synthetic times break no rule)
  // Times that carry no silence (USB bursts) judge no timing rule, as the dissectors judge no
  // t1.5 or t3.5.
  if (!timing.silences_trusted) return;
  const TimeNs char_time = timing.character_time;
  // A finding, typed; its text (timing_break_text, with the rule's source, "ERMAN E-9P/9G, 000
  // §5.2") only when `described`: a run that shows no anomaly counts it by its kind.
  auto finding = [&](TimingRule rule, double measured, double limit) {
    Anomaly a{AnomalyKind::timing_rule, m.start, m.channel, m.number, {}};
    a.timing = {rule, measured, limit, p.name, p.timing_section};
    if (described) a.detail = timing_break_text(a.timing);
    found.push_back(std::move(a));
  };
  auto ms = [](TimeNs t) { return static_cast<double>(t) / static_cast<double>(kNsPerMs); };
  if (m.direction == Direction::request) {
    if (p.min_silence_chars && m.gap_before >= 0 && char_time > 0 &&
        static_cast<double>(m.gap_before) < *p.min_silence_chars * static_cast<double>(char_time))
      finding(TimingRule::silence_before_request,
              static_cast<double>(m.gap_before) / static_cast<double>(char_time),
              *p.min_silence_chars);
    const auto last = last_reply_end_.find(m.address);
    if (p.min_reply_to_request_ms && last != last_reply_end_.end() &&
        ms(m.start - last->second) < *p.min_reply_to_request_ms)
      finding(TimingRule::request_after_reply, ms(m.start - last->second),
              *p.min_reply_to_request_ms);
  } else if (m.direction == Direction::response) {
    if (m.latency >= 0 && p.min_reply_delay_ms && ms(m.latency) < *p.min_reply_delay_ms)
      finding(TimingRule::reply_too_soon, ms(m.latency), *p.min_reply_delay_ms);
    if (m.latency >= 0 && p.max_reply_delay_ms && ms(m.latency) > *p.max_reply_delay_ms)
      finding(TimingRule::reply_too_late, ms(m.latency), *p.max_reply_delay_ms);
    last_reply_end_[m.address] = m.last_byte + char_time;
  }
}

const DriveProfile* Pipeline::drive_profile_for(std::size_t link, TelegramDriveRecords& telegram,
                                                bool& sure) {
  const int address = telegram.telegram().address;
  if (const auto drive = options_.drives.find(address); drive != options_.drives.end()) {
    sure = true;
    return drive->second;
  }
  std::optional<BusEvent> changed;
  const DriveProfile* profile = binder_.learn_bound(link, telegram, changed);
  sure = profile && binder_.sure(link, address);
  std::uint64_t withdrawn = 0;
  if (!held_findings_.empty()) withdrawn = settle_held_findings(link, address, profile, sure);
  if (changed) {
    // A binding let go or taken over takes the findings its family set along: those held are
    // dropped, those handed on leave the counts (and the sinks that count them, on this event).
    if (const auto made = findings_under_binding_.find({link, address});
        !changed->from.empty() && made != findings_under_binding_.end()) {
      stats_.anomalies[static_cast<std::size_t>(AnomalyKind::timing_rule)] -= made->second;
      stats_.anomaly_total -= made->second;
      withdrawn += made->second;
      findings_under_binding_.erase(made);
    }
    changed->withdrawn = withdrawn;
    if (withdrawn)
      changed->detail +=
          fmt::format(FMT_COMPILE("; {} timing-rule finding{} made under it withdrawn"), withdrawn,
                      withdrawn == 1 ? "" : "s");
    sink_.on_event(*changed);
  }
  return profile;
}

void Pipeline::hold_family_findings(std::size_t link, int address, const DriveProfile& profile,
                                    std::vector<Anomaly>& found) {
  if (found.empty()) return;
  HeldFindings& held = held_findings_[{link, address}];
  held.profile = &profile;
  for (Anomaly& a : found) {
    a.address = address;
    if (held.findings.size() < kMaxHeldFindings)
      held.findings.push_back(std::move(a));
    else
      ++held.left_out[static_cast<std::size_t>(a.kind)];
  }
  found.clear();
}

std::size_t Pipeline::settle_held_findings(std::size_t link, int address,
                                           const DriveProfile* profile, bool sure) {
  const auto it = held_findings_.find({link, address});
  if (it == held_findings_.end()) return 0;
  HeldFindings& held = it->second;
  std::size_t dropped = 0;
  if (held.profile != profile) {
    dropped = held.findings.size();
    for (const std::uint64_t n : held.left_out) dropped += n;
  } else if (sure) {
    count_under_binding(link, address, held.findings.size());
    for (const std::uint64_t n : held.left_out) count_under_binding(link, address, n);
    for (const Anomaly& a : held.findings) emit_anomaly(a);
    for (std::size_t k = 0; k < held.left_out.size(); ++k)
      for (std::uint64_t n = 0; n < held.left_out[k]; ++n)
        stats_.count_anomaly(static_cast<AnomalyKind>(k));
  } else {
    return 0;
  }
  held_findings_.erase(it);
  return dropped;
}

void Pipeline::check_packetization(const Frame& frame, ChannelState& st) {
  check_packetization(frame.kind, frame.events.front_origin(), frame.events.back_origin(),
                      frame.number, frame.start(), frame.channel, st);
}

void Pipeline::check_packetization(FrameKind kind, std::uint32_t first, std::uint32_t last,
                                   std::uint64_t number, TimeNs start, ChannelId channel,
                                   ChannelState& st) {
  // Only sources with packets (origin != 0) are checked: a good capture tool puts exactly one
  // frame in each packet; drivetap re-frames anyway and says where the tool did not.
  if (first == 0) return;
  if (first == last && first != st.last_frame_origin) {  // (nearly every frame: nothing to say)
    st.last_frame_origin = last;
    st.last_frame_number = number;
    return;
  }
  report_packetization(kind, first, last, number, start, channel, st);
}

void Pipeline::report_packetization(FrameKind kind, std::uint32_t first, std::uint32_t last,
                                    std::uint64_t number, TimeNs start, ChannelId channel,
                                    ChannelState& st) {
  const char* what = kind == FrameKind::noise ? "noise record" : "frame";
  if (first != last) {
    emit_anomaly(
        {AnomalyKind::packet_split_frame, start, channel, number,
         fmt::format(FMT_COMPILE("{} #{} spans packets {}..{}"), what, number, first, last)});
  }
  if (first == st.last_frame_origin && st.reported_merged_origin != first) {
    emit_anomaly({AnomalyKind::packet_merged_frames, start, channel, number,
                  fmt::format(FMT_COMPILE("packet {} holds more than one frame (#{} and #{})"),
                              first, st.last_frame_number, number)});
    st.reported_merged_origin = first;
  }
  st.last_frame_origin = last;
  st.last_frame_number = number;
}

void Pipeline::handle_frame(Frame& frame, const ProtocolDecoder& decoder) {
  frame.number = ++frame_counter_;
  // The frame came out of its channel's framer: the channel's state exists.
  ChannelState& st = *states_[frame.channel];
  // Cut on a line with no drive protocol (by the fallback framer): data, not a telegram.
  if (st.no_protocol && st.decoder == &decoder) frame.kind = FrameKind::noise;
  if (frame.kind == FrameKind::noise) {
    pairer_.expire(frame.start(), transactions_);
    emit_transactions(transactions_);
    stats_.count_noise(frame);
    sink_.on_noise(frame);
    emit_anomaly({AnomalyKind::noise, frame.start(), frame.channel, frame.number,
                  noise_detail(frame.events)});
    if (st.detection_reads(decoder) && ++st.failures >= st.redetect_after) st.redetect = true;
    std::vector<Anomaly> uart;
    append_uart_anomalies(frame.events, frame.number, uart);
    for (const Anomaly& a : uart) emit_anomaly(a);
    check_packetization(frame, st);
    return;
  }
  TelegramView t;
  t.frame = &frame;
  handle_telegram(t, decoder, st);
}

void Pipeline::handle_telegram(TelegramView& t, const ProtocolDecoder& decoder, ChannelState& st) {
  const std::size_t link = st.link;
  // What the steps below read of the telegram, taken before dissect() moves its frame.
  const bool whole = t.frame == nullptr;
  const std::span<const std::uint8_t> bytes = t.bytes();
  const ChannelId channel = whole ? t.run.channel : t.frame->channel;
  const TimeNs start = whole ? t.run.first : t.frame->start();
  const std::uint64_t number = whole ? ++frame_counter_ : t.frame->number;
  pairer_.expire(start, transactions_);
  emit_transactions(transactions_);
  const ProtocolDecoder::PairingKeys keys = decoder.pairing_keys(bytes);
  const Direction dir = decide_direction(decoder, start, bytes, keys.address, keys.function, link,
                                         st.role, t.precheck);
  // A reply is dissected in the light of the request it answers (the drive level reads it
  // too): the pairer's own copy, which stays as it is until pairer_.add() below.
  // (Only a decode shown to a sink and the drive level read it: the findings counted without
  // them, `read --stats` with no profile, never depend on it.)
  std::span<const std::uint8_t> request;
  if (dir == Direction::response && (hand_over_records_ || drive_level_))
    request = pairer_.awaited_request(link, keys.address, keys.function, start);
  // The Message only where a sink takes it from here: a sink that takes no records has the
  // telegram's head counted, one that decodes telegrams itself gets those taken whole undecoded
  // (its needs' deferred_decode).
  const bool deferred = whole && hand_over_records_;
  const DissectDepth depth =
      !hand_over_records_ || deferred ? DissectDepth::head : DissectDepth::detail;
  Message& m = message_;
  TelegramFindings found;
  PairingInput in;
  const FramingTiming& timing = st.silences_trusted ? options_.timing : untrusted_timing_;
  const bool detailed = decoder.dissect(t, dir, timing, request, depth, m, &found);
  if (detailed) {
    m.frame.number = number;
    m.silences_trusted = st.silences_trusted;
    in = pairing_input(m);
  } else {
    // The telegram's head (for pairing and the drive level) and function, from its findings.
    in.direction = dir;
    in.protocol = decoder.protocol();
    in.address = found.address;
    in.verdict = found.verdict;
    in.plausible =
        (found.other_kinds & (1u << static_cast<unsigned>(AnomalyKind::implausible))) == 0;
    static_cast<TelegramFunction&>(in) = found;  // the function part, as the findings have it
    in.number = number;
    in.channel = channel;
    in.start = start;
    in.last_byte = whole ? t.run.time(t.run.size() - 1) : t.frame->events.back_time();
    in.gap_before = whole ? t.taken.timing.gap_before : t.frame->gap_before;
    in.bytes = bytes;
    in.silences_trusted = st.silences_trusted;
  }
  if (!st.silences_trusted) ++stats_.silences_unjudged;
  // Drive level: the station's profile (bound on the command line or guessed from its traffic),
  // what the telegram means to it, and the state changes it shows. Its drive records are read at
  // most once, by the first of the binder and the annotation to ask for them.
  TelegramDriveRecords records(drive_records_, in, request);
  bool sure = false;
  const DriveProfile* profile = drive_level_ ? drive_profile_for(link, records, sure) : nullptr;
  if (profile) {
    // The annotation's text is written here, or by the sink on its own thread (then only the
    // observation is made here: the timeline needs it now).
    read_for_drive_into(*profile, in, records.get(),
                        detailed && m.detail && m.info_text && !defer_drive_info_
                            ? DriveReadingWants::text_and_observation
                            : DriveReadingWants::observation,
                        drive_reading_);
    if (detailed && defer_drive_info_) {
      m.drive_profile = profile;
      m.request.assign(request.begin(), request.end());
    } else if (detailed) {
      std::swap(m.drive_info, drive_reading_.text);  // both keep their storage for later frames
      m.request.assign(request.begin(), request.end());
    }
    if (detailed) {
      m.drive_read_with = profile;
      if (hand_over_drive_values_)
        collect_drive_values(*profile, in.address, drive_reading_.observed, m.drive_values);
    }
  }
  if (st.detection_reads(decoder)) {
    if (good_telegram(in)) {
      st.failures = 0;
    } else if (++st.failures >= st.redetect_after) {
      st.redetect = true;
    }
  }
  // (`request`, the pairer's storage, stays as it is through pairer_.add() of this reply: the
  // deferred hand-over below reads it there.)
  const PairingResult paired = pairer_.add(link, in, transactions_);
  if (paired.paired) {
    if (!st.silences_trusted) ++stats_.latencies_unjudged;
    in.latency = paired.latency;
    if (detailed) {
      m.latency = paired.latency;
      m.request_number = paired.request_number;
    }
  }
  if (detailed) {
    if (profile && sure) {
      const std::size_t before = m.anomalies.size();
      check_drive_timing(in, *profile, timing, m.anomalies, true);
      count_under_binding(link, in.address, m.anomalies.size() - before);
    } else if (profile) {
      drive_anomalies_.clear();
      check_drive_timing(in, *profile, timing, drive_anomalies_, true);
      for (Anomaly& a : drive_anomalies_) a.frame_number = number;
      hold_family_findings(link, in.address, *profile, drive_anomalies_);
    }
    for (Anomaly& a : m.anomalies) a.frame_number = number;
    stats_.count_frame(m);
    sink_.on_frame(m);
    for (const Anomaly& a : m.anomalies) emit_anomaly(a);
    check_packetization(m.frame, st);
  } else {
    stats_.count_telegram(bytes.size(), in.verdict, in.plausible, start, in.last_byte);
    // The message's findings, counted (a sink that decodes the message hands them on).
    for (std::size_t i = 0; i < found.malformed; ++i) stats_.count_anomaly(AnomalyKind::malformed);
    // Each pass counts the lowest kind left.
    for (std::uint32_t kinds = found.other_kinds; kinds != 0; kinds &= kinds - 1)
      stats_.count_anomaly(static_cast<AnomalyKind>(std::countr_zero(kinds)));
    if (profile) {
      drive_anomalies_.clear();
      // (A sink without records shows no anomaly: the findings are counted, not described.)
      check_drive_timing(in, *profile, timing, drive_anomalies_, hand_over_records_);
      if (!sure) hold_family_findings(link, in.address, *profile, drive_anomalies_);
      count_under_binding(link, in.address, drive_anomalies_.size());
      for (const Anomaly& a : drive_anomalies_) stats_.count_anomaly(a);
    }
    if (deferred) {
      // What the sink decodes, with what only the pipeline knows.
      DeferredTelegram telegram;
      telegram.decoder = &decoder;
      telegram.timing = timing;
      telegram.run = t.run;
      telegram.taken = t.taken;
      telegram.number = number;
      telegram.direction = dir;
      telegram.request = request;
      telegram.head = &found;
      telegram.plausible = in.plausible;
      if (paired.paired) {
        telegram.latency = paired.latency;
        telegram.request_number = paired.request_number;
      }
      if (profile) {
        if (defer_drive_info_) telegram.drive_profile = profile;
        telegram.anomalies = drive_anomalies_;
        if (hand_over_drive_values_ && defer_drive_info_ && !drive_values_at_hand_over_) {
          telegram.drive_values_with_annotation = true;
        } else if (hand_over_drive_values_) {
          drive_values_.clear();
          collect_drive_values(*profile, in.address, drive_reading_.observed, drive_values_);
          telegram.drive_values = drive_values_;
        }
      }
      sink_.on_deferred_frame(telegram);
    }
    if (whole)
      check_packetization(FrameKind::telegram, t.run.origin, t.run.origin, number, start, channel,
                          st);
    else
      check_packetization(*t.frame, st);
  }
  // A corrupted or implausible telegram says nothing reliable about the drive's state.
  if (profile && good_telegram(in))
    for (const BusEvent& e :
         timeline_.observe(link, in, *profile, drive_reading_.observed, hand_over_events_))
      sink_.on_event(e);
  emit_transactions(transactions_);
}

void Pipeline::summarise_drives() {
  std::map<DriveTimeline::Key, DriveSummary> drives;
  for (const auto& [key, station] : binder_.stations()) {
    DriveSummary& d = drives[key];
    d.link = key.first;
    d.address = key.second;
    d.profile = station.bound >= 0 ? binder_.candidate(station.bound).id : "generic";
    d.profile_name = station.bound >= 0 ? binder_.candidate(station.bound).name : "generic";
    d.binding = binder_.evidence(station);
  }
  for (const auto& [key, state] : timeline_.drives()) {
    const bool by_option = options_.drives.count(key.second) != 0;
    // A station bound for a while and then let go (its traffic stopped fitting) is summed up as
    // the binder sees it now: the profile it was read with is no longer claimed.
    if (!by_option) {
      const auto station = binder_.stations().find(key);
      if (station != binder_.stations().end() && station->second.bound < 0) continue;
    }
    DriveSummary& d = drives[key];
    d.link = key.first;
    d.address = key.second;
    if (by_option) d.binding = "bound with --drive";
    d.profile = state.profile_id;
    d.profile_name = state.profile_name;
    d.state = state.summary();
    d.events = state.events;
  }
  stats_.drives.clear();
  for (auto& [key, d] : drives) stats_.drives.push_back(std::move(d));
}

namespace {

// The finding on a request no reply answered, or on a reply that answers none. (Out of line: rare,
// and kept out of the loop over every transaction.)
[[gnu::noinline]] Anomaly unpaired_finding(const Transaction& t) {
  const bool timeout = t.outcome == Outcome::timeout;
  const std::uint64_t number = timeout ? t.request_number : t.response_number;
  return {
      timeout ? AnomalyKind::unanswered_request : AnomalyKind::unsolicited_response,
      timeout ? t.request_time : t.response_time, t.channel, number,
      fmt::format(FMT_COMPILE("{} #{} {} address {}{}: {}"), timeout ? "request" : "reply", number,
                  timeout ? "to" : "from", t.address,
                  t.function < 0 ? "" : fmt::format(FMT_COMPILE(" function {:02X}"), t.function),
                  t.detail)};
}

}  // namespace

void Pipeline::emit_some_transactions(std::vector<Transaction>& transactions) {
  for (const Transaction& t : transactions) {
    stats_.count_transaction(t);
    if (hand_over_transactions_) sink_.on_transaction(t);
    if (t.outcome == Outcome::timeout || t.outcome == Outcome::unsolicited)
      emit_anomaly(unpaired_finding(t));
  }
  transactions.clear();
}

void Pipeline::finish(bool cut_partial) {
  if (finished_) return;
  finished_ = true;
  for (std::size_t i = 0; cut_partial && i < states_.size(); ++i) {
    ChannelState& st = *states_[i];
    if (!st.framer) detect(st, static_cast<ChannelId>(i), latest_time_, true);
    if (st.framer) st.framer->finish(ready_);
  }
  handle_frames();
  release_waiting(kNoneHeld);  // (what --count's limit or cut_partial left waiting)
  flush_events(kNoneHeld);
  // Findings held for a binding that stands at the end are its: handed on (the binder's last
  // word on the station is the binding).
  while (!held_findings_.empty()) {
    const auto [link, address] = held_findings_.begin()->first;
    settle_held_findings(link, address, binder_.bound(link, address), true);
  }
  for (const auto& st : states_) stats_.left_out_bytes += st->left_out_bytes;
  for (std::size_t i = 0; i < states_.size(); ++i)
    if (states_[i]->left_out && i < channels_.size())
      stats_.source_notes.push_back(
          fmt::format(FMT_COMPILE("{}: no drive protocol, {} bytes left out of the decode"),
                      channels_.at(static_cast<ChannelId>(i)).name, states_[i]->left_out_bytes));
  pairer_.finish(transactions_);
  emit_transactions(transactions_);
  summarise_drives();
  sink_.on_summary(stats_);
}

}  // namespace drivetap
