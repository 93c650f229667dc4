// The display filter's sink (src/filter/filter_sink.hpp).
#include "filter/filter_sink.hpp"

#include <utility>
#include <vector>

namespace drivetap {
namespace {

// Frames back that a later record can still find its selected frame in (a request's timeout
// comes a second or so after it: a few hundred frames on a busy bus).
constexpr std::size_t kRecentFrames = 1u << 16;

}  // namespace

DisplayFilterSink::DisplayFilterSink(DisplayFilter filter, Sink& inner,
                                     const ChannelTable& channels, TimeNs character_time,
                                     bool show_latency)
    : filter_(std::move(filter)),
      inner_(inner),
      inner_needs_(inner.needs()),
      by_head_(!filter_.needs().message && (!inner_needs_.records || inner_needs_.deferred_decode)),
      views_(channels, character_time, show_latency),
      recent_selected_(kRecentFrames, 0) {}

SinkNeeds DisplayFilterSink::needs() const {
  SinkNeeds n = inner_needs_;
  n.records = true;
  if (by_head_) {
    // Telegrams taken whole come undecoded; the others decoded as the inner sink needs them
    // (the filter reads none of the detail, nor the annotation the inner sink may write).
    n.deferred_decode = true;
    return n;
  }
  // Every frame comes here, decoded here: the filter reads its Message on this thread, and the
  // texts only when it or the inner sink reads them.
  const RecordFieldNeeds f = filter_.needs();
  n.detail = inner_needs_.detail || f.detail || f.tree;
  n.fields = (inner_needs_.detail && inner_needs_.fields) || f.tree;
  n.info_text = (inner_needs_.detail && inner_needs_.info_text) || f.detail;
  n.drive_info = false;
  n.deferred_decode = false;
  return n;
}

void DisplayFilterSink::release_events(std::uint64_t number, bool selected) {
  if (held_events_.empty()) return;
  for (const BusEvent& e : held_events_)
    if (e.frame == number && selected) inner_.on_event(e);
  std::erase_if(held_events_, [number](const BusEvent& e) { return e.frame <= number; });
}

void DisplayFilterSink::note(std::uint64_t number, bool selected) {
  release_events(number, selected);
  last_number_ = number;
  ++records_;
  recent_selected_[number % kRecentFrames] = selected ? number : 0;
  if (selected) ++matched_;
}

bool DisplayFilterSink::selected(std::uint64_t number) const {
  return number != 0 && recent_selected_[number % kRecentFrames] == number;
}

void DisplayFilterSink::on_frame(const Message& m) {
  const RecordView r = views_.of(m);
  const bool pass = filter_.matches(r);
  note(m.frame.number, pass);
  if (pass) inner_.on_frame(m);
}

void DisplayFilterSink::on_deferred_frame(const DeferredTelegram& telegram) {
  const bool pass = filter_.matches(views_.of(telegram));
  note(telegram.number, pass);
  // (by_head_: an inner sink that takes records decodes them itself)
  if (pass && inner_needs_.records) inner_.on_deferred_frame(telegram);
}

void DisplayFilterSink::on_noise(const Frame& f) {
  const RecordView r = views_.of(f);
  const bool pass = filter_.matches(r);
  note(f.number, pass);
  if (pass) inner_.on_noise(f);
}

void DisplayFilterSink::on_anomaly(const Anomaly& a) {
  if (selected(a.frame_number)) inner_.on_anomaly(a);
}

void DisplayFilterSink::on_transaction(const Transaction& t) {
  if (selected(t.request_number) || selected(t.response_number)) inner_.on_transaction(t);
}

void DisplayFilterSink::on_event(const BusEvent& e) {
  if (e.frame > last_number_)
    held_events_.push_back(e);
  else if (selected(e.frame))
    inner_.on_event(e);
}

void DisplayFilterSink::on_summary(const Stats& s) {
  Stats with_filter = s;
  with_filter.display_filter = filter_.text();
  with_filter.filter_matched = matched_;
  with_filter.filter_records = records_;
  inner_.on_summary(with_filter);
}

}  // namespace drivetap
