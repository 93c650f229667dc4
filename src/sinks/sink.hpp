// Sink: where the pipeline's records go (text, JSON, pcapng). Sinks walk the generic field
// tree; they know no protocol. Records arrive in bus order: for each frame, the timeouts it
// revealed, then the frame (or noise), then its anomalies, then the transaction it completed.
// The contract is a handful of event methods and one description of what the sink needs
// (SinkNeeds); formatting on several threads is a separate, smaller one (FormattingSink).
#pragma once

#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <span>
#include <string_view>
#include <vector>

#include "core/anomaly.hpp"
#include "core/bus_event.hpp"
#include "core/byte_event.hpp"
#include "core/drive_values.hpp"
#include "core/frame.hpp"
#include "core/line_buffer.hpp"
#include "core/message.hpp"
#include "core/protocol.hpp"
#include "core/stats.hpp"
#include "core/transaction.hpp"

namespace drivetap {

// The bytes of a cache line (x86-64, most ARM cores): what the threaded sink and its helpers,
// written by different threads for every record, are aligned to (alignas), so that no line holds
// parts of two of them: a line shared by two writing threads goes back and forth between cores.
inline constexpr std::size_t kCacheLineBytes = 64;

// Whether a sink's writes to its file failed, and the first failure's errno. Records may be
// written on another thread than the one that flushes (ThreadedSink), and errno is per thread:
// it is kept here when the write fails.
class WriteStatus {
 public:
  void note_failure() {
    if (errno_ == 0) errno_ = errno != 0 ? errno : EIO;
  }
  [[nodiscard]] bool failed() const { return errno_ != 0; }
  // Flushes `file`; true when every write to it went through, else false with errno set to the
  // first failure's (or to fflush's own, when that is the first).
  bool flush(std::FILE* file) const {
    const bool ok = std::fflush(file) == 0 && !failed() && !std::ferror(file);
    if (!ok && failed()) errno = errno_;
    return ok;
  }

 private:
  int errno_ = 0;
};

// A frame record handed over undecoded, for a sink that decodes it itself, off the decoding
// thread (SinkNeeds::deferred_decode): a telegram its framer took whole (Framer::take_whole), with
// what only the pipeline knows of it. Spans are valid for the call that hands it over.
struct DeferredTelegram {
  const ProtocolDecoder* decoder = nullptr;
  FramingTiming timing;      // the run's, which the decoder judges gaps by
  ByteRun run;               // the telegram's bytes and times (no UART marks)
  Framer::WholeFrame taken;  // its timing and carried checksum
  std::uint64_t number = 0;  // the frame's number
  Direction direction = Direction::unknown;
  TimeNs latency = -1;  // pairing, for a reply
  std::uint64_t request_number = 0;
  std::span<const std::uint8_t> request;  // for a reply: the request it answers, if known
  // With drive profiles: the profile whose annotation the sink writes (Message::drive_profile,
  // SinkNeeds::drive_info), nullptr for none; and what the pipeline found of the telegram's
  // timing under the profile's rules, numbered with the frame, which follow the decode's own
  // anomalies.
  const DriveProfile* drive_profile = nullptr;
  std::span<const Anomaly> anomalies;
  // With drive profiles: the values the pipeline's drive level read (Message::drive_values).
  std::span<const DriveValue> drive_values;
  // With drive_profile: the values are not given above but collected by the reading that writes
  // the annotation (complete_drive_info_and_values(), drive/drive_fields.hpp), the same values
  // from the same reading, made on the sink's thread and into the message at once.
  bool drive_values_with_annotation = false;
  // What the pipeline's dissection to DissectDepth::head found of the telegram (keys, checksum
  // verdict, finding kinds), for a sink that judges it by its head (the display filter). Valid
  // during on_deferred_frame() only: a copy kept for later must not read it.
  const TelegramFindings* head = nullptr;
  // The head found the telegram plausible (TelegramView::known_plausible): the decode here
  // does not check the rules a second time.
  bool plausible = false;

