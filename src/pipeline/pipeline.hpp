// Pipeline: ByteEvent -> Frame -> Message -> Transaction, wired to a Sink (docs/protocols.md
// §1-§2).
//
// One framer per channel; the pairing stage per link (ChannelTable). The pipeline also owns the
// per-channel time discipline: bytes on one wire cannot overlap, so a byte stamped before the
// previous byte ended (a USB adapter stamping a whole read at once) is moved to right after it.
// And the order across channels: frames are decoded, paired and handed on in order of their
// first byte, a closed frame waiting (FrameQueue) while another channel holds bytes that may
// start an earlier one — an open frame, or bytes held for protocol detection — within the bounds
// of docs/reference.md "Order of the output".
#pragma once

#include <limits>
#include <map>
#include <memory>
#include <vector>

#include "core/byte_event.hpp"
#include "core/protocol.hpp"
#include "core/protocol_desc.hpp"
#include "core/serial_config.hpp"
#include "core/stats.hpp"
#include "drive/binder.hpp"
#include "drive/profile.hpp"
#include "drive/records.hpp"
#include "drive/timeline.hpp"
#include "pipeline/frame_queue.hpp"
#include "pipeline/pairer.hpp"
#include "sinks/sink.hpp"

namespace drivetap {

struct PipelineOptions {
  SerialConfig serial;
  FramingTiming timing;  // usually FramingTiming::from(serial), possibly overridden
  TimeNs max_hold = 100 * kNsPerMs;
  TimeNs reply_timeout = 1 * kNsPerSecond;
  // False for `drivetap decode`, whose times are synthetic: no timeout or unanswered request, no
  // drive timing rule (PairerOptions::clocked).
  bool clocked = true;
  // --protocol: a fixed protocol, or Protocol::unknown to detect it per channel ("auto").
  Protocol protocol = Protocol::unknown;
  // Drive profiles bound to station addresses (--drive 2=e9); the profiles outlive the pipeline.
  std::map<int, const DriveProfile*> drives;
  // --drive auto (the default): the profiles other stations are bound to by their traffic.
  std::vector<const DriveProfile*> auto_candidates;
  // Detection decides on at least this many good telegrams (checksum and plausibility), never
  // on one lucky checksum on a bus; `decode` sets 1: its frames are the ones the user typed.
  int detect_min_good = 2;
  // The protocols auto detection weighs (the registry's when empty; one is enough).
  std::vector<const ProtocolDesc*> detect_protocols;
  // Stop emitting after this many frames (0: no limit): `capture -c N` gets exactly N even when
  // one byte closes several frames at once.
  std::uint64_t max_frames = 0;
};

class Pipeline {
 public:
  Pipeline(PipelineOptions options, const ChannelTable& channels, Sink& sink);
  ~Pipeline();

  void push(const ByteEvent& event);
  // The same as push() of each in turn, cheaper: bytes that follow on one channel with no
  // silence and before anything else falls due go to the framer as one run.
  void push_batch(std::span<const ByteEvent> events);
  // The same for runs (a source's packets): push() of each byte of each run in turn, with the
  // bytes after a run's first that close nothing handed to the framer as one run.
  void push_runs(const RunBatch& runs);
  void push_run(const ByteRun& run);
  // A finding from the source itself (e.g. a timestamp going backwards in a file).
  void report(const Anomaly& anomaly);
  // Live capture: the clock reached `now` with no new byte, so frames whose closing silence has
  // passed are emitted now instead of when the next byte comes (bytes pushed later must not be
  // earlier than `now`).
  void advance(TimeNs now) { advance_all(now); }
  // When advance() can next close something (max() when nothing is pending): a poll timeout.
  [[nodiscard]] TimeNs next_deadline() const { return earliest_deadline_; }
  // A line about the source for the summary (before finish()).
  void add_source_note(std::string note) { stats_.source_notes.push_back(std::move(note)); }
  // The source found that `channel`'s times carry no inter-frame silence (a USB adapter's bursts:
  // SerialPort::timing_trusted()): from its next telegram on, no latency is measured and no
  // silence rule (t1.5, t3.5, a drive's timing rule) judged; the summary counts them.
  void distrust_silences(ChannelId channel);
  // Closes everything pending and emits the summary. Idempotent. `cut_partial` false: bytes of
  // a frame not closed yet are dropped, not emitted as a cut frame (a capture told to stop
  // after N frames).
  void finish(bool cut_partial = true);
  [[nodiscard]] const Stats& stats() const { return stats_; }
  // The decoder whose prechecks a reader on another thread should make for channel `channel`'s
  // runs (ReadAhead::precheck_with), channels [0, channel_count()): the channel's decoder now,
  // when this thread alone decodes — the sink takes no records, every telegram taken whole is
  // dissected to its head — and the reader's core would otherwise wait; nullptr otherwise (no
  // decoder yet, re-detecting, or a sink whose writers keep both cores busy, where a precheck,
  // which works out both directions' findings, is more work in all).
  [[nodiscard]] const ProtocolDecoder* precheck_decoder_of(ChannelId channel) const;
  [[nodiscard]] std::size_t channel_count() const { return states_.size(); }

