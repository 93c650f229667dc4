// Sink: where the pipeline's records go (text, JSON, later pcapng). Sinks walk the generic field
// tree; they know no protocol. Records arrive in bus order: for each frame, the timeouts it
// revealed, then the frame (or noise), then its anomalies, then the transaction it completed.
#pragma once

#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <vector>

#include "core/anomaly.hpp"
#include "core/bus_event.hpp"
#include "core/byte_event.hpp"
#include "core/frame.hpp"
#include "core/line_buffer.hpp"
#include "core/message.hpp"
#include "core/protocol.hpp"
#include "core/transaction.hpp"
#include "core/stats.hpp"

namespace drivetap {

// The bytes of a cache line (x86-64, most ARM cores): what the threaded sink and its helpers,
// written by different threads for every record, are aligned to (alignas), so that no line holds
// parts of two of them (bench/README.md, "The cache round").
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

class Sink {
 public:
  virtual ~Sink() = default;
  virtual void on_frame(const Message& message) = 0;
  virtual void on_noise(const Frame& noise) = 0;
  // Anomalies of a frame arrive right after it (frame_number set); others stand alone.
  virtual void on_anomaly(const Anomaly& anomaly) = 0;
  virtual void on_transaction(const Transaction& transaction) = 0;
  virtual void on_summary(const Stats& stats) = 0;
  // Conclusions about the bus (protocol detected on a channel). Sinks without a use ignore them.
  virtual void on_event(const BusEvent& event) { (void)event; }
  // Pushes buffered output to its file; returns false when a write failed, with errno saying why.
  virtual bool flush() = 0;
  // Whether the sink shows messages' field trees and info lines; when no sink of a run does,
  // dissectors skip building them (Message::detail). Fixed for the sink's lifetime.
  [[nodiscard]] virtual bool wants_detail() const { return true; }
  // Whether the sink reads messages' field trees (Message::tree); only with wants_detail().
  [[nodiscard]] virtual bool wants_fields() const { return wants_detail(); }
  // Whether on_transaction() does anything; when not, the pipeline still counts transactions but
  // does not hand them over (a writer thread would copy each). Fixed for the sink's lifetime.
  [[nodiscard]] virtual bool wants_transactions() const { return true; }
  // Whether the sink writes the drive annotation of the messages it gets (Message::drive_profile
  // -> drive_info) before anything reads them; the pipeline then leaves that to it (the
  // ThreadedSink does it on its writer thread, off the decoding one). Fixed for its lifetime.
  [[nodiscard]] virtual bool completes_drive_info() const { return false; }
  // A telegram the pipeline counted without decoding it (only when completes_decode()): its
  // Message (decode_undissected()) as on_frame() and that message's anomalies as on_anomaly(),
  // which is what the pipeline would have handed over. This default decodes it here.
  virtual void on_undissected(const UndissectedTelegram& telegram) {
    Message m;
    m.detail = wants_detail();
    m.tree = m.detail && wants_fields();
    decode_undissected(telegram, m);
    on_frame(m);
    for (const Anomaly& a : m.anomalies) on_anomaly(a);
  }
  // Whether the sink takes telegrams undissected (on_undissected()) where it can decode them
  // more cheaply than the pipeline (the ThreadedSink, on its writer thread): the pipeline then
  // counts the telegrams its framers take whole without decoding them (its summary lane) and
  // hands them over so. Fixed for the sink's lifetime.
  [[nodiscard]] virtual bool completes_decode() const { return false; }
  // Formatting on several threads (a ThreadedSink with helpers: sinks like its inner one, each
  // writing a batch of records into memory while the others write theirs):
  // - formatted(): a sink made to write into memory gives the text it wrote since it was last
  //   cleared (the caller writes it elsewhere and clears it); nullptr for other sinks;
  // - write_formatted(): appends text that such a sink of the same kind formatted for the
  //   records that come next, as this sink would have written them;
  // - follow(): the records that come next follow the frame or noise record numbered `number`
  //   (what a sink shows differently right after its frame, e.g. the frame's anomalies).
  virtual LineBuffer* formatted() { return nullptr; }
  virtual void write_formatted(std::string_view text) { (void)text; }
  virtual void follow(std::uint64_t number) { (void)number; }
  // Whether on_frame(), on_noise(), on_anomaly() and on_transaction() do anything; when not, the
  // pipeline may count what the summary needs of a telegram without decoding it into a Message
  // (its summary lane: `read --stats`). Fixed for the sink's lifetime.
  [[nodiscard]] virtual bool wants_records() const { return true; }
  // Whether on_event() does anything; when not, the pipeline still keeps each drive's state and
  // counts its changes, but writes no event's text (`read --stats`). Fixed for its lifetime.
  [[nodiscard]] virtual bool wants_events() const { return true; }
};

// Sends every record to several sinks.
class TeeSink final : public Sink {
 public:
  void add(Sink* s) { sinks_.push_back(s); }
  void on_frame(const Message& m) override {
    for (Sink* s : sinks_) s->on_frame(m);
  }
  void on_noise(const Frame& f) override {
    for (Sink* s : sinks_) s->on_noise(f);
  }
  void on_anomaly(const Anomaly& a) override {
    for (Sink* s : sinks_) s->on_anomaly(a);
  }
  void on_transaction(const Transaction& t) override {
    for (Sink* s : sinks_) s->on_transaction(t);
  }
  void on_event(const BusEvent& e) override {
    for (Sink* s : sinks_) s->on_event(e);
  }
  void on_summary(const Stats& st) override {
    for (Sink* s : sinks_) s->on_summary(st);
  }
  bool flush() override {
    bool ok = true;
    for (Sink* s : sinks_) ok = s->flush() && ok;
    return ok;
  }
  [[nodiscard]] bool wants_detail() const override { return any_wants(&Sink::wants_detail); }
  [[nodiscard]] bool wants_fields() const override { return any_wants(&Sink::wants_fields); }
  [[nodiscard]] bool wants_transactions() const override {
    return any_wants(&Sink::wants_transactions);
  }
  [[nodiscard]] bool wants_records() const override { return any_wants(&Sink::wants_records); }
  [[nodiscard]] bool wants_events() const override { return any_wants(&Sink::wants_events); }

