// `drivetap report`: the sink that draws a capture as one self-contained HTML page (timing per
// docs/protocols.md §1; what the page holds: docs/reference.md "Report"). It keeps fixed-size
// series, never the records: every value over time falls into one of kColumns columns (a pixel
// column of the chart) holding its minimum and maximum, and when the time span outgrows the
// columns their width doubles and neighbours merge pairwise, so memory stays flat whatever the
// capture's length.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "core/byte_event.hpp"
#include "core/serial_config.hpp"
#include "core/time.hpp"
#include "drive/drive_fields.hpp"
#include "sinks/sink.hpp"
#include "sinks/stats_tables.hpp"

namespace drivetap {

// Cells over time from a common origin: kColumns of them, each `width` ns wide; a time beyond the
// last column doubles the width, merging cells pairwise (Cell::merge). Times before the origin
// fall into the first column.
template <class Cell>
class ColumnSeries {
 public:
  static constexpr std::size_t kColumns = 1024;
  static constexpr TimeNs kFirstWidth = kNsPerMs;

  // The cell holding time `t` (ns from the origin).
  Cell& at(TimeNs t) {
    if (cells_.empty()) cells_.resize(kColumns);
    if (t < 0) t = 0;
    while (t / width_ >= static_cast<TimeNs>(kColumns)) widen();
    const auto k = static_cast<std::size_t>(t / width_);
    used_ = std::max(used_, k + 1);
    return cells_[k];
  }
  // Makes the columns at least `width` wide (series drawn on one grid share their width).
  void widen_to(TimeNs width) {
    while (width_ < width) widen();
  }
  [[nodiscard]] TimeNs width() const { return width_; }
  [[nodiscard]] std::size_t used() const { return used_; }
  [[nodiscard]] const Cell& cell(std::size_t k) const { return cells_[k]; }

 private:
  void widen() {
    for (std::size_t k = 0; k < cells_.size() / 2; ++k) {
      Cell merged = cells_[2 * k];
      merged.merge(cells_[2 * k + 1]);
      cells_[k] = merged;
    }
    for (std::size_t k = cells_.size() / 2; k < cells_.size(); ++k) cells_[k] = Cell{};
    used_ = (used_ + 1) / 2;
    width_ *= 2;
  }

  std::vector<Cell> cells_;
  TimeNs width_ = kFirstWidth;
  std::size_t used_ = 0;
};

// One capture of the report, as the header shows it.
struct ReportCapture {
  std::string file;
  std::string format;    // "pcapng", "byte log", ...
  std::string line;      // "19200 8E1"
  FramingTiming timing;  // t1.5, t3.5, character time
  bool wall_clock = false;
  TimeNs shift = 0;              // added to its times to place it on the report's timeline
  TimeNs first = -1, last = -1;  // on the timeline
  std::uint64_t frames = 0;
  std::string stations_json;  // its -z stations and -z gaps records (JSON lines)
};

class ReportSink final : public Sink {
 public:
  // Events kept to mark on the charts, per drive and in all; the rest are counted.
  static constexpr std::size_t kMaxEventsPerDrive = 400;
  static constexpr std::size_t kMaxEvents = 4000;
  // Columns of the findings heatmap (each a few of the series' columns).
  static constexpr std::size_t kHeatColumns = 128;
  // What the page holds however many stations a capture has (docs/reference.md "Report"): the
  // busiest stations' rows and latency histograms, the rest summed in one row; the busiest
  // channels' load; the first drives
  // charted; the findings rows with the most findings, the rest one row per kind. Kept in memory:
  // each station's counts, and up to kMaxFindingRows rows of findings (those past it are counted
  // in their kind's "other stations" row).
  static constexpr std::size_t kStationRows = 64;
  static constexpr std::size_t kLoadChannels = 16;
  static constexpr std::size_t kLatencyCharts = 48;
  static constexpr std::size_t kMaxDrives = 128;
  static constexpr std::size_t kFindingRows = 64;
  static constexpr std::size_t kMaxFindingRows = 1024;
  static constexpr int kOtherStations = -2;  // a findings row of stations not listed alone

  explicit ReportSink(const ChannelTable& channels);

  // The next capture: its records' times are shifted by `capture.shift` onto the timeline.
  void begin_capture(ReportCapture capture);
  // What the current capture's times are shifted by.
  [[nodiscard]] TimeNs current_shift() const { return shift_; }
  // The end of the latest record so far on the shifted clock (-1 before any).
  [[nodiscard]] TimeNs timeline_end() const { return have_origin_ ? origin_ + last_ : -1; }
  // The capture ended; `stations_json`: its -z stations and gaps records.
  void end_capture(std::string stations_json);

  void on_frame(const Message& message) override;
  void on_noise(const Frame& noise) override;
  void on_anomaly(const Anomaly& anomaly) override;
  void on_transaction(const Transaction& transaction) override;
  void on_event(const BusEvent& event) override;
  void on_summary(const Stats& stats) override;
  bool flush() override { return true; }
  [[nodiscard]] SinkNeeds needs() const override;