  // Its decoder's dissection of the frame alone, into `out` (what decode_into() starts from).
  void dissect_into(Message& out) const { dissect_to(DissectDepth::detail, out); }
  // Its field tree alone (DissectDepth::fields), into `out`.
  void dissect_fields_into(Message& out) const { dissect_to(DissectDepth::fields, out); }
  void dissect_to(DissectDepth depth, Message& out) const {
    TelegramView t;
    t.run = run;
    t.taken = taken;
    t.known_plausible = plausible;
    decoder->dissect(t, direction, timing, request, depth, out, nullptr);
  }
  // The Message the pipeline would have handed over: its decoder's dissection of the frame, with
  // the pipeline's numbers, pairing and drive-level findings, each anomaly numbered with the
  // frame, and the profile whose annotation is still to write. `out`'s storage is reused.
  void decode_into(Message& out) const {
    dissect_into(out);
    out.frame.number = number;
    out.latency = latency;
    out.request_number = request_number;
    out.silences_trusted = timing.silences_trusted;
    for (Anomaly& a : out.anomalies) a.frame_number = number;
    if (!anomalies.empty())
      out.anomalies.insert(out.anomalies.end(), anomalies.begin(), anomalies.end());
    if (drive_profile) {
      out.drive_profile = drive_profile;
      out.drive_read_with = drive_profile;
      out.request.assign(request.begin(), request.end());
    }
    out.drive_values.assign(drive_values.begin(), drive_values.end());
  }
};

// What a sink needs of the pipeline, fixed for the sink's lifetime: the pipeline reads it once
// (Sink::needs()) and skips the work no sink asks for. The defaults are a sink that shows
// everything and completes nothing itself.
struct SinkNeeds {
  // on_frame(), on_noise(), on_anomaly() and on_transaction() do something; when not, the
  // pipeline counts what the summary needs of a telegram without decoding it in detail
  // (`read --stats`).
  bool records = true;
  // Messages' field trees and info lines (Message::detail); dissectors skip them otherwise.
  bool detail = true;
  // Messages' field trees (Message::tree); read only with `detail`.
  bool fields = true;
  // With `detail`: the info lines and drive annotations too (Message::info_text); false only for
  // a sink that reads the field tree alone (the display filter's).
  bool info_text = true;
  // on_transaction() does something; transactions are still counted when not.
  bool transactions = true;
  // on_event() does something; drive state is still kept and its changes counted when not.
  bool events = true;
  // The sink writes the drive annotation of the messages it gets (Message::drive_profile ->
  // drive_info) before anything reads them (the ThreadedSink, on its writer thread).
  bool drive_info = false;
  // The sink decodes telegrams handed over undecoded (Sink::on_deferred_frame()) more cheaply
  // than the pipeline would (the ThreadedSink, on its writer thread).
  bool deferred_decode = false;
  // With drive profiles: each frame's drive values (Message::drive_values, the `drive.*` fields
  // and the JSON record's drive object), collected by the pipeline's drive level.
  bool drive_values = true;
  // With drive_values: the sink reads a telegram's values when it is handed over undecoded (the
  // display filter judging it by its head), so the pipeline collects them then
  // (DeferredTelegram::drive_values), not the sink's reading that writes the annotation.
  bool drive_values_at_hand_over = false;

  // What a sink handing every record to both `a` and `b` needs: all either asks for, and
  // nothing completed by the sink (each member gets the same, completed, record).
  [[nodiscard]] static SinkNeeds either(const SinkNeeds& a, const SinkNeeds& b) {
    SinkNeeds n;
    n.records = a.records || b.records;
    n.detail = a.detail || b.detail;
    n.fields = (a.detail && a.fields) || (b.detail && b.fields);
    n.info_text = !(a.detail || b.detail) || (a.detail && a.info_text) || (b.detail && b.info_text);
    n.transactions = a.transactions || b.transactions;
    n.events = a.events || b.events;
    n.drive_values = a.drive_values || b.drive_values;
    n.drive_values_at_hand_over = a.drive_values_at_hand_over || b.drive_values_at_hand_over;
    return n;
  }
  // Nothing at all (the start of either() over a set of sinks).
  [[nodiscard]] static SinkNeeds none() {
    SinkNeeds n;
    n.records = n.detail = n.fields = n.transactions = n.events = n.drive_values = false;
    return n;
  }
};

// The contract: the pipeline's records, in bus order, and one description of what the sink
// needs (needs()). Records may arrive on another thread than the one that made the sink only
// through a ThreadedSink. Every sink takes the frames and the noise, the bus's bytes; the other
// records a sink without a use for them ignores (these defaults).
class Sink {
 public:
  virtual ~Sink() = default;
  virtual void on_frame(const Message& message) = 0;
  virtual void on_noise(const Frame& noise) = 0;
  // Anomalies of a frame arrive right after it (frame_number set); others stand alone.
  virtual void on_anomaly(const Anomaly& anomaly) { (void)anomaly; }
  virtual void on_transaction(const Transaction& transaction) { (void)transaction; }
  virtual void on_summary(const Stats& stats) { (void)stats; }
  // Conclusions about the bus (protocol detected on a channel).
  virtual void on_event(const BusEvent& event) { (void)event; }
  // Pushes buffered output to its file; returns false when a write failed, with errno saying why.
  virtual bool flush() = 0;
  [[nodiscard]] virtual SinkNeeds needs() const { return {}; }
  // The frame record handed over undecoded (only to a sink whose needs() say deferred_decode):
  // its Message (DeferredTelegram::decode_into()) as on_frame() and that message's anomalies as
  // on_anomaly(), exactly what the pipeline would have handed over. This default decodes here.
  virtual void on_deferred_frame(const DeferredTelegram& telegram) {
    const SinkNeeds n = needs();
    Message m;
    m.detail = n.detail;
    m.tree = n.detail && n.fields;
    telegram.decode_into(m);
    on_frame(m);
    for (const Anomaly& a : m.anomalies) on_anomaly(a);
  }
};

// A sink that can format on several threads (the text and JSON sinks, for a ThreadedSink with
// helpers: sinks like its inner one, each writing a batch of records into memory while the
// others write theirs):
// - formatted(): a sink made to write into memory gives the text it wrote since it was last
//   cleared (the caller writes it elsewhere and clears it); nullptr for other sinks;
// - write_formatted(): appends text that such a sink of the same kind formatted for the
//   records that come next, as this sink would have written them;
// - follow(): the records that come next follow the frame or noise record numbered `number`
//   (what a sink shows differently right after its frame, e.g. the frame's anomalies).
class FormattingSink : public Sink {
 public:
  virtual LineBuffer* formatted() = 0;
  virtual void write_formatted(std::string_view text) = 0;
  virtual void follow(std::uint64_t number) { (void)number; }
};

// Sends every record to several sinks.
class TeeSink final : public Sink {
 public:
  void add(Sink* s) { sinks_.push_back(s); }
  [[nodiscard]] bool empty() const { return sinks_.empty(); }
  void on_frame(const Message& m) override { to_each(&Sink::on_frame, m); }
  void on_noise(const Frame& f) override { to_each(&Sink::on_noise, f); }
  void on_anomaly(const Anomaly& a) override { to_each(&Sink::on_anomaly, a); }
  void on_transaction(const Transaction& t) override { to_each(&Sink::on_transaction, t); }
  void on_event(const BusEvent& e) override { to_each(&Sink::on_event, e); }
  void on_summary(const Stats& st) override { to_each(&Sink::on_summary, st); }
  bool flush() override {
    bool ok = true;
    for (Sink* s : sinks_) ok = s->flush() && ok;
    return ok;
  }
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n = SinkNeeds::none();
    for (const Sink* s : sinks_) n = SinkNeeds::either(n, s->needs());
    return n;
  }

