// -z statistics, as tshark prints them after a run: per station, per function code, the gaps
// between frames and the bus load, counted from the pipeline's records (timing: docs/protocols.md
// §1; the tables and their JSON records: docs/reference.md "Statistics (-z)").
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "core/byte_event.hpp"
#include "core/serial_config.hpp"
#include "core/time.hpp"
#include "sinks/sink.hpp"

namespace drivetap {

enum class StatisticKind : std::uint8_t { stations, functions, gaps, load };

// One -z argument: "stations", "functions", "gaps", "load" or "load,SECONDS".
struct StatisticRequest {
  StatisticKind kind = StatisticKind::stations;
  TimeNs interval = kNsPerSecond;  // load: the interval each row covers
};

// The request `spec` names; nullopt with *error set (the whole message after "drivetap: ")
// otherwise.
std::optional<StatisticRequest> parse_statistic(std::string_view spec, std::string* error);

// A distribution of non-negative durations in fixed memory, whatever the count: a log-linear
// histogram (as HdrHistogram), exact below 128 ns, above in 64 buckets per power of two. A
// percentile is the midpoint of the bucket holding the nearest-rank value, kept within the exact
// minimum and maximum: within 1/128 (0.8 %) of the true nearest-rank value.
class LogHistogram {
 public:
  static constexpr int kSubBucketBits = 6;
  void add(TimeNs value);
  [[nodiscard]] std::uint64_t count() const { return count_; }
  [[nodiscard]] TimeNs min() const { return min_; }
  [[nodiscard]] TimeNs max() const { return max_; }
  // The nearest-rank percentile (0 < percent <= 100): the value at rank ceil(percent/100 * count),
  // within the resolution above; -1 when empty.
  [[nodiscard]] TimeNs percentile(int percent) const;
  // Each bucket that holds values, in increasing order: visit(low, width, count) (ns).
  template <class Visit>
  void for_each_bucket(Visit visit) const {
    for (std::size_t k = 0; k < counts_.size(); ++k)
      if (counts_[k] != 0) visit(bucket_low(first_ + k), bucket_width(first_ + k), counts_[k]);
  }
  // Adds the values `other` holds.
  void merge(const LogHistogram& other);

  static std::size_t bucket_of(std::uint64_t value);
  static std::uint64_t bucket_low(std::size_t bucket);
  static std::uint64_t bucket_width(std::size_t bucket);

 private:
  // Buckets first_ .. first_ + size - 1: from the lowest used to the highest (of some 3800), so
  // that a station whose replies take 10-20 ms keeps some 70 counts, not 1500.
  void count(std::size_t bucket, std::uint64_t n);
  std::vector<std::uint64_t> counts_;
  std::size_t first_ = 0;
  std::uint64_t count_ = 0;
  TimeNs min_ = -1;
  TimeNs max_ = -1;
};

// Counts what the requested statistics need from the records it gets and writes the tables at
// the end (tables()). It asks the pipeline for no field trees or info lines, and takes telegrams
// undecoded (dissecting them to their head itself), so that `--stats -z stations` stays fast;
// beside another sink, BesideSink hands it the same records.
class StatsTablesSink final : public Sink {
 public:
  // `timed`: the records have real times (not `decode`'s); without them latency, poll interval,
  // gaps and load are not shown.
  StatsTablesSink(const ChannelTable& channels, FramingTiming timing, bool timed,
                  std::vector<StatisticRequest> requests);
  void on_frame(const Message& message) override;
  void on_noise(const Frame& noise) override;
  void on_transaction(const Transaction& transaction) override;
  bool flush() override { return true; }
  [[nodiscard]] SinkNeeds needs() const override;
  void on_deferred_frame(const DeferredTelegram& telegram) override;
  // -z stations lists only the `rows` busiest stations (most requests and replies) and sums the
  // rest in one last row (the report: its page stays small whatever the station count).
  void limit_station_rows(std::size_t rows) { station_rows_ = rows; }

  // The tables, in the order requested: text (tshark's "====" blocks) or JSON lines (one
  // {"type":"stat",...} record per row).
  [[nodiscard]] std::string tables(bool json) const;
  // The same handed to `write` a part at a time (some 64 KiB: a day of load rows runs to
  // megabytes), each part whole lines.
  void write_tables(bool json, const std::function<void(std::string_view)>& write) const;

  // Gap bins: below t1.5, t1.5 .. t3.5, then t3.5 * 2^k .. t3.5 * 2^(k+1) for k < kGapDoublings,
  // then the rest.
  static constexpr std::size_t kGapDoublings = 16;
  static constexpr std::size_t kGapBins = 2 + kGapDoublings + 1;
  // Load: a run of more idle intervals than this between two busy ones is one row.
  static constexpr std::int64_t kMaxIdleRows = 10;