 private:
  struct ChannelState;
  ChannelState& state_for(ChannelId id);
  void advance_all(TimeNs now);
  // push_runs() of a chunk with prechecks (RunBatch::has_prechecks) or without. A run is framed
  // whole when the next run of its channel, at most kWholeRunLookAhead runs on, shows the silence
  // after it.
  static constexpr std::size_t kWholeRunLookAhead = 4;
  template <bool Prechecked>
  void push_runs_as(const RunBatch& runs);
  // The part of push() after the clock has moved to e's time: e to its channel's framer (or
  // detection).
  void frame_byte(ChannelState& st, const ByteEvent& e);
  // push_run() of `run` when the next byte on its channel, with nothing else pushed on it before,
  // starts at next_time: a whole frame between two silences goes to the framer at once
  // (Framer::take_whole), and is handled at once when it would be handled alone. False when the
  // run was not taken (push_run() it).
  // This and the two other always_inline members below run once a telegram taken whole: inlined
  // as a profile-guided build inlines them, which the hot path shows. Defined inline in
  // pipeline.cpp, their only user.
  // `precheck`: the run's (RunBatch::precheck), or nullptr.
  [[gnu::always_inline]] bool push_whole(const ByteRun& run, TimeNs next_time,
                                         const TelegramPrecheck* precheck);
  // push_run() from byte i on, byte i - 1 having been pushed.
  void push_rest(const ByteRun& run, std::size_t i);
  // Bytes from run byte i on that advance_all() would have nothing due before, given to the
  // framer at once (it stops after one that closed frames): how many it took.
  std::size_t take_quietly(const ByteRun& run, std::size_t i, TimeNs character_time);
  // A byte as the wire could have carried it: data bits only, not before `last_end`, the end of
  // its channel's previous byte. push() and push_batch() both take bytes through these two.
  [[nodiscard]] ByteEvent as_on_the_wire(ByteEvent e, TimeNs last_end) const;
  // Records that the channel's latest byte is `e` (its end, the run's latest time).
  void note_taken(ChannelState& st, const ByteEvent& e);
  // The earliest next_deadline() of the framers of channels other than `channel`.
  [[nodiscard, gnu::always_inline]] TimeNs deadline_of_others(ChannelId channel) const;
  void handle_frames();
  // `decoder`: of the framer that cut the frame (the channel's, unless it is detecting afresh).
  // Noise here; a telegram goes on to handle_telegram().
  void handle_frame(Frame& frame, const ProtocolDecoder& decoder);
  // The one per-telegram path: direction, dissection (in detail, or only its head when no sink
  // takes the Message from here), drive level, pairing, counting, findings and hand-over. `t`: a
  // frame out of the framer (numbered), or a run the framer took whole (numbered here; its
  // events before it handed on already).
  void handle_telegram(TelegramView& t, const ProtocolDecoder& decoder, ChannelState& st);
  // The reorder stage. Records that `frame` came out of its channel's framer: the channel's bytes
  // not in a frame yet come after it, or there are none.
  void note_framed(const Frame& frame);
  // The earliest time a frame not closed yet can start at: the first byte any channel holds
  // unframed (in its framer or for detection); max() when none holds any.
  [[nodiscard]] TimeNs output_watermark() const;
  // Hands on the waiting frames that start no later than `watermark`, and those the hold's bounds
  // let go (kMaxReorderHold, kMaxWaitingFrames), in order.
  void release_waiting(TimeNs watermark);
  // handle_frame() of a frame in its turn: the events before it first; none past --count's limit.
  void handle_in_order(Frame& frame, const ProtocolDecoder& decoder);
  // Hands on the pending events (protocol detection) stamped no later than `until`.
  void flush_events(TimeNs until) {
    if (!pending_events_.empty()) flush_some_events(until);
  }
  void flush_some_events(TimeNs until);
  void check_packetization(const Frame& frame, ChannelState& st);
  // The same for a record of `kind` whose bytes came from source packets first..last.
  void check_packetization(FrameKind kind, std::uint32_t first, std::uint32_t last,
                           std::uint64_t number, TimeNs start, ChannelId channel, ChannelState& st);
  // Its findings, for a record that is not one packet's alone (kept apart from the check that
  // nearly every record passes, which is then inlined).
  void report_packetization(FrameKind kind, std::uint32_t first, std::uint32_t last,
                            std::uint64_t number, TimeNs start, ChannelId channel,
                            ChannelState& st);
  // The profile's timing rules (docs/protocols.md, each drive's section) under the telegram's
  // channel's `timing` (none judged where its silences are not trusted): findings into `found`,
  // their detail written only when `described`.
  void check_drive_timing(const TelegramHead& telegram, const DriveProfile& profile,
                          const FramingTiming& timing, std::vector<Anomaly>& found, bool described);
  // The profile of the telegram's station: bound with --drive, or by the binder (which learns
  // from the telegram first, and hands a change of binding to the sink); nullptr for none.
  // `sure`: bound with --drive, or by the binder with confidence high.
  const DriveProfile* drive_profile_for(std::size_t link, TelegramDriveRecords& telegram,
                                        bool& sure);
  // Findings that depend on the family (timing rules) of a station the binder has bound but is
  // not sure of yet are held: handed on when it is sure, or when the input ends with the binding
  // standing; dropped with a binding that is let go or taken over. `found` is emptied.
  void hold_family_findings(std::size_t link, int address, const DriveProfile& profile,
                            std::vector<Anomaly>& found);
  // What the station's binding now says of its held findings; the number dropped.
  std::size_t settle_held_findings(std::size_t link, int address, const DriveProfile* profile,
                                   bool sure);
  void summarise_drives();
  // `now`: the time detection decides at (the byte that made it decide, or the clock).
  void detect(ChannelState& st, ChannelId channel, TimeNs now, bool final, bool deadline = false);
  void start_detection(ChannelState& st);
  // The direction of a frame starting at `start`; `precheck`: its decoder's, or nullptr.
  [[gnu::always_inline]] Direction decide_direction(const ProtocolDecoder& decoder, TimeNs start,
                                                    std::span<const std::uint8_t> bytes,
                                                    int address, int function, std::size_t link,
                                                    ChannelRole role,
                                                    const TelegramPrecheck* precheck) const;
  // Counts and hands over `transactions` (none, most of the calls: inline), then empties it.
  void emit_transactions(std::vector<Transaction>& transactions) {
    if (!transactions.empty()) emit_some_transactions(transactions);
  }
  void emit_some_transactions(std::vector<Transaction>& transactions);
  void emit_anomaly(const Anomaly& a);

