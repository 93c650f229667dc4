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
    : ForwardingSink(inner),
      filter_(std::move(filter)),
      views_(channels, character_time, show_latency),
      recent_selected_(kRecentFrames, 0) {}

SinkNeeds DisplayFilterSink::needs() const {
  // Every frame comes here, decoded here (ForwardingSink): the filter reads its Message on this
  // thread.
  SinkNeeds n = ForwardingSink::needs();
  n.records = true;
  n.detail = n.detail || filter_.needs().detail;
  n.fields = (n.detail && n.fields) || filter_.needs().tree;
  n.drive_values = n.drive_values || filter_.needs().drive_values;
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

bool DisplayFilterSink::selected(std::uint64_t number) const {
  return number != 0 && recent_selected_[number % kRecentFrames] == number;
}

void DisplayFilterSink::on_anomaly(const Anomaly& a) {
  if (selected(a.frame_number)) next_.on_anomaly(a);
}

void DisplayFilterSink::on_transaction(const Transaction& t) {
  if (selected(t.request_number) || selected(t.response_number)) next_.on_transaction(t);
}

void DisplayFilterSink::on_event(const BusEvent& e) {
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
  next_.on_summary(with_filter);
}

}  // namespace drivetap