 private:
  struct StationKey {
    ChannelId channel = 0;
    Protocol protocol;
    int address = -1;
    friend bool operator<(const StationKey& a, const StationKey& b) {
      return std::tuple(a.channel, protocol_id(a.protocol), a.address) <
             std::tuple(b.channel, protocol_id(b.protocol), b.address);
    }
  };
  // What the transactions of a station, or of a function code, held: requests, replies and
  // exception replies.
  struct ExchangeCounts {
    std::uint64_t requests = 0;
    std::uint64_t replies = 0;
    std::uint64_t exceptions = 0;
    void count(const Transaction& t) {
      if (t.request_number != 0) ++requests;
      if (t.response_number != 0) ++replies;
      if (t.outcome == Outcome::exception) ++exceptions;
    }
  };
  struct Station : ExchangeCounts {
    std::uint64_t timeouts = 0;
    std::uint64_t bad_checksums = 0;
    std::uint64_t bytes = 0;
    LogHistogram latency;
    // Poll interval: time between consecutive request frames (Welford's running mean and sum of
    // squared deviations).
    TimeNs last_request = -1;
    std::uint64_t polls = 0;
    double poll_mean = 0;
    double poll_m2 = 0;
  };
  struct FunctionKey {
    Protocol protocol;
    int function = -1;
    friend bool operator<(const FunctionKey& a, const FunctionKey& b) {
      return std::tuple(protocol_id(a.protocol), a.function) <
             std::tuple(protocol_id(b.protocol), b.function);
    }
  };
  struct LoadCell {
    std::uint64_t frames = 0;
    std::uint64_t bytes = 0;
    TimeNs busy = 0;
  };
  // Load: each request's intervals, counted from the first record's start.
  // At most this many intervals with traffic are kept a series: past it, the series' intervals
  // are doubled (two merged into one) and its table says so, so that `-z load,0.001` over days
  // of traffic keeps its memory and its rows bounded.
  static constexpr std::size_t kMaxLoadIntervals = 100000;
  struct LoadSeries {
    TimeNs requested = kNsPerSecond;  // the interval -z asked for
    TimeNs interval = kNsPerSecond;   // the interval counted in: `requested` doubled as needed
    std::map<std::int64_t, std::vector<LoadCell>> cells;  // by interval, then channel
    // The interval last counted in (most frames fall in the one before them).
    std::int64_t last = 0;
    std::vector<LoadCell>* last_cells = nullptr;
  };

  // What every telegram adds, however it came.
  void count_telegram(ChannelId channel, Protocol protocol, int address, Direction direction,
                      ChecksumVerdict verdict, std::size_t size, TimeNs start, TimeNs gap_before);
  void count_bytes(ChannelId channel, std::size_t size, TimeNs start, bool telegram);
  static void widen(LoadSeries& series);
  Station& station(ChannelId channel, Protocol protocol, int address);

  void stations_table(std::string& out, bool json) const;
  void functions_table(std::string& out, bool json) const;
  void gaps_table(std::string& out, bool json) const;
  void load_table(std::string& out, bool json, const LoadSeries& series,
                  const std::function<void(std::string_view)>& write) const;

  const ChannelTable& channels_;
  FramingTiming timing_;
  bool timed_;
  std::vector<StatisticRequest> requests_;
  bool stations_ = false, functions_ = false, gaps_ = false;
  std::size_t station_rows_ = static_cast<std::size_t>(-1);

  std::map<StationKey, Station> stations_by_key_;
  // The station last counted (a reply follows its request): its key and row.
  StationKey last_key_;
  Station* last_station_ = nullptr;
  std::vector<std::uint64_t> channel_bytes_;  // telegrams and noise, by channel
  std::map<FunctionKey, ExchangeCounts> functions_by_key_;
  std::array<std::uint64_t, kGapBins> gap_bins_{};
  std::uint64_t gap_count_ = 0;
  TimeNs load_origin_ = -1;
  bool have_load_origin_ = false;
  std::vector<LoadSeries> load_series_;
  Message scratch_;  // an undecoded telegram's head, for protocols that dissect in detail
};

// Hands every record to `main` and to `counter` (a StatsTablesSink): main's needs with the records
// and transactions the counter asks for besides. Telegrams handed over undecoded go to both when
// main takes records (main may decode on its own thread: the counter reads only their heads).
class BesideSink final : public ForwardingSink {
 public:
  BesideSink(Sink& main, Sink& counter);
  void on_frame(const Message& m) override;
  void on_noise(const Frame& f) override;
  void on_anomaly(const Anomaly& a) override;
  void on_transaction(const Transaction& t) override;
  [[nodiscard]] SinkNeeds needs() const override { return needs_; }
  void on_deferred_frame(const DeferredTelegram& telegram) override;
  [[nodiscard]] Sink& main() const { return next_; }

 private:
  Sink& counter_;
  const SinkNeeds main_needs_;
  const SinkNeeds counter_needs_;
  const SinkNeeds needs_;
};

}  // namespace drivetap