 private:
  // Hands `record` to each sink's `handler` (inlined: the same virtual call as written out).
  template <class Record>
  [[gnu::always_inline]] void to_each(void (Sink::*handler)(const Record&), const Record& record) {
    for (Sink* s : sinks_) (s->*handler)(record);
  }

  std::vector<Sink*> sinks_;
};

// Hands every record on to `next_` as it came: the base of a sink in front of another that
// changes some of what passes (it overrides only those events). The calls are the ones a sink
// written out in full makes: one virtual call into the next sink per record. needs() are the next
// sink's, but for the records' completion: this sink may read what it passes on, so it takes
// telegrams decoded and their drive annotation written (on_deferred_frame() is then never
// called; its default decodes here).
class ForwardingSink : public Sink {
 public:
  explicit ForwardingSink(Sink& next) : next_(next) {}
  void on_frame(const Message& m) override { next_.on_frame(m); }
  void on_noise(const Frame& f) override { next_.on_noise(f); }
  void on_anomaly(const Anomaly& a) override { next_.on_anomaly(a); }
  void on_transaction(const Transaction& t) override { next_.on_transaction(t); }
  void on_summary(const Stats& s) override { next_.on_summary(s); }
  void on_event(const BusEvent& e) override { next_.on_event(e); }
  bool flush() override { return next_.flush(); }
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n = next_.needs();
    n.drive_info = n.deferred_decode = false;
    return n;
  }

 protected:
  Sink& next_;
};

// Drops the frame, noise, anomaly and transaction records: the sinks below pass on to the next
// sink only the summary or only the events.
class RecordDroppingSink : public ForwardingSink {
 public:
  using ForwardingSink::ForwardingSink;
  void on_frame(const Message&) override {}
  void on_noise(const Frame&) override {}
  void on_anomaly(const Anomaly&) override {}
  void on_transaction(const Transaction&) override {}
};

// Passes on only the closing summary: `drivetap read --stats` decodes everything and prints
// nothing per frame (no formatting cost either).
class SummaryOnlySink final : public RecordDroppingSink {
 public:
  using RecordDroppingSink::RecordDroppingSink;
  void on_event(const BusEvent&) override {}
  [[nodiscard]] SinkNeeds needs() const override { return SinkNeeds::none(); }
};

// Passes on only the events — the drive-state timeline with the bindings and protocol detection
// that explain it (`drivetap read --events`).
class EventsOnlySink final : public RecordDroppingSink {
 public:
  using RecordDroppingSink::RecordDroppingSink;
  void on_summary(const Stats&) override {}
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n;
    n.records = n.fields = n.transactions = false;
    return n;
  }
};

}  // namespace drivetap
