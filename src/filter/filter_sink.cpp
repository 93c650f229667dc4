// The display filter's sink (src/filter/filter_sink.hpp).
#include "filter/filter_sink.hpp"

#include <utility>
#include <vector>

#include "drive/annotate.hpp"

namespace drivetap {
namespace {

// Frames back that a later record can still find its selected frame in (a request's timeout
// comes a second or so after it: a few hundred frames on a busy bus).
constexpr std::size_t kRecentFrames = 1u << 16;

}  // namespace

DisplayFilterSink::DisplayFilterSink(DisplayFilter filter, Sink& inner,
                                     const ChannelTable& channels, TimeNs character_time,
                                     bool show_latency)
    : ForwardingSink(inner),
      filter_(std::move(filter)),
      inner_needs_(inner.needs()),
      by_head_(!inner_needs_.records || inner_needs_.deferred_decode),
      views_(channels, character_time, show_latency),
      telegram_decode_(filter_.tree_ids(), filter_.needs().annotation),
      recent_selected_(kRecentFrames, 0),
      drive_reading_(std::make_unique<DriveReading>()) {
  if (filter_.names_late_findings()) late_frames_.resize(kRecentFrames);
}

SinkNeeds DisplayFilterSink::needs() const {
  SinkNeeds n = inner_needs_;
  n.records = true;
  if (by_head_) {
    // Telegrams taken whole come undecoded (the filter decodes those it reads texts or trees
    // of itself); the others decoded as the inner sink needs them, with the texts and tree the
    // filter reads (below), the annotation left as the inner sink has it (annotated()).
    n.deferred_decode = true;
    if (!inner_needs_.records) {
      // Nothing is decoded for the inner sink: the annotation is left to this sink, which
      // writes it only where the filter reads it (so that the pipeline takes telegrams whole
      // with drive profiles too), and a telegram not taken whole is decoded without tree or
      // texts but those the filter reads.
      n.detail = n.drive_info = true;
      n.fields = false;
      n.info_text = filter_.needs().detail;
    }
    n.drive_values = n.drive_values || filter_.needs().drive_values;
    n.drive_values_at_hand_over = filter_.needs().drive_values;  // (read in on_deferred_frame())
    // A telegram not read to its head (too short, UART marks, another protocol) is read in the
    // tree and with the texts the filter looks into. (With detail, the pipeline also leaves the
    // annotation to the sinks, SinkNeeds::drive_info, and so takes telegrams whole with drive
    // profiles too.)
    if (filter_.needs().tree) n.detail = n.fields = true;
    if (filter_.needs().detail) n.detail = n.info_text = true;
    return n;
  }
  // Every frame comes here, decoded here: the filter reads its Message on this thread, and the
  // texts only when it or the inner sink reads them.
  const RecordFieldNeeds f = filter_.needs();
  n.detail = inner_needs_.detail || f.detail || f.tree;
  n.fields = (inner_needs_.detail && inner_needs_.fields) || f.tree;
  n.info_text = (inner_needs_.detail && inner_needs_.info_text) || f.detail;
  n.drive_values = n.drive_values || f.drive_values;
  n.drive_info = false;
  n.deferred_decode = false;
  return n;
}

void DisplayFilterSink::release_events(std::uint64_t number, bool selected) {
  if (held_events_.empty()) return;
  for (const BusEvent& e : held_events_)
    if (e.frame == number && selected) next_.on_event(e);
  std::erase_if(held_events_, [number](const BusEvent& e) { return e.frame <= number; });
}

void DisplayFilterSink::note(std::uint64_t number, bool selected) {
  release_events(number, selected);
  last_number_ = number;
  ++records_;
  recent_selected_[number % kRecentFrames] = selected ? number : 0;
  if (selected) ++matched_;
}

void DisplayFilterSink::note_late_frame(const RecordView& r) {
  if (late_frames_.empty()) return;
  held_transaction_.reset();
  const LateFindingFrame f = late_finding_frame_of(r);
  late_frames_[f.number % kRecentFrames] = f;
}

bool DisplayFilterSink::selected(std::uint64_t number) const {
  return number != 0 && recent_selected_[number % kRecentFrames] == number;
}

const Message& DisplayFilterSink::annotated(const Message& m) {
  if (!filter_.needs().annotation || !m.drive_profile) return m;
  annotated_ = m;  // (the inner sink gets `m`, and writes the annotation itself)
  complete_drive_info(annotated_, *drive_reading_);
  return annotated_;
}

void DisplayFilterSink::on_frame(const Message& m) {
  const RecordView r = views_.of(annotated(m));
  note_late_frame(r);
  const bool pass = filter_.matches(r);
  note(m.frame.number, pass);
  if (pass) next_.on_frame(m);
}

void DisplayFilterSink::on_deferred_frame(const DeferredTelegram& telegram) {
  RecordView r = views_.of(telegram);
  telegram_decode_.reset(telegram);
  r.decode = &telegram_decode_;
  note_late_frame(r);
  const bool pass = filter_.matches(r);
  note(telegram.number, pass);
  // (by_head_: an inner sink that takes records decodes them itself)
  if (pass && inner_needs_.records) next_.on_deferred_frame(telegram);
}

void DisplayFilterSink::on_noise(const Frame& f) {
  const RecordView r = views_.of(f);
  note_late_frame(r);
  const bool pass = filter_.matches(r);
  note(f.number, pass);
  if (pass) next_.on_noise(f);
}

void DisplayFilterSink::on_anomaly(const Anomaly& a) {
  std::optional<Transaction> reporter;
  reporter.swap(held_transaction_);
  if (selected(a.frame_number)) {
    if (a.kind == AnomalyKind::timing_rule) ++timing_findings_shown_;
    next_.on_anomaly(a);
    return;
  }
  // (A finding that names its station was handed on after its frame; the others a frame's own.)
  if (late_frames_.empty() || !(finding_known_after_frame(a.kind) || a.address >= 0)) return;
  if (!filter_.matches(views_.of(a, late_frames_[a.frame_number % kRecentFrames]))) return;
  if (reporter &&
      (reporter->request_number == a.frame_number || reporter->response_number == a.frame_number))
    next_.on_transaction(*reporter);
  ++matched_late_;
  if (a.kind == AnomalyKind::timing_rule) ++timing_findings_shown_;
  next_.on_anomaly(a);
}

void DisplayFilterSink::on_transaction(const Transaction& t) {
  held_transaction_.reset();
  if (selected(t.request_number) || selected(t.response_number)) {
    next_.on_transaction(t);
  } else if (!late_frames_.empty() &&
             (t.outcome == Outcome::timeout || t.outcome == Outcome::unsolicited)) {
    held_transaction_ = t;  // (the pipeline reports its finding next)
  }
}

void DisplayFilterSink::on_event(const BusEvent& e) {
  held_transaction_.reset();
  // A binding let go withdraws timing-rule findings: where it showed some, the output says so.
  if (e.withdrawn > 0 && timing_findings_shown_ > 0) {
    next_.on_event(e);
    return;
  }
  if (e.frame > last_number_)
    held_events_.push_back(e);
  else if (selected(e.frame))
    next_.on_event(e);
}

void DisplayFilterSink::on_summary(const Stats& s) {
  Stats with_filter = s;
  with_filter.display_filter = filter_.text();
  with_filter.filter_matched = matched_;
  with_filter.filter_records = records_;
  with_filter.filter_late_findings = matched_late_;
  next_.on_summary(with_filter);
}

}  // namespace drivetap
