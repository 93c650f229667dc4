// The display filter's sink (-Y): hands on to its inner sink only the frame and noise records a
// DisplayFilter selects, with what belongs to them (docs/reference.md "Display filters"): their
// findings, the transactions and the drive events of a selected frame. Records that belong to no
// frame (protocol detection, a source's findings) are left out, as tshark -Y shows only packets.
// The summary counts everything, and says how many records the filter selected.
//
// A filter naming a finding reported after its frame (unanswered_request, ...) is also evaluated
// against that finding's own record (its n, t, channel and its frame's protocol, addr, fc): a
// match shows the finding, with the transaction that reported it.
//
// Where the pipeline takes a telegram whole, the filter judges it by its head: the telegram comes
// undecoded (on_deferred_frame()), and only one the filter selects is decoded, by the inner sink.
// A name no head holds is read of the telegram decoded here when the filter first reads it
// (TelegramDecode): a tree id of its tree of the filter's ids alone, a text (summary, drive, a
// finding's) of its Message; a finding id only when the head has a finding of its kind. A filter
// decodes only the telegrams whose cheaper tests did not decide first.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "filter/display_filter.hpp"
#include "sinks/sink.hpp"

namespace drivetap {

class DisplayFilterSink final : public ForwardingSink {
 public:
  // `show_latency`: the records have real times (as the JSON sink's).
  DisplayFilterSink(DisplayFilter filter, Sink& inner, const ChannelTable& channels,
                    TimeNs character_time, bool show_latency);

  void on_frame(const Message& m) override;
  void on_noise(const Frame& f) override;
  void on_anomaly(const Anomaly& a) override;
  void on_transaction(const Transaction& t) override;
  void on_event(const BusEvent& e) override;
  void on_summary(const Stats& s) override;
  void on_deferred_frame(const DeferredTelegram& telegram) override;
  [[nodiscard]] SinkNeeds needs() const override;

  [[nodiscard]] std::uint64_t matched() const { return matched_; }
  // Every telegram judged by its head is decoded for the filter (DisplayFilter::
  // first_test_decodes()).
  [[nodiscard]] bool decodes_every_telegram() const {
    return by_head_ && filter_.first_test_decodes();
  }

 private:
  void note(std::uint64_t number, bool selected);
  // Hands on the events held for frame `number` (those of a selected frame), before the frame as
  // they came, and drops them.
  void release_events(std::uint64_t number, bool selected);
  [[nodiscard]] bool selected(std::uint64_t number) const;
  // `m`, with its drive annotation written where the filter reads it and the pipeline left it to
  // the sinks (SinkNeeds::drive_info).
  const Message& annotated(const Message& m);
  // Notes what a late finding's record says of the frame `r` (a filter naming late findings).
  void note_late_frame(const RecordView& r);

  DisplayFilter filter_;
  SinkNeeds inner_needs_;
  // Telegrams are judged by their head when they come undecoded (decided once, from what the
  // inner sink takes).
  bool by_head_ = false;
  RecordViews views_;
  // A telegram judged by its head: decoded when the filter first reads what no head holds.
  TelegramDecode telegram_decode_;
  // The numbers of the latest selected frames, each at its number modulo the size: a transaction
  // or finding reported later (a timeout) finds its frame here. Fixed size: no allocation.
  std::vector<std::uint64_t> recent_selected_;
  // Events read from a frame not handed over yet (a drive bound by the frame that showed it):
  // held until the filter has judged their frame.
  std::vector<BusEvent> held_events_;
  // A filter naming late findings: what their records say of the latest frames (at the number
  // modulo the size, as recent_selected_), and the transaction that is to report one (a timeout
  // or an unsolicited reply of no selected frame), held until its finding is judged.
  std::vector<LateFindingFrame> late_frames_;
  std::optional<Transaction> held_transaction_;
  std::uint64_t last_number_ = 0;  // the latest frame or noise record judged
  std::uint64_t matched_ = 0;
  std::uint64_t matched_late_ = 0;           // findings selected by their own record
  std::uint64_t timing_findings_shown_ = 0;  // (a binding let go may withdraw them)
  std::uint64_t records_ = 0;
  // A frame whose drive annotation the pipeline left to the sinks, annotated for a filter that
  // reads it (annotated()).
  Message annotated_;
  std::unique_ptr<DriveReading> drive_reading_;
};

}  // namespace drivetap