  PipelineOptions options_;
  FramingTiming untrusted_timing_;  // options_.timing without silences (distrust_silences())
  const ChannelTable& channels_;
  Sink& sink_;
  Pairer pairer_;
  Stats stats_;
  std::vector<std::unique_ptr<ChannelState>> states_;
  FrameBatch ready_;
  // Reused from frame to frame so that the hot path does not allocate: the batch being handled
  // (ready_ swaps with it).
  FrameBatch batch_;
  FrameBatch detection_scratch_;  // frames the detection candidates cut, scored and dropped
  FrameQueue waiting_;  // closed frames waiting for the channels that may close earlier ones
  // Protocol detections, handed on in time order with the frames (just before the first frame
  // they do not follow), oldest first.
  std::vector<BusEvent> pending_events_;
  bool in_batch_ = false;
  std::vector<ByteEvent> run_;  // push_batch: the run going to a framer at once
  std::vector<Transaction> transactions_;
  Message message_;  // every frame is decoded into this one (its storage is reused)
  bool hand_over_transactions_ = true;  // the sink's needs' transactions
  bool defer_drive_info_ = false;       // the sink's needs' drive_info, with detail
  // Telegrams taken whole are handled at once, not decoded in detail here: the sink takes no
  // records or decodes them itself (and, with drive profiles, writes their annotation), and no
  // frame limit stops the run.
  bool whole_telegrams_direct_ = false;
  bool drive_level_ = false;  // profiles bound with --drive, or candidates for binding by guess
  // A telegram dissected to its head, with drive profiles: its timing-rule findings.
  std::vector<Anomaly> drive_anomalies_;
  // hold_family_findings(): per station, the profile they were found with and the findings (at
  // most kMaxHeldFindings described; past it counted alone, by kind).
  struct HeldFindings {
    const DriveProfile* profile = nullptr;
    std::vector<Anomaly> findings;
    AnomalyCounts left_out{};
  };
  static constexpr std::size_t kMaxHeldFindings = 1024;
  std::map<DriveBinder::Key, HeldFindings> held_findings_;
  // Per station bound by the binder: the timing-rule findings handed on under its binding,
  // withdrawn from the counts with a binding let go or taken over.
  std::map<DriveBinder::Key, std::uint64_t> findings_under_binding_;
  void count_under_binding(std::size_t link, int address, std::size_t n) {
    if (n) findings_under_binding_[{link, address}] += n;
  }
  bool hand_over_records_ = true;       // the sink's needs' records
  bool hand_over_events_ = true;        // the sink's needs' events: drive state changes as events
  bool hand_over_drive_values_ = true;  // the sink's needs' drive_values
  bool drive_values_at_hand_over_ = false;  // the sink's needs' drive_values_at_hand_over
  TimeNs earliest_deadline_;
  std::uint64_t frame_counter_ = 0;
  TimeNs latest_time_ = std::numeric_limits<TimeNs>::min();
  std::map<int, TimeNs> last_reply_end_;  // per station address, for profile timing rules
  DriveBinder binder_;
  DriveTimeline timeline_;
  DriveReading drive_reading_;            // every frame's drive reading (its storage is reused)
  std::vector<DriveValue> drive_values_;  // a deferred telegram's, from drive_reading_
  // Every frame's drive records, read once for the binder and the annotation (storage reused).
  DriveRecordReader drive_records_;
  bool finished_ = false;
};

}  // namespace drivetap
