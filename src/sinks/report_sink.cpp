// `drivetap report`'s sink (src/sinks/report_sink.hpp; timing per docs/protocols.md §1, the page
// in docs/reference.md "Report"): fixed-size series filled while the records stream past, written
// as the data of one HTML page.
#include "sinks/report_sink.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>

#include "core/format.hpp"
#include "drive/profile.hpp"
#include "sinks/json_sink.hpp"
#include "sinks/report_assets.hpp"

namespace drivetap {
namespace {

// Seconds from the timeline's origin, as the page's x axis takes them.
std::string seconds(TimeNs t) {
  return format_seconds(t, 6);
}

// A chart value: short, and null for what JSON cannot hold.
std::string number(double v) {
  if (!std::isfinite(v)) return "null";
  return fmt::format("{:.6g}", v);
}

// The drive values that are a quantity over time, not a key or a word.
bool is_telemetry(const DriveValue& v) {
  if (v.kind == DriveValue::Kind::text) return false;
  if (v.kind == DriveValue::Kind::reg && v.reg) {
    const RegisterDef& reg = *v.reg;
    // A register with a role is drawn under its shared id (setpoint, output_frequency, ...) or
    // as the state bands and events; bits, enumerated codes and words without a unit are not
    // quantities worth a line.
    if (reg.role != RegisterRole::none && !reg.shared_field_id && v.id == reg.field_id)
      return false;
    if (!reg.bits.empty() || !reg.enum_name.empty() || reg.unit.empty()) return false;
  }
  return v.id != "station" && v.id != "running" && v.id != "fault" && v.id != "status_word" &&
         v.id != "control_word";
}

// Hands each group of `factor` cells of `series` (merged) to `emit(column, cell)`, up to the
// last column used: the series drawn at `factor` times its own column width.
template <class Cell, class Emit>
void for_each_column(const ColumnSeries<Cell>& series, TimeNs width, Emit emit) {
  const auto factor = static_cast<std::size_t>(width / series.width());
  for (std::size_t k = 0; k * factor < series.used(); ++k) {
    Cell merged;
    for (std::size_t j = k * factor; j < (k + 1) * factor && j < series.used(); ++j)
      merged.merge(series.cell(j));
    emit(k, merged);
  }
}

}  // namespace

ReportSink::ReportSink(const ChannelTable& channels) : channels_(channels) {}

SinkNeeds ReportSink::needs() const {
  // Records and transactions, without field trees or info lines, with the drive values the
  // pipeline read (Message::drive_values).
  SinkNeeds n;
  n.detail = false;
  n.fields = false;
  n.drive_values = true;
  return n;
}

void ReportSink::begin_capture(ReportCapture capture) {
  shift_ = capture.shift;
  character_time_ = capture.timing.character_time;
  captures_.push_back(std::move(capture));
}

void ReportSink::end_capture(std::string stations_json) {
  if (!captures_.empty()) captures_.back().stations_json = std::move(stations_json);
}

TimeNs ReportSink::shifted(TimeNs t) const {
  // (held at +-2^62, as on_timeline() is: a shift from a capture near the edge cannot wrap)
  constexpr TimeNs kEdge = std::numeric_limits<TimeNs>::max() / 2;
  return static_cast<TimeNs>(
      std::clamp<__int128>(static_cast<__int128>(t) + shift_, -kEdge, kEdge));
}

TimeNs ReportSink::on_timeline(TimeNs t) const {
  // Exact for every time a source gives (|t| < 2^62); a shifted capture past that is held at
  // +-2^62, not wrapped.
  constexpr TimeNs kEdge = std::numeric_limits<TimeNs>::max() / 2;
  const __int128 v = static_cast<__int128>(t) + shift_ - origin_;
  return static_cast<TimeNs>(std::clamp<__int128>(v, -kEdge, kEdge));
}

void ReportSink::count_busy(ChannelId channel, std::size_t bytes, TimeNs start, bool telegram) {
  if (!have_origin_) {
    have_origin_ = true;
    origin_ = shifted(start);
  }
  const TimeNs from = on_timeline(start);
  // (Times span at most +-2^62 ns: a stretch past the end of a 2^63 ns timeline is cut there.)
  TimeNs to = 0;
  if (__builtin_mul_overflow(static_cast<TimeNs>(bytes), character_time_, &to) ||
      __builtin_add_overflow(from, to, &to))
    to = std::numeric_limits<TimeNs>::max() / 2;
  first_ = first_ < 0 ? from : std::min(first_, from);
  last_ = std::max(last_, to);
  if (!captures_.empty()) {
    ReportCapture& c = captures_.back();
    c.first = c.first < 0 ? from : std::min(c.first, from);
    c.last = std::max(c.last, to);
    if (telegram) ++c.frames;
  }
  // The line is busy a character time a byte (as -z load): that time split over the columns it
  // falls in.
  ColumnSeries<Busy>& series = load_[channel];
  series.at(to);  // (widened first: the columns below stay put)
  // Each step ends a column (widened above so that `to` falls in the last): at most kColumns
  // steps, each of at least 1 ns.
  for (TimeNs t = std::max<TimeNs>(from, 0); t < to;) {
    Busy& cell = series.at(t);
    const TimeNs part = std::min(to - t, series.width() - t % series.width());
    cell.busy += part;
    if (telegram && t == std::max<TimeNs>(from, 0)) ++cell.frames;
    t += part;
  }
}

ReportSink::Drive* ReportSink::drive_of(std::size_t link, int address) {
  const std::size_t capture = capture_index();
  if (last_drive_ && last_drive_->capture == capture && last_drive_->link == link &&
      last_drive_->address == address)
    return last_drive_;
  const DriveKey key{capture, link, address};
  auto it = drives_.find(key);
  if (it == drives_.end()) {
    if (drives_.size() >= kMaxDrives) {
      drives_left_out_.insert(key);
      return nullptr;
    }
    it = drives_.emplace(key, Drive{}).first;
  }
  Drive& d = it->second;
  last_drive_ = &d;
  d.capture = capture;
  d.link = link;
  d.address = address;
  return &d;
}

void ReportSink::on_frame(const Message& m) {
  count_busy(m.frame.channel, m.frame.size(), m.frame.start(), true);
  last_frame_ = m.frame.number;
  last_frame_address_ = m.address;
  if (!m.drive_read_with || m.address < 0) return;
  const TimeNs t = on_timeline(m.frame.start());
  Drive* drive = drive_of(channels_.link_index(m.frame.channel), m.address);
  if (!drive) return;
  Drive& d = *drive;
  d.channel = m.frame.channel;
  d.profile = m.drive_read_with->id;
  d.name = m.drive_read_with->name;
  std::array<char, kDriveNumberChars> buffer;
  for (const DriveValue& v : m.drive_values) {
    if (!is_telemetry(v)) continue;
    // The number a reader of the value's text gets (the profile's unit and scale).
    const std::string_view text = drive_value_text(v, buffer);
    double value = 0;
    std::from_chars(text.data(), text.data() + text.size(), value);
    auto series = std::find_if(d.series.begin(), d.series.end(),
                               [&v](const auto& s) { return s.first == v.id; });
    if (series == d.series.end()) {
      d.series.emplace_back(std::string(v.id), ColumnSeries<MinMax>{});
      series = d.series.end() - 1;
    }
    series->second.at(t).add(value);
    if (v.kind == DriveValue::Kind::reg && v.reg && !v.reg->unit.empty())
      d.units[std::string(v.id)] = v.reg->unit;
  }
  mark_state(d, t);
}

// The drive's state now, in the column of `t`: at each frame, and at each state event, so that a
// band changes at the frame whose event changed it.
void ReportSink::mark_state(Drive& d, TimeNs t) {
  std::uint8_t bits = 0;
  if (d.fault_code || d.fault_word) bits |= kFault;
  if (d.running) bits |= *d.running ? kRunning : kStopped;
  if (bits == 0) bits = kUnknown;
  d.states.at(t).set(bits);
}

void ReportSink::on_noise(const Frame& noise) {
  count_busy(noise.channel, noise.size(), noise.start(), false);
  last_frame_ = noise.number;
  last_frame_address_ = -1;
}

void ReportSink::count_finding(AnomalyKind kind, int station, TimeNs t) {
  FindingKey key{kind, capture_index(), station};
  auto it = findings_.find(key);
  if (it == findings_.end()) {
    if (findings_.size() >= kMaxFindingRows) key = {kind, kAllCaptures, kOtherStations};
    it = findings_.try_emplace(key).first;
  }
  FindingRow& row = it->second;
  ++row.cells.at(t).count;
  ++row.count;
}

void ReportSink::on_anomaly(const Anomaly& a) {
  // The station: the one it names (a finding handed on late), the frame's it follows, or the
  // request's whose timeout it reports.
  int station = a.address;
  if (station < 0 && a.frame_number != 0 && a.frame_number == last_frame_)
    station = last_frame_address_;
  else if (station < 0 && a.frame_number != 0 && a.frame_number == last_request_)
    station = last_request_address_;
  if (!have_origin_) {
    have_origin_ = true;
    origin_ = shifted(a.time);
  }
  ++finding_totals_[static_cast<std::size_t>(a.kind)];
  count_finding(a.kind, station, on_timeline(a.time));
}

void ReportSink::on_transaction(const Transaction& t) {
  last_request_ = t.request_number;
  last_request_address_ = t.address;
  if (t.address < 0) return;
  const StationKey key{capture_index(), t.channel, protocol_id(t.protocol), t.address};
  if (!last_station_ || last_station_key_ != key) {
    last_station_key_ = key;
    last_station_ = &stations_[key];
  }
  Station& s = *last_station_;
  if (t.request_number != 0) ++s.requests;
  if (t.response_number != 0) ++s.replies;
  if (t.outcome == Outcome::exception) ++s.exceptions;
  if (t.outcome == Outcome::timeout) ++s.timeouts;
  if (t.latency >= 0) s.latency.add(t.latency);
}

void ReportSink::on_event(const BusEvent& e) {
  if (e.kind == EventKind::drive_bound) {
    // A binding let go or taken over takes what was read under it along: the drive's values,
    // states and events (as the summary's drives are the binder's last word).
    const auto it = drives_.find({capture_index(), channels_.link_index(e.channel), e.address});
    if (it != drives_.end() && it->second.profile != e.profile) {
      events_kept_ -= it->second.events.size();
      if (last_drive_ == &it->second) last_drive_ = nullptr;
      drives_.erase(it);
    }
    // The timing rules its family set were never the drive's.
    const auto row = findings_.find({AnomalyKind::timing_rule, capture_index(), e.address});
    if (!e.from.empty() && row != findings_.end()) {
      finding_totals_[static_cast<std::size_t>(AnomalyKind::timing_rule)] -= row->second.count;
      findings_.erase(row);
    }
    return;
  }
  if (e.address < 0 || e.profile.empty() || e.profile == "generic") return;
  if (!is_drive_state(e.kind)) return;
  Drive* drive = drive_of(channels_.link_index(e.channel), e.address);
  if (!drive) return;
  Drive& d = *drive;
  if (e.kind == EventKind::running) d.running = e.to == "running";
  if (e.kind == EventKind::fault) {
    // Two sources of a fault: the fault code and the status word's fault bit.
    const bool active = !e.to.empty();
    if (e.status_word)
      d.fault_word = active;
    else
      d.fault_code = active;
  }
  if (e.kind == EventKind::running || e.kind == EventKind::fault)
    mark_state(d, on_timeline(e.time));
  if (d.events.size() < kMaxEventsPerDrive && events_kept_ < kMaxEvents) {
    d.events.push_back({on_timeline(e.time), std::string(event_kind_id(e.kind)), e.detail});
    ++events_kept_;
  } else {
    ++d.events_left_out;
  }
}

void ReportSink::on_summary(const Stats& s) {
  ++summaries_;
  totals_.frames += s.frames;
  totals_.bytes += s.bytes;
  totals_.noise_records += s.noise_records;
  totals_.noise_bytes += s.noise_bytes;
  totals_.transactions += s.transactions;
  totals_.anomaly_total += s.anomaly_total;
  for (std::size_t k = 0; k < s.checksum.size(); ++k) totals_.checksum[k] += s.checksum[k];
  for (std::size_t k = 0; k < s.outcomes.size(); ++k) totals_.outcomes[k] += s.outcomes[k];
  for (std::size_t k = 0; k < s.anomalies.size(); ++k) totals_.anomalies[k] += s.anomalies[k];
}

std::string ReportSink::data_json(const std::string& diagnosis_json) const {
  // Every series is drawn on one grid: the widest columns any of them grew to.
  TimeNs width = ColumnSeries<Busy>::kFirstWidth;
  for (const auto& [c, s] : load_) width = std::max(width, s.width());
  for (const auto& [k, d] : drives_) {
    width = std::max(width, d.states.width());
    for (const auto& [id, s] : d.series) width = std::max(width, s.width());
  }
  for (const auto& [k, row] : findings_) width = std::max(width, row.cells.width());
  const auto column_mid = [width](std::size_t k) {
    return seconds(static_cast<TimeNs>(k) * width + width / 2);
  };

  std::string out = "{";
  const bool wall_clock =
      !captures_.empty() && std::all_of(captures_.begin(), captures_.end(),
                                        [](const ReportCapture& c) { return c.wall_clock; });
  fmt::format_to(std::back_inserter(out),
                 R"("wall_clock":{},"origin_s":{},"from_s":{},"to_s":{},"column_s":{},)"
                 R"("columns":{},)",
                 wall_clock, format_seconds(origin_, 9), seconds(std::max<TimeNs>(first_, 0)),
                 seconds(std::max<TimeNs>(last_, 0)), seconds(width), ColumnSeries<Busy>::kColumns);
  out += R"("captures":[)";
  for (std::size_t i = 0; i < captures_.size(); ++i) {
    const ReportCapture& c = captures_[i];
    fmt::format_to(std::back_inserter(out),
                   R"({}{{"file":{},"format":{},"line":{},"t15_ms":{},"t35_ms":{},)"
                   R"("character_ms":{},"wall_clock":{},"from_s":{},"to_s":{},"frames":{},)"
                   R"("stats":[)",
                   i ? "," : "", json_quote(c.file), json_quote(c.format), json_quote(c.line),
                   format_ms(c.timing.t15), format_ms(c.timing.t35),
                   format_ms(c.timing.character_time), c.wall_clock,
                   seconds(std::max<TimeNs>(c.first, 0)), seconds(std::max<TimeNs>(c.last, 0)),
                   c.frames);
    // Its -z records, one JSON object a line: an array of them.
    bool first = true;
    for (std::size_t from = 0; from < c.stations_json.size();) {
      std::size_t end = c.stations_json.find('\n', from);
      if (end == std::string::npos) end = c.stations_json.size();
      if (end > from) {
        if (!first) out += ',';
        out.append(c.stations_json, from, end - from);
        first = false;
      }
      from = end + 1;
    }
    out += "]}";
  }
  out += "],";
  fmt::format_to(std::back_inserter(out),
                 R"("summary":{{"frames":{},"bytes":{},"noise_records":{},"transactions":{},)"
                 R"("timeouts":{},"exceptions":{},"checksum_bad":{},"findings":{}}},)",
                 totals_.frames, totals_.bytes, totals_.noise_records, totals_.transactions,
                 totals_.outcomes[static_cast<std::size_t>(Outcome::timeout)],
                 totals_.outcomes[static_cast<std::size_t>(Outcome::exception)],
                 totals_.checksum[static_cast<std::size_t>(ChecksumVerdict::bad)] +
                     totals_.checksum[static_cast<std::size_t>(ChecksumVerdict::swapped)],
                 totals_.anomaly_total);
  out += R"("diagnosis":)";
  out += diagnosis_json.empty() ? std::string("null") : diagnosis_json;
  if (!out.empty() && out.back() == '\n') out.pop_back();

  // Bus load per channel: busy % of each column.
  // (the kLoadChannels channels busiest over the whole capture)
  std::vector<std::pair<TimeNs, const std::pair<const ChannelId, ColumnSeries<Busy>>*>> channels;
  for (const auto& entry : load_) {
    TimeNs busy = 0;
    for (std::size_t k = 0; k < entry.second.used(); ++k) busy += entry.second.cell(k).busy;
    channels.emplace_back(busy, &entry);
  }
  std::stable_sort(channels.begin(), channels.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  fmt::format_to(std::back_inserter(out), R"(,"load_channels":{},"load":[)", channels.size());
  if (channels.size() > kLoadChannels) channels.resize(kLoadChannels);
  std::sort(channels.begin(), channels.end(),
            [](const auto& a, const auto& b) { return a.second->first < b.second->first; });
  bool first_load = true;
  for (const auto& [busy, entry] : channels) {
    const auto& [channel, series] = *entry;
    fmt::format_to(std::back_inserter(out), R"({}{{"channel":{},"points":[)", first_load ? "" : ",",
                   json_quote(channels_.at(channel).name));
    first_load = false;
    bool first_point = true;
    for_each_column(series, width, [&](std::size_t k, const Busy& cell) {
      fmt::format_to(std::back_inserter(out), "{}[{},{},{}]", first_point ? "" : ",", column_mid(k),
                     number(100.0 * static_cast<double>(cell.busy) / static_cast<double>(width)),
                     cell.frames);
      first_point = false;
    });
    out += "]}";
  }
  out += "]";

  // Latency per station: the -z stations histogram's buckets, merged into a few display bins.
  // (every station when they are kLatencyCharts or fewer; else those with the most replies timed)
  std::vector<const std::pair<const StationKey, Station>*> timed;
  for (const auto& entry : stations_) timed.push_back(&entry);
  fmt::format_to(std::back_inserter(out), R"(,"latency_stations":{},"latency":[)", timed.size());
  if (timed.size() > kLatencyCharts) {
    std::stable_sort(timed.begin(), timed.end(), [](const auto* a, const auto* b) {
      return a->second.latency.count() > b->second.latency.count();
    });
    timed.resize(kLatencyCharts);
  }
  bool first_station = true;
  for (const auto* entry : timed) {
    const auto& [key, s] = *entry;
    const auto& [capture, channel, protocol, address] = key;
    const LogHistogram& l = s.latency;
    fmt::format_to(std::back_inserter(out),
                   R"({}{{"capture":{},"channel":{},"protocol":"{}","addr":{},"requests":{},)"
                   R"("replies":{},"timeouts":{},"exceptions":{},"count":{})",
                   first_station ? "" : ",", capture, json_quote(channels_.at(channel).name),
                   protocol, address, s.requests, s.replies, s.timeouts, s.exceptions, l.count());
    first_station = false;
    if (l.count() > 0) {
      fmt::format_to(std::back_inserter(out),
                     R"(,"min_ms":{},"p50_ms":{},"p95_ms":{},"p99_ms":{},"max_ms":{})",
                     format_ms(l.min()), format_ms(l.percentile(50)), format_ms(l.percentile(95)),
                     format_ms(l.percentile(99)), format_ms(l.max()));
      // Display bins: 48 of equal width from the minimum to the maximum, each bucket counted in
      // the bin of its midpoint (clamped to the exact minimum and maximum).
      constexpr std::size_t kBins = 48;
      std::array<std::uint64_t, kBins> bins{};
      const double lo = static_cast<double>(l.min());
      const double span = std::max(1.0, static_cast<double>(l.max() - l.min()));
      l.for_each_bucket([&](std::uint64_t low, std::uint64_t bucket_width, std::uint64_t count) {
        double mid = static_cast<double>(low) + static_cast<double>(bucket_width) / 2;
        mid = std::clamp(mid, lo, static_cast<double>(l.max()));
        const auto bin = std::min<std::size_t>(
            kBins - 1, static_cast<std::size_t>((mid - lo) / span * static_cast<double>(kBins)));
        bins[bin] += count;
      });
      fmt::format_to(std::back_inserter(out), R"(,"bin_ms":{},"bins":[)",
                     number(span / static_cast<double>(kBins) / 1e6));
      for (std::size_t b = 0; b < kBins; ++b)
        fmt::format_to(std::back_inserter(out), "{}{}", b ? "," : "", bins[b]);
      out += "]";
    }
    out += "}";
  }
  out += "]";

  // Drives: telemetry (min/max per column), state bands, events.
  out += R"(,"drives":[)";
  bool first_drive = true;
  for (const auto& [key, d] : drives_) {
    if (d.profile.empty()) continue;  // events of a drive no frame was read of
    fmt::format_to(std::back_inserter(out),
                   R"({}{{"capture":{},"link":{},"addr":{},"channel":{},"profile":{},"name":{},)"
                   R"("series":[)",
                   first_drive ? "" : ",", d.capture, d.link, d.address,
                   json_quote(channels_.at(d.channel).name), json_quote(d.profile),
                   json_quote(d.name));
    first_drive = false;
    bool first_series = true;
    for (const auto& [id, series] : d.series) {
      const auto unit = d.units.find(id);
      fmt::format_to(std::back_inserter(out), R"({}{{"id":{},"unit":{},"points":[)",
                     first_series ? "" : ",", json_quote(id),
                     json_quote(unit == d.units.end() ? "" : unit->second));
      first_series = false;
      bool first_point = true;
      std::uint64_t values = 0;
      for_each_column(series, width, [&](std::size_t k, const MinMax& cell) {
        if (cell.count == 0) return;
        values += cell.count;
        fmt::format_to(std::back_inserter(out), "{}[{},{},{}]", first_point ? "" : ",",
                       column_mid(k), number(cell.min), number(cell.max));
        first_point = false;
      });
      fmt::format_to(std::back_inserter(out), R"(],"values":{}}})", values);
    }
    out += R"(],"states":[)";
    bool first_state = true;
    for_each_column(d.states, width, [&](std::size_t k, const Bits& cell) {
      if (cell.bits == 0) return;
      fmt::format_to(std::back_inserter(out), "{}[{},{},{}]", first_state ? "" : ",", column_mid(k),
                     cell.bits, cell.last);
      first_state = false;
    });
    out += R"(],"events":[)";
    for (std::size_t i = 0; i < d.events.size(); ++i)
      fmt::format_to(std::back_inserter(out), "{}[{},{},{}]", i ? "," : "",
                     seconds(d.events[i].time), json_quote(d.events[i].kind),
                     json_quote(d.events[i].detail));
    fmt::format_to(std::back_inserter(out), R"(],"events_left_out":{}}})", d.events_left_out);
  }
  fmt::format_to(std::back_inserter(out), R"(],"drives_left_out":{})", drives_left_out_.size());

  // Findings: a row per kind and station, the columns of the heatmap with their counts; past the
  // kFindingRows rows with the most findings, one row per kind for the other stations.
  const TimeNs heat_width =
      width * static_cast<TimeNs>(ColumnSeries<Count>::kColumns / kHeatColumns);
  using RowEntry = std::pair<FindingKey, const FindingRow*>;
  std::vector<RowEntry> rows;
  for (const auto& [key, row] : findings_) rows.emplace_back(key, &row);
  std::map<FindingKey, FindingRow> merged;
  const auto add_row = [](FindingRow& into, const FindingRow& from) {
    into.count += from.count;
    into.cells.widen_to(from.cells.width());
    for (std::size_t c = 0; c < from.cells.used(); ++c)
      if (from.cells.cell(c).count != 0)
        into.cells.at(static_cast<TimeNs>(c) * from.cells.width()).count +=
            from.cells.cell(c).count;
  };
  if (rows.size() > kFindingRows) {
    std::stable_sort(rows.begin(), rows.end(), [](const RowEntry& a, const RowEntry& b) {
      return a.second->count > b.second->count;
    });
    for (std::size_t k = kFindingRows; k < rows.size(); ++k)
      add_row(merged[{std::get<0>(rows[k].first), kAllCaptures, kOtherStations}], *rows[k].second);
    rows.resize(kFindingRows);
    // (a kind's own "other stations" row, kept among the busiest, joins the merged one)
    std::erase_if(rows, [&](const RowEntry& r) {
      const auto other = merged.find(r.first);
      if (other == merged.end()) return false;
      add_row(other->second, *r.second);
      return true;
    });
    for (const auto& [key, row] : merged) rows.emplace_back(key, &row);
    std::sort(rows.begin(), rows.end(),
              [](const RowEntry& a, const RowEntry& b) { return a.first < b.first; });
  }
  fmt::format_to(std::back_inserter(out), R"(,"findings":{{"column_s":{},"rows":[)",
                 seconds(heat_width));
  bool first_row = true;
  for (const auto& [key, row_pointer] : rows) {
    const FindingRow& row = *row_pointer;
    const auto& [kind, capture, station] = key;
    fmt::format_to(std::back_inserter(out),
                   R"({}{{"kind":{},"capture":{},"station":{},"count":{},"cells":[)",
                   first_row ? "" : ",", json_quote(anomaly_id(kind)),
                   capture == kAllCaptures ? std::string("null") : std::to_string(capture), station,
                   row.count);
    first_row = false;
    bool first_cell = true;
    for_each_column(row.cells, heat_width, [&](std::size_t k, const Count& cell) {
      if (cell.count == 0) return;
      fmt::format_to(std::back_inserter(out), "{}[{},{}]", first_cell ? "" : ",", k, cell.count);
      first_cell = false;
    });
    out += "]}";
  }
  out += "]}}";
  return out;
}

bool ReportSink::write_page(std::FILE* out, const std::string& diagnosis_json) const {
  // Inside <script>, "</" could end the element and "<!--" start a comment that swallows the page's
  // script: every <, > and & is written as its \u escape, which JSON reads as the same character
  // (they occur only inside strings).
  std::string data;
  {
    const std::string raw = data_json(diagnosis_json);
    data.reserve(raw.size());
    for (const char c : raw) {
      if (c == '<')
        data += "\\u003c";
      else if (c == '>')
        data += "\\u003e";
      else if (c == '&')
        data += "\\u0026";
      else
        data += c;
    }
  }
  const std::string_view page = report_page_template();
  // The template's two marks: the library and the data go there.
  constexpr std::string_view kLibraryMark = "/*@CHART_JS@*/";
  constexpr std::string_view kDataMark = "/*@REPORT_DATA@*/";
  const std::size_t library = page.find(kLibraryMark);
  const std::size_t data_at = page.find(kDataMark);
  if (library == std::string_view::npos || data_at == std::string_view::npos || data_at < library)
    return false;
  const auto put = [out](std::string_view text) {
    return std::fwrite(text.data(), 1, text.size(), out) == text.size();
  };
  bool ok = put(page.substr(0, library));
  ok = ok && put(report_chart_js());
  ok = ok &&
       put(page.substr(library + kLibraryMark.size(), data_at - library - kLibraryMark.size()));
  ok = ok && put(data);
  ok = ok && put(page.substr(data_at + kDataMark.size()));
  return ok;
}

}  // namespace drivetap