 private:
  // Whether any member sink answers yes to `wants`.
  [[nodiscard]] bool any_wants(bool (Sink::*wants)() const) const {
    for (const Sink* s : sinks_)
      if ((s->*wants)()) return true;
    return false;
  }
  std::vector<Sink*> sinks_;
};

// Passes on only the closing summary: `drivetap read --stats` decodes everything and prints
// nothing per frame (no formatting cost either).
class SummaryOnlySink final : public Sink {
 public:
  explicit SummaryOnlySink(Sink& inner) : inner_(inner) {}
  void on_frame(const Message&) override {}
  void on_noise(const Frame&) override {}
  void on_anomaly(const Anomaly&) override {}
  void on_transaction(const Transaction&) override {}
  void on_summary(const Stats& s) override { inner_.on_summary(s); }
  bool flush() override { return inner_.flush(); }
  [[nodiscard]] bool wants_detail() const override { return false; }
  [[nodiscard]] bool wants_fields() const override { return false; }
  [[nodiscard]] bool wants_transactions() const override { return false; }
  [[nodiscard]] bool wants_records() const override { return false; }
  [[nodiscard]] bool wants_events() const override { return false; }

 private:
  Sink& inner_;
};

// Passes on only the events — the drive-state timeline with the bindings and protocol detection
// that explain it (`drivetap read --events`).
class EventsOnlySink final : public Sink {
 public:
  explicit EventsOnlySink(Sink& inner) : inner_(inner) {}
  void on_frame(const Message&) override {}
  void on_noise(const Frame&) override {}
  void on_anomaly(const Anomaly&) override {}
  void on_transaction(const Transaction&) override {}
  void on_summary(const Stats&) override {}
  void on_event(const BusEvent& e) override { inner_.on_event(e); }
  bool flush() override { return inner_.flush(); }
  [[nodiscard]] bool wants_fields() const override { return false; }
  [[nodiscard]] bool wants_transactions() const override { return false; }
  [[nodiscard]] bool wants_records() const override { return false; }

 private:
  Sink& inner_;
};

}  // namespace drivetap
