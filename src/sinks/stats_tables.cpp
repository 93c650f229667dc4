// -z statistics (src/sinks/stats_tables.hpp; timing per docs/protocols.md §1, the tables in
// docs/reference.md "Statistics (-z)").
#include "sinks/stats_tables.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <limits>
#include <set>

#include "core/format.hpp"
#include "core/protocol.hpp"
#include "sinks/json_sink.hpp"

namespace drivetap {

namespace {

constexpr std::string_view kStatisticNames = "stations, functions, gaps, load";
// The tables are handed on in parts of about this size.
constexpr std::size_t kWriteBytes = 64 * 1024;
constexpr std::string_view kRule =
    "===================================================================================";

// floor(a / b) for b > 0, a of either sign.
std::int64_t floor_div(TimeNs a, TimeNs b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}

// A duration in ms with three decimals (JSON and text alike), "-" / null for none.
std::string ms_or(TimeNs t, std::string_view none) {
  return t < 0 ? std::string(none) : format_ms(t);
}
std::string ms_of(double ns) {
  return fmt::format("{:.3f}", ns / static_cast<double>(kNsPerMs));
}
std::string percent(std::uint64_t part, std::uint64_t whole) {
  return fmt::format(
      "{:.3f}", whole == 0 ? 0.0 : 100.0 * static_cast<double>(part) / static_cast<double>(whole));
}

// The name of function code `function` of `protocol`: the names of its function-code field (the
// enumerated field whose id ends ".func_code", Wireshark's name), empty when it has none or none
// for this code.
std::string_view function_name(Protocol protocol, int function) {
  if (!protocol.desc() || function < 0) return "";
  for (const FieldProtocol* group : protocol.desc()->field_protocols)
    for (const FieldDesc* field : group->fields)
      if (field->type == FieldType::enumerated && field->id.ends_with(".func_code"))
        return field->name_of(static_cast<std::uint32_t>(function));
  return "";
}

}  // namespace

std::optional<StatisticRequest> parse_statistic(std::string_view spec, std::string* error) {
  const std::size_t comma = spec.find(',');
  const std::string_view name = spec.substr(0, comma);
  const std::string_view argument =
      comma == std::string_view::npos ? std::string_view{} : spec.substr(comma + 1);
  StatisticRequest r;
  if (name == "stations") {
    r.kind = StatisticKind::stations;
  } else if (name == "functions") {
    r.kind = StatisticKind::functions;
  } else if (name == "gaps") {
    r.kind = StatisticKind::gaps;
  } else if (name == "load") {
    r.kind = StatisticKind::load;
  } else {
    *error = fmt::format("-z: unknown statistic '{}' ({})", name, kStatisticNames);
    return std::nullopt;
  }
  if (comma == std::string_view::npos) return r;
  if (r.kind != StatisticKind::load) {
    *error = fmt::format("-z {}: takes no argument", spec);
    return std::nullopt;
  }
  double seconds = 0;
  const auto [end, ec] =
      std::from_chars(argument.data(), argument.data() + argument.size(), seconds);
  if (ec != std::errc{} || end != argument.data() + argument.size() || !(seconds >= 0.001) ||
      seconds > 86400) {
    *error =
        fmt::format("-z {}: the interval must be seconds from 0.001 to 86400, e.g. load,1", spec);
    return std::nullopt;
  }
  r.interval = static_cast<TimeNs>(std::llround(seconds * static_cast<double>(kNsPerSecond)));
  return r;
}

// --- LogHistogram ---

std::size_t LogHistogram::bucket_of(std::uint64_t value) {
  constexpr std::uint64_t kLinear = std::uint64_t{2} << kSubBucketBits;  // 128
  if (value < kLinear) return static_cast<std::size_t>(value);
  const int top = std::bit_width(value) - 1;  // >= 7
  const int shift = top - kSubBucketBits;
  const std::uint64_t sub = (value >> shift) - (std::uint64_t{1} << kSubBucketBits);
  return static_cast<std::size_t>(kLinear +
                                  static_cast<std::uint64_t>(top - kSubBucketBits - 1) *
                                      (std::uint64_t{1} << kSubBucketBits) +
                                  sub);
}

std::uint64_t LogHistogram::bucket_low(std::size_t bucket) {
  constexpr std::size_t kLinear = std::size_t{2} << kSubBucketBits;
  constexpr std::size_t kSub = std::size_t{1} << kSubBucketBits;
  if (bucket < kLinear) return bucket;
  const std::size_t octave = (bucket - kLinear) / kSub;  // top = octave + 7
  const std::size_t sub = (bucket - kLinear) % kSub;
  return static_cast<std::uint64_t>(kSub + sub) << (octave + 1);
}

std::uint64_t LogHistogram::bucket_width(std::size_t bucket) {
  constexpr std::size_t kLinear = std::size_t{2} << kSubBucketBits;
  constexpr std::size_t kSub = std::size_t{1} << kSubBucketBits;
  if (bucket < kLinear) return 1;
  return std::uint64_t{1} << ((bucket - kLinear) / kSub + 1);
}

void LogHistogram::count(std::size_t bucket, std::uint64_t n) {
  if (counts_.empty()) {
    first_ = bucket;
  } else if (bucket < first_) {
    counts_.insert(counts_.begin(), first_ - bucket, 0);
    first_ = bucket;
  }
  if (bucket - first_ >= counts_.size()) counts_.resize(bucket - first_ + 1);
  counts_[bucket - first_] += n;
}

void LogHistogram::add(TimeNs value) {
  if (value < 0) return;
  count(bucket_of(static_cast<std::uint64_t>(value)), 1);
  min_ = count_ == 0 ? value : std::min(min_, value);
  max_ = count_ == 0 ? value : std::max(max_, value);
  ++count_;
}

void LogHistogram::merge(const LogHistogram& other) {
  if (other.count_ == 0) return;
  for (std::size_t k = 0; k < other.counts_.size(); ++k)
    if (other.counts_[k] != 0) count(other.first_ + k, other.counts_[k]);
  min_ = count_ == 0 ? other.min_ : std::min(min_, other.min_);
  max_ = count_ == 0 ? other.max_ : std::max(max_, other.max_);
  count_ += other.count_;
}

TimeNs LogHistogram::percentile(int percent) const {
  if (count_ == 0) return -1;
  // Nearest rank, in integers: ceil(percent * count / 100).
  const std::uint64_t rank =
      std::max<std::uint64_t>(1, (static_cast<std::uint64_t>(percent) * count_ + 99) / 100);
  // The ends are known exactly.
  if (rank == 1) return min_;
  if (rank == count_) return max_;
  std::uint64_t seen = 0;
  for (std::size_t k = 0; k < counts_.size(); ++k) {
    seen += counts_[k];
    if (seen < rank) continue;
    const std::size_t b = first_ + k;
    const auto mid = static_cast<TimeNs>(bucket_low(b) + bucket_width(b) / 2);
    return std::clamp(mid, min_, max_);
  }
  return max_;
}

// --- StatsTablesSink ---

StatsTablesSink::StatsTablesSink(const ChannelTable& channels, FramingTiming timing, bool timed,
                                 std::vector<StatisticRequest> requests)
    : channels_(channels), timing_(timing), timed_(timed) {
  // Each statistic once, in the order first asked for (a load per interval).
  for (const StatisticRequest& r : requests) {
    const bool repeated = std::any_of(requests_.begin(), requests_.end(), [&](const auto& seen) {
      return seen.kind == r.kind && (r.kind != StatisticKind::load || seen.interval == r.interval);
    });
    if (repeated) continue;
    requests_.push_back(r);
    stations_ = stations_ || r.kind == StatisticKind::stations;
    functions_ = functions_ || r.kind == StatisticKind::functions;
    gaps_ = gaps_ || r.kind == StatisticKind::gaps;
    if (r.kind == StatisticKind::load) load_series_.push_back({r.interval, r.interval, {}});
  }
  scratch_.detail = false;
  scratch_.tree = false;
}

SinkNeeds StatsTablesSink::needs() const {
  SinkNeeds n = SinkNeeds::none();
  n.records = stations_ || gaps_ || !load_series_.empty();
  n.transactions = stations_ || functions_;
  n.deferred_decode = true;  // (its head only: see on_deferred_frame())
  return n;
}

StatsTablesSink::Station& StatsTablesSink::station(ChannelId channel, Protocol protocol,
                                                   int address) {
  if (last_station_ && last_key_.channel == channel && last_key_.protocol == protocol &&
      last_key_.address == address)
    return *last_station_;
  last_key_ = StationKey{channel, protocol, address};
  last_station_ = &stations_by_key_[last_key_];
  return *last_station_;
}

void StatsTablesSink::count_bytes(ChannelId channel, std::size_t size, TimeNs start,
                                  bool telegram) {
  if (channel >= channel_bytes_.size()) channel_bytes_.resize(std::size_t{channel} + 1);
  channel_bytes_[channel] += size;
  if (load_series_.empty() || size == 0 || !timed_) return;
  if (!have_load_origin_) {
    load_origin_ = start;
    have_load_origin_ = true;
  }
  // The line is busy a character time a byte, from the first byte on: that time is split over the
  // intervals it falls in; the frame counts in the interval it starts in.
  // (Held inside +-(2^63 - two days): sources keep times inside +-2^62, so a span from one end
  // to the other nears 2^63, and (k + 1) * interval must not wrap for the longest interval.)
  constexpr TimeNs kEdge = std::numeric_limits<TimeNs>::max() - 2 * 86400 * kNsPerSecond;
  const auto held = [](__int128 t) {
    return static_cast<TimeNs>(std::clamp<__int128>(t, -kEdge, kEdge));
  };
  const TimeNs busy_from = held(static_cast<__int128>(start) - load_origin_);
  const TimeNs busy_to =
      held(static_cast<__int128>(busy_from) +
           static_cast<__int128>(size) * static_cast<__int128>(timing_.character_time));
  for (LoadSeries& series : load_series_) {
    const std::int64_t first = floor_div(busy_from, series.interval);
    for (std::int64_t k = first; k * series.interval < busy_to; ++k) {
      if (!series.last_cells || series.last != k) {
        series.last = k;
        series.last_cells = &series.cells[k];
      }
      std::vector<LoadCell>& cells = *series.last_cells;
      // (Sized for every channel at once: grown one by one, the rows would leave holes in the
      // heap.)
      if (cells.size() <= channel)
        cells.resize(std::max(channels_.size(), std::size_t{channel} + 1));
      LoadCell& cell = cells[channel];
      const TimeNs from = std::max(busy_from, k * series.interval);
      const TimeNs to = std::min(busy_to, (k + 1) * series.interval);
      cell.busy += to - from;
      if (k == first) {
        cell.bytes += size;
        if (telegram) ++cell.frames;
      }
    }
    while (series.cells.size() > kMaxLoadIntervals) widen(series);
  }
}

void StatsTablesSink::widen(LoadSeries& series) {
  // Interval k of the doubled width holds the old 2k and 2k + 1 (the origin stays).
  std::map<std::int64_t, std::vector<LoadCell>> merged;
  for (auto& [k, cells] : series.cells) {
    std::vector<LoadCell>& into = merged[floor_div(k, 2)];
    if (into.size() < cells.size()) into.resize(cells.size());
    for (std::size_t c = 0; c < cells.size(); ++c) {
      into[c].busy += cells[c].busy;
      into[c].bytes += cells[c].bytes;
      into[c].frames += cells[c].frames;
    }
  }
  series.cells = std::move(merged);
  series.interval *= 2;
  series.last_cells = nullptr;
}

void StatsTablesSink::count_telegram(ChannelId channel, Protocol protocol, int address,
                                     Direction direction, ChecksumVerdict verdict, std::size_t size,
                                     TimeNs start, TimeNs gap_before) {
  count_bytes(channel, size, start, true);
  if (gaps_ && gap_before >= 0 && timed_) {
    std::size_t bin = 0;
    if (gap_before < timing_.t15) {
      bin = 0;
    } else if (gap_before < timing_.t35) {
      bin = 1;
    } else {
      bin = 2;
      for (TimeNs bound = timing_.t35 * 2; bin < kGapBins - 1 && gap_before >= bound; bound *= 2)
        ++bin;
    }
    ++gap_bins_[bin];
    ++gap_count_;
  }
  if (!stations_ || address < 0) return;
  Station& s = station(channel, protocol, address);
  s.bytes += size;
  if (verdict == ChecksumVerdict::bad || verdict == ChecksumVerdict::swapped) ++s.bad_checksums;
  if (direction == Direction::request && timed_) {
    if (s.last_request >= 0) {
      // Welford: the mean and the sum of squared deviations, one interval at a time.
      const double interval = static_cast<double>(start - s.last_request);
      ++s.polls;
      const double delta = interval - s.poll_mean;
      s.poll_mean += delta / static_cast<double>(s.polls);
      s.poll_m2 += delta * (interval - s.poll_mean);
    }
    s.last_request = start;
  }
}

void StatsTablesSink::on_frame(const Message& m) {
  count_telegram(m.frame.channel, m.protocol, m.address, m.direction, m.checksum.verdict,
                 m.frame.size(), m.frame.start(), m.frame.gap_before);
}

void StatsTablesSink::on_noise(const Frame& noise) {
  count_bytes(noise.channel, noise.size(), noise.start(), false);
}

void StatsTablesSink::on_deferred_frame(const DeferredTelegram& telegram) {
  // The head is all the tables read: the telegram is dissected no further.
  TelegramView view;
  view.run = telegram.run;
  view.taken = telegram.taken;
  TelegramFindings head;
  int address = -1;
  ChecksumVerdict verdict = ChecksumVerdict::none;
  if (telegram.decoder->dissect(view, telegram.direction, telegram.timing, telegram.request,
                                DissectDepth::head, scratch_, &head)) {
    address = scratch_.address;
    verdict = scratch_.checksum.verdict;
  } else {
    address = head.address;
    verdict = head.verdict;
  }
  count_telegram(telegram.run.channel, telegram.decoder->protocol(), address, telegram.direction,
                 verdict, telegram.run.size(), telegram.run.first,
                 telegram.taken.timing.gap_before);
}

void StatsTablesSink::on_transaction(const Transaction& t) {
  if (functions_) functions_by_key_[FunctionKey{t.protocol, t.function}].count(t);
  if (!stations_ || t.address < 0) return;
  Station& s = station(t.channel, t.protocol, t.address);
  s.count(t);
  if (t.outcome == Outcome::timeout) ++s.timeouts;
  if (t.latency >= 0 && timed_) s.latency.add(t.latency);
}

std::string StatsTablesSink::tables(bool json) const {
  std::string all;
  write_tables(json, [&all](std::string_view part) { all += part; });
  return all;
}

void StatsTablesSink::write_tables(bool json,
                                   const std::function<void(std::string_view)>& write) const {
  std::string out;
  for (const StatisticRequest& r : requests_) {
    switch (r.kind) {
      case StatisticKind::stations:
        stations_table(out, json);
        break;
      case StatisticKind::functions:
        functions_table(out, json);
        break;
      case StatisticKind::gaps:
        gaps_table(out, json);
        break;
      case StatisticKind::load:
        for (const LoadSeries& series : load_series_)
          if (series.requested == r.interval) load_table(out, json, series, write);
        break;
    }
  }
  if (!out.empty()) write(out);
}

void StatsTablesSink::stations_table(std::string& out, bool json) const {
  // The stations listed: all of them, or the busiest station_rows_ (in key order) and the rest
  // summed into `others`.
  using Entry = const std::pair<const StationKey, Station>*;
  std::vector<Entry> listed;
  listed.reserve(stations_by_key_.size());
  for (const auto& entry : stations_by_key_) listed.push_back(&entry);
  Station others;
  std::size_t other_count = 0;
  if (listed.size() > station_rows_) {
    const auto busier = [](Entry a, Entry b) {
      return a->second.requests + a->second.replies > b->second.requests + b->second.replies;
    };
    std::stable_sort(listed.begin(), listed.end(), busier);
    for (auto it = listed.begin() + static_cast<std::ptrdiff_t>(station_rows_); it != listed.end();
         ++it) {
      const Station& s = (*it)->second;
      others.requests += s.requests;
      others.replies += s.replies;
      others.exceptions += s.exceptions;
      others.timeouts += s.timeouts;
      others.bad_checksums += s.bad_checksums;
      others.bytes += s.bytes;
      others.latency.merge(s.latency);
      ++other_count;
    }
    listed.resize(station_rows_);
    std::sort(listed.begin(), listed.end(), [](Entry a, Entry b) { return a->first < b->first; });
  }
  std::size_t width = 8;  // the channel column's: its longest name
  for (const Entry e : listed) width = std::max(width, channels_.at(e->first.channel).name.size());
  if (!json) {
    fmt::format_to(std::back_inserter(out),
                   "{}\nStations (-z stations): latency and poll interval in ms; share: % of the "
                   "channel's bytes\n",
                   kRule);
    fmt::format_to(std::back_inserter(out),
                   "{:<{}} {:<12} {:>4} {:>8} {:>8} {:>5} {:>8} {:>6} {:>9} {:>9} {:>9} {:>9} "
                   "{:>9} {:>9} {:>9} {:>10} {:>6}\n",
                   "channel", width, "protocol", "addr", "requests", "replies", "exc", "timeouts",
                   "badsum", "lat_min", "lat_p50", "lat_p95", "lat_p99", "lat_max", "poll",
                   "jitter", "bytes", "share");
  }
  // One row; `key` null for the others' sum (no channel, so no share or poll interval).
  const auto row = [&](const StationKey* key, const Station& s) {
    const std::string_view channel =
        key ? std::string_view(channels_.at(key->channel).name) : std::string_view();
    const std::uint64_t channel_bytes =
        key && key->channel < channel_bytes_.size() ? channel_bytes_[key->channel] : 0;
    const bool polled = s.polls > 0;
    const double jitter = polled ? std::sqrt(s.poll_m2 / static_cast<double>(s.polls)) : 0;
    const LogHistogram& l = s.latency;
    if (json) {
      out += R"({"type":"stat","stat":"stations",)";
      if (key)
        fmt::format_to(std::back_inserter(out), R"("channel":{},"protocol":"{}","addr":{},)",
                       json_quote(channel), protocol_id(key->protocol), key->address);
      else
        fmt::format_to(std::back_inserter(out),
                       R"("channel":null,"protocol":null,"addr":null,"other_stations":{},)",
                       other_count);
      fmt::format_to(std::back_inserter(out),
                     R"("requests":{},"replies":{},"exceptions":{},"timeouts":{},)"
                     R"("bad_checksums":{},"latency_ms":)",
                     s.requests, s.replies, s.exceptions, s.timeouts, s.bad_checksums);
      if (l.count() == 0)
        out += "null";
      else
        fmt::format_to(std::back_inserter(out),
                       R"({{"count":{},"min":{},"p50":{},"p95":{},"p99":{},"max":{}}})", l.count(),
                       format_ms(l.min()), format_ms(l.percentile(50)), format_ms(l.percentile(95)),
                       format_ms(l.percentile(99)), format_ms(l.max()));
      out += R"(,"poll_ms":)";
      if (!polled)
        out += "null";
      else
        fmt::format_to(std::back_inserter(out), R"({{"count":{},"mean":{},"jitter":{}}})", s.polls,
                       ms_of(s.poll_mean), ms_of(jitter));
      fmt::format_to(std::back_inserter(out), R"(,"bytes":{},"share_pct":{}}})", s.bytes,
                     key ? percent(s.bytes, channel_bytes) : std::string("null"));
      out += '\n';
      return;
    }
    const bool lat = l.count() > 0;
    const std::string name =
        key ? std::string(channel) : fmt::format("({} other stations)", other_count);
    fmt::format_to(
        std::back_inserter(out),
        "{:<{}} {:<12} {:>4} {:>8} {:>8} {:>5} {:>8} {:>6} {:>9} {:>9} {:>9} {:>9} "
        "{:>9} {:>9} {:>9} {:>10} {:>6}\n",
        name, width, key ? protocol_id(key->protocol) : "-",
        key ? std::to_string(key->address) : std::string("-"), s.requests, s.replies, s.exceptions,
        s.timeouts, s.bad_checksums, ms_or(lat ? l.min() : -1, "-"),
        ms_or(lat ? l.percentile(50) : -1, "-"), ms_or(lat ? l.percentile(95) : -1, "-"),
        ms_or(lat ? l.percentile(99) : -1, "-"), ms_or(lat ? l.max() : -1, "-"),
        polled ? ms_of(s.poll_mean) : "-", polled ? ms_of(jitter) : "-", s.bytes,
        key ? fmt::format("{:.1f}", channel_bytes == 0 ? 0.0
                                                       : 100.0 * static_cast<double>(s.bytes) /
                                                             static_cast<double>(channel_bytes))
            : std::string("-"));
  };
  for (const Entry e : listed) row(&e->first, e->second);
  if (other_count > 0) row(nullptr, others);
  if (!json) {
    if (stations_by_key_.empty()) out += "(no stations)\n";
    fmt::format_to(std::back_inserter(out), "{}\n", kRule);
  }
}

void StatsTablesSink::functions_table(std::string& out, bool json) const {
  if (!json)
    fmt::format_to(std::back_inserter(out),
                   "{}\nFunctions (-z functions)\n{:<12} {:>4} {:<36} {:>9} {:>9} {:>10}\n", kRule,
                   "protocol", "fc", "name", "requests", "replies", "exceptions");
  for (const auto& [key, f] : functions_by_key_) {
    const std::string_view name = function_name(key.protocol, key.function);
    if (json) {
      fmt::format_to(std::back_inserter(out),
                     R"({{"type":"stat","stat":"functions","protocol":"{}","fc":)",
                     protocol_id(key.protocol));
      out += key.function < 0 ? std::string("null") : std::to_string(key.function);
      fmt::format_to(std::back_inserter(out),
                     R"(,"name":{},"requests":{},"replies":{},"exceptions":{}}})"
                     "\n",
                     name.empty() ? std::string("null") : json_quote(name), f.requests, f.replies,
                     f.exceptions);
      continue;
    }
    fmt::format_to(std::back_inserter(out), "{:<12} {:>4} {:<36} {:>9} {:>9} {:>10}\n",
                   protocol_id(key.protocol),
                   key.function < 0 ? std::string("-") : std::to_string(key.function),
                   name.empty() ? "-" : name, f.requests, f.replies, f.exceptions);
  }
  if (!json) {
    if (functions_by_key_.empty()) out += "(no transactions)\n";
    fmt::format_to(std::back_inserter(out), "{}\n", kRule);
  }
}

void StatsTablesSink::gaps_table(std::string& out, bool json) const {
  if (!timed_) {
    if (!json)
      fmt::format_to(std::back_inserter(out), "{}\nGaps (-z gaps): no real times (decode)\n{}\n",
                     kRule, kRule);
    return;
  }
  // The bin's bounds, ns: [low, high), high -1 for the open last bin.
  const auto bounds = [this](std::size_t bin) -> std::pair<TimeNs, TimeNs> {
    if (bin == 0) return {0, timing_.t15};
    if (bin == 1) return {timing_.t15, timing_.t35};
    const TimeNs low = timing_.t35 << (bin - 2);
    return {low, bin == kGapBins - 1 ? -1 : low * 2};
  };
  std::size_t last = 2;  // (the bins up to t3.5 * 2 are always shown)
  for (std::size_t b = 0; b < kGapBins; ++b)
    if (gap_bins_[b] != 0) last = std::max(last, b);
  if (json) {
    fmt::format_to(std::back_inserter(out),
                   R"({{"type":"stat","stat":"gaps","t15_ms":{},"t35_ms":{},"frames":{},"bins":[)",
                   format_ms(timing_.t15), format_ms(timing_.t35), gap_count_);
    for (std::size_t b = 0; b <= last; ++b) {
      const auto [low, high] = bounds(b);
      fmt::format_to(std::back_inserter(out),
                     R"({}{{"from_ms":{},"to_ms":{},"count":{},"pct":{}}})", b ? "," : "",
                     format_ms(low), ms_or(high, "null"), gap_bins_[b],
                     percent(gap_bins_[b], gap_count_));
    }
    out += "]}\n";
    return;
  }
  fmt::format_to(std::back_inserter(out),
                 "{}\nGaps (-z gaps): silence before each frame; t1.5 {} ms, t3.5 {} ms; {} "
                 "frames\n{:<28} {:>10} {:>7}\n",
                 kRule, format_ms(timing_.t15), format_ms(timing_.t35), gap_count_, "gap (ms)",
                 "frames", "%");
  for (std::size_t b = 0; b <= last; ++b) {
    const auto [low, high] = bounds(b);
    std::string range = high < 0 ? fmt::format(">= {}", format_ms(low))
                                 : fmt::format("{} .. {}", format_ms(low), format_ms(high));
    if (b == 0) range += " (< t1.5)";
    if (b == 1) range += " (t1.5..t3.5)";
    fmt::format_to(std::back_inserter(out), "{:<28} {:>10} {:>7.1f}\n", range, gap_bins_[b],
                   gap_count_ == 0 ? 0.0
                                   : 100.0 * static_cast<double>(gap_bins_[b]) /
                                         static_cast<double>(gap_count_));
  }
  fmt::format_to(std::back_inserter(out), "{}\n", kRule);
}

void StatsTablesSink::load_table(std::string& out, bool json, const LoadSeries& series,
                                 const std::function<void(std::string_view)>& write) const {
  const std::string seconds =
      fmt::format("{:g}", static_cast<double>(series.interval) / static_cast<double>(kNsPerSecond));
  if (!timed_) {
    if (!json)
      fmt::format_to(std::back_inserter(out), "{}\nLoad (-z load,{}): no real times (decode)\n{}\n",
                     kRule, seconds, kRule);
    return;
  }
  // The channels that carried anything, in the table's order.
  std::vector<ChannelId> channels;
  for (std::size_t c = 0; c < channel_bytes_.size(); ++c)
    if (channel_bytes_[c] != 0) channels.push_back(static_cast<ChannelId>(c));
  std::size_t width = 8;  // the channel column's: its longest name
  for (const ChannelId c : channels) width = std::max(width, channels_.at(c).name.size());
  const std::string asked = fmt::format(
      "{:g}", static_cast<double>(series.requested) / static_cast<double>(kNsPerSecond));
  if (!json)
    fmt::format_to(std::back_inserter(out),
                   "{}\nLoad (-z load,{}): busy = bytes x character time ({} ms) per interval; "
                   "intervals from {} s{}\n{:<24} {:<{}} {:>8} {:>10} {:>7}\n",
                   kRule, asked, format_ms(timing_.character_time), format_seconds(load_origin_, 6),
                   series.interval == series.requested
                       ? std::string()
                       : fmt::format("; intervals of {} s: {} s gave more than {} with traffic",
                                     seconds, asked, kMaxLoadIntervals),
                   "interval (s)", "channel", width, "frames", "bytes", "busy %");
  const auto row = [&](std::int64_t from, std::int64_t to, const std::vector<LoadCell>* cells) {
    const TimeNs length = (to - from) * series.interval;
    for (const ChannelId c : channels) {
      const LoadCell cell = cells && c < cells->size() ? (*cells)[c] : LoadCell{};
      const std::string busy = fmt::format(
          "{:.3f}", 100.0 * static_cast<double>(cell.busy) / static_cast<double>(length));
      const std::string from_s = format_seconds(from * series.interval, 3);
      const std::string to_s = format_seconds(to * series.interval, 3);
      if (json) {
        fmt::format_to(
            std::back_inserter(out),
            R"({{"type":"stat","stat":"load","interval_s":{},"t0":{},"character_time_ns":{},)"
            R"("from_s":{},"to_s":{},"channel":{},"frames":{},"bytes":{},"busy_pct":{}}})"
            "\n",
            seconds, format_seconds(load_origin_, 9), timing_.character_time, from_s, to_s,
            json_quote(channels_.at(c).name), cell.frames, cell.bytes, busy);
      } else {
        fmt::format_to(std::back_inserter(out), "{:<24} {:<{}} {:>8} {:>10} {:>7.1f}\n",
                       fmt::format("{} - {}", from_s, to_s), channels_.at(c).name, width,
                       cell.frames, cell.bytes,
                       100.0 * static_cast<double>(cell.busy) / static_cast<double>(length));
      }
    }
    if (out.size() >= kWriteBytes) {
      write(out);
      out.clear();
    }
  };
  std::int64_t next = 0;  // the first interval not shown yet
  bool first = true;
  for (const auto& [k, cells] : series.cells) {
    if (first) next = k;
    first = false;
    // Idle intervals before this one: each shown, or one row for a long run of them.
    if (k - next > kMaxIdleRows) {
      row(next, k, nullptr);
    } else {
      for (std::int64_t idle = next; idle < k; ++idle) row(idle, idle + 1, nullptr);
    }
    row(k, k + 1, &cells);
    next = k + 1;
  }
  if (!json) {
    if (series.cells.empty()) out += "(no traffic)\n";
    fmt::format_to(std::back_inserter(out), "{}\n", kRule);
  }
}

// --- BesideSink ---

namespace {

SinkNeeds beside_needs(const SinkNeeds& main, const SinkNeeds& counter) {
  // The counter's needs where main takes no records; else main's, which give the counter what it
  // reads (keys, verdicts, sizes and times come with every record).
  SinkNeeds n = main.records ? main : counter;
  n.records = main.records || counter.records;
  n.transactions = main.transactions || counter.transactions;
  n.events = main.events;
  return n;
}

}  // namespace

BesideSink::BesideSink(Sink& main, Sink& counter)
    : ForwardingSink(main),
      counter_(counter),
      main_needs_(main.needs()),
      counter_needs_(counter.needs()),
      needs_(beside_needs(main_needs_, counter_needs_)) {}

void BesideSink::on_frame(const Message& m) {
  next_.on_frame(m);
  if (counter_needs_.records) counter_.on_frame(m);
}

void BesideSink::on_noise(const Frame& f) {
  next_.on_noise(f);
  if (counter_needs_.records) counter_.on_noise(f);
}

void BesideSink::on_anomaly(const Anomaly& a) {
  next_.on_anomaly(a);
  if (counter_needs_.records) counter_.on_anomaly(a);
}

void BesideSink::on_transaction(const Transaction& t) {
  if (main_needs_.transactions) next_.on_transaction(t);
  if (counter_needs_.transactions) counter_.on_transaction(t);
}

void BesideSink::on_deferred_frame(const DeferredTelegram& telegram) {
  if (main_needs_.records) next_.on_deferred_frame(telegram);
  if (counter_needs_.records) counter_.on_deferred_frame(telegram);
}

}  // namespace drivetap