  // The page: the template (src/sinks/report_page.html) with the plotting library and the data
  // inlined; `diagnosis_json` the diagnose verdicts of each capture (a JSON array, one object a
  // capture, in order). Returns false when a write to `out` failed.
  bool write_page(std::FILE* out, const std::string& diagnosis_json) const;
  // The page's data alone (one JSON object), as write_page() embeds it.
  [[nodiscard]] std::string data_json(const std::string& diagnosis_json) const;

 private:
  struct MinMax {
    float min = 0, max = 0;
    std::uint32_t count = 0;
    void add(double v) {
      const auto f = static_cast<float>(v);
      if (count == 0 || f < min) min = f;
      if (count == 0 || f > max) max = f;
      ++count;
    }
    void merge(const MinMax& o) {
      if (o.count == 0) return;
      if (count == 0 || o.min < min) min = o.min;
      if (count == 0 || o.max > max) max = o.max;
      count += o.count;
    }
  };
  struct Busy {
    TimeNs busy = 0;
    std::uint32_t frames = 0;
    void merge(const Busy& o) {
      busy += o.busy;
      frames += o.frames;
    }
  };
  // A drive's states in a column: every state it was in (`bits`, what the column is coloured by)
  // and the one it was in at the column's end (`last`, what holds until the next column with any).
  struct Bits {
    std::uint8_t bits = 0;
    std::uint8_t last = 0;
    void set(std::uint8_t state) {
      bits |= state;
      last = state;
    }
    void merge(const Bits& o) {
      bits |= o.bits;
      if (o.bits) last = o.last;
    }
  };
  struct Count {
    std::uint32_t count = 0;
    void merge(const Count& o) { count += o.count; }
  };
  // A station: the capture it is in (its index: two files' station 1 are two stations), then
  // channel, protocol and address, as -z stations keys it.
  using StationKey = std::tuple<std::size_t, ChannelId, std::string_view, int>;
  // A drive: capture, link and address. A finding row: kind, capture and station (the capture
  // kAllCaptures for the other stations' row).
  using DriveKey = std::tuple<std::size_t, std::size_t, int>;
  using FindingKey = std::tuple<AnomalyKind, std::size_t, int>;
  static constexpr std::size_t kAllCaptures = static_cast<std::size_t>(-1);
  struct Station {
    LogHistogram latency;
    std::uint64_t requests = 0, replies = 0, timeouts = 0, exceptions = 0;
  };
  // Drive state bits of a column: what the drive was while polled in it.
  static constexpr std::uint8_t kRunning = 1, kStopped = 2, kFault = 4, kUnknown = 8;
  struct DriveEvent {
    TimeNs time = 0;
    std::string kind, detail;
  };
  struct Drive {
    std::string profile, name;
    std::size_t capture = 0;
    std::size_t link = 0;
    int address = -1;
    ChannelId channel = 0;
    // By drive value id, in the order first seen (a handful: looked up in turn).
    std::vector<std::pair<std::string, ColumnSeries<MinMax>>> series;
    std::map<std::string, std::string> units;
    ColumnSeries<Bits> states;
    std::optional<bool> running;
    bool fault_code = false, fault_word = false;
    std::vector<DriveEvent> events;
    std::uint64_t events_left_out = 0;
  };
  struct FindingRow {
    ColumnSeries<Count> cells;
    std::uint64_t count = 0;
  };

  [[nodiscard]] TimeNs on_timeline(TimeNs t) const;
  // The index of the capture being read (0 before the first).
  [[nodiscard]] std::size_t capture_index() const {
    return captures_.empty() ? 0 : captures_.size() - 1;
  }
  // `t` on the shifted clock (the origin's), held within +-2^62.
  [[nodiscard]] TimeNs shifted(TimeNs t) const;
  void count_busy(ChannelId channel, std::size_t bytes, TimeNs start, bool telegram);
  void count_finding(AnomalyKind kind, int station, TimeNs t);
  static void mark_state(Drive& d, TimeNs t);
  // The drive's series, or null for a drive past the first kMaxDrives (then counted).
  Drive* drive_of(std::size_t link, int address);

  const ChannelTable& channels_;
  std::vector<ReportCapture> captures_;
  TimeNs shift_ = 0;
  TimeNs character_time_ = 0;
  bool have_origin_ = false;
  TimeNs origin_ = 0;              // the timeline's first record (ns, the captures' own clock)
  TimeNs first_ = -1, last_ = -1;  // from the origin
  std::map<ChannelId, ColumnSeries<Busy>> load_;
  std::map<StationKey, Station> stations_;
  std::map<DriveKey, Drive> drives_;
  std::set<DriveKey> drives_left_out_;  // past kMaxDrives
  Drive* last_drive_ = nullptr;         // the drive of the last frame read (most frames: the same)
  StationKey last_station_key_;
  Station* last_station_ = nullptr;
  std::size_t events_kept_ = 0;
  std::map<FindingKey, FindingRow> findings_;
  std::array<std::uint64_t, kAnomalyKindCount> finding_totals_{};
  // The last frame and the last transaction's request: the station of the findings that follow.
  std::uint64_t last_frame_ = 0;
  int last_frame_address_ = -1;
  std::uint64_t last_request_ = 0;
  int last_request_address_ = -1;
  Stats totals_;  // the captures' summaries, added up
  std::uint64_t summaries_ = 0;
};

}  // namespace drivetap
