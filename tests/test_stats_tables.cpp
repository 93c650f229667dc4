// Unit tests: the -z statistics (src/sinks/stats_tables.*): the latency histogram's buckets and
// its nearest-rank percentiles against the exact ones, the gap bins at their bounds, the load
// split over intervals, what the counter asks of the pipeline beside other sinks, -z parsing.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "sinks/stats_tables.hpp"

using namespace drivetap;

namespace {

// A telegram of `size` bytes on channel 0, its bytes back to back from `start`.
Message telegram(TimeNs start, std::size_t size, TimeNs character_time, TimeNs gap_before,
                 Direction direction = Direction::request, int address = 1) {
  Message m;
  for (std::size_t i = 0; i < size; ++i)
    m.frame.events.push_back(
        ByteEvent{start + static_cast<TimeNs>(i) * character_time, std::uint8_t{0x01}, 0, 0, 0});
  m.frame.gap_before = gap_before;
  m.direction = direction;
  m.address = address;
  m.bytes.assign(size, 0x01);
  return m;
}

// The value of a JSON number key in `text` after `from` ("key":VALUE).
std::string value_after(const std::string& text, const std::string& key, std::size_t from = 0) {
  const std::size_t at = text.find("\"" + key + "\":", from);
  if (at == std::string::npos) return "";
  const std::size_t start = at + key.size() + 3;
  return text.substr(start, text.find_first_of(",}", start) - start);
}

}  // namespace

TEST(StatsTables, HistogramBucketsTileTheRangeWithinOne64th) {
  for (std::size_t b = 0; b < 3000; ++b) {
    const std::uint64_t low = LogHistogram::bucket_low(b);
    const std::uint64_t width = LogHistogram::bucket_width(b);
    ASSERT_EQ(LogHistogram::bucket_low(b + 1), low + width) << b;
    ASSERT_EQ(LogHistogram::bucket_of(low), b) << b;
    ASSERT_EQ(LogHistogram::bucket_of(low + width - 1), b) << b;
    if (b >= 128) {
      ASSERT_LE(width * 64, low) << b;  // a width at most 1/64 of the values
    }
  }
  EXPECT_EQ(LogHistogram::bucket_of(127), 127u);
  EXPECT_EQ(LogHistogram::bucket_of(128), 128u);
  // The largest time fits (some 3800 buckets for every int64).
  EXPECT_LT(LogHistogram::bucket_of(std::uint64_t{1} << 62), 4000u);
}

TEST(StatsTables, PercentilesAreNearestRankWithin128th) {
  std::mt19937_64 random(7);
  for (const std::size_t n : {1u, 2u, 3u, 19u, 20u, 21u, 100u, 1001u, 50000u}) {
    LogHistogram h;
    std::vector<TimeNs> values;
    for (std::size_t i = 0; i < n; ++i) {
      // Latencies from 0 to some 5 s, over several octaves.
      const TimeNs v = static_cast<TimeNs>(random() % (TimeNs{1} << (10 + random() % 23)));
      values.push_back(v);
      h.add(v);
    }
    std::sort(values.begin(), values.end());
    EXPECT_EQ(h.count(), n);
    EXPECT_EQ(h.min(), values.front());
    EXPECT_EQ(h.max(), values.back());
    for (const int p : {1, 50, 95, 99, 100}) {
      const std::size_t rank = std::max<std::size_t>(1, (p * n + 99) / 100);
      const TimeNs exact = values[rank - 1];
      const TimeNs got = h.percentile(p);
      EXPECT_LE(std::abs(got - exact), exact / 128) << "n " << n << " p" << p;
    }
  }
  LogHistogram empty;
  EXPECT_EQ(empty.percentile(50), -1);
  LogHistogram small;  // exact below 128 ns
  for (const TimeNs v : {5, 7, 9, 11}) small.add(v);
  EXPECT_EQ(small.percentile(50), 7);
  EXPECT_EQ(small.percentile(51), 9);
}

// The histogram keeps the buckets from its lowest value to its highest: values that arrive falling,
// rising or in two halves merged give the same buckets and percentiles.
TEST(StatsTables, HistogramKeepsItsRangeWhateverTheOrderAndMerges) {
  std::mt19937_64 random(11);
  std::vector<TimeNs> values;
  for (int i = 0; i < 2000; ++i)
    values.push_back(static_cast<TimeNs>(random() % (TimeNs{1} << (5 + random() % 30))));
  std::vector<TimeNs> falling = values;
  std::sort(falling.rbegin(), falling.rend());
  LogHistogram in_order, reversed, first_half, second_half;
  for (std::size_t i = 0; i < values.size(); ++i) {
    in_order.add(values[i]);
    reversed.add(falling[i]);
    (i % 2 ? first_half : second_half).add(values[i]);
  }
  first_half.merge(second_half);
  const auto buckets = [](const LogHistogram& h) {
    std::vector<std::array<std::uint64_t, 3>> out;
    h.for_each_bucket([&out](std::uint64_t low, std::uint64_t width, std::uint64_t count) {
      out.push_back({low, width, count});
    });
    return out;
  };
  EXPECT_EQ(buckets(in_order), buckets(reversed));
  EXPECT_EQ(buckets(in_order), buckets(first_half));
  for (const LogHistogram* h : {&reversed, &first_half}) {
    EXPECT_EQ(h->count(), in_order.count());
    EXPECT_EQ(h->min(), in_order.min());
    EXPECT_EQ(h->max(), in_order.max());
    for (const int p : {1, 50, 95, 99, 100}) EXPECT_EQ(h->percentile(p), in_order.percentile(p));
  }
  LogHistogram empty;
  in_order.merge(empty);
  EXPECT_EQ(in_order.count(), values.size());
  empty.merge(in_order);
  EXPECT_EQ(buckets(empty), buckets(in_order));
}

TEST(StatsTables, GapBinsSplitAtT15AndT35AndTheirDoublings) {
  ChannelTable channels;
  channels.intern("bus");
  const FramingTiming timing{750'000, 1'750'000, 500'000};
  StatsTablesSink sink(channels, timing, true, {{StatisticKind::gaps, kNsPerSecond}});
  TimeNs t = 0;
  // One gap each just below and at every bound: t1.5, t3.5, 2 t3.5, 4 t3.5.
  for (const TimeNs gap :
       {TimeNs{749'999}, TimeNs{750'000}, TimeNs{1'749'999}, TimeNs{1'750'000}, TimeNs{3'499'999},
        TimeNs{3'500'000}, TimeNs{6'999'999}, TimeNs{7'000'000}}) {
    t += kNsPerSecond;
    sink.on_frame(telegram(t, 8, timing.character_time, gap));
  }
  sink.on_frame(telegram(t + kNsPerSecond, 8, timing.character_time, -1));  // no gap: not counted
  const std::string json = sink.tables(true);
  EXPECT_EQ(value_after(json, "frames"), "8");
  // Bins: [0, t1.5) 1, [t1.5, t3.5) 2, [t3.5, 7) 2, [7, 14) 2, [14, 28) 1.
  std::vector<std::string> counts;
  for (std::size_t at = json.find("\"count\":"); at != std::string::npos;
       at = json.find("\"count\":", at + 1))
    counts.push_back(value_after(json, "count", at));
  EXPECT_EQ(counts, (std::vector<std::string>{"1", "2", "2", "2", "1"}));
}

TEST(StatsTables, LoadSplitsBusyTimeOverIntervals) {
  ChannelTable channels;
  channels.intern("bus");
  const FramingTiming timing{750'000, 1'750'000, 1'000'000};  // 1 ms a character
  StatsTablesSink sink(channels, timing, true, {{StatisticKind::load, kNsPerSecond}});
  // t0 = 10 s; a 10-byte frame from 10.995 s: 5 ms in the first interval, 5 ms in the second.
  sink.on_frame(telegram(10 * kNsPerSecond, 1, timing.character_time, -1));
  sink.on_frame(telegram(10 * kNsPerSecond + 995'000'000, 10, timing.character_time, 1));
  // 30 idle intervals later, one byte: the idle ones are one row.
  sink.on_frame(telegram(42 * kNsPerSecond, 1, timing.character_time, 1));
  const std::string json = sink.tables(true);
  std::vector<std::string> rows;
  for (std::size_t at = 0, end; (end = json.find('\n', at)) != std::string::npos; at = end + 1)
    rows.push_back(json.substr(at, end - at));
  ASSERT_EQ(rows.size(), 4u) << json;
  EXPECT_EQ(value_after(rows[0], "frames"), "2");
  EXPECT_EQ(value_after(rows[0], "bytes"), "11");
  EXPECT_EQ(value_after(rows[0], "busy_pct"), "0.600");  // 1 + 5 ms of 1 s
  EXPECT_EQ(value_after(rows[1], "frames"), "0");
  EXPECT_EQ(value_after(rows[1], "busy_pct"), "0.500");
  EXPECT_EQ(value_after(rows[2], "from_s"), "2.000");
  EXPECT_EQ(value_after(rows[2], "to_s"), "32.000");
  EXPECT_EQ(value_after(rows[2], "busy_pct"), "0.000");
  EXPECT_EQ(value_after(rows[3], "from_s"), "32.000");
  EXPECT_EQ(value_after(rows[3], "busy_pct"), "0.100");
}

TEST(StatsTables, PollIntervalMeanAndJitter) {
  ChannelTable channels;
  channels.intern("bus");
  const FramingTiming timing{750'000, 1'750'000, 500'000};
  StatsTablesSink sink(channels, timing, true, {{StatisticKind::stations, kNsPerSecond}});
  // Requests 100, 300 and 600 ms apart... intervals 100, 300 ms (replies do not count).
  sink.on_frame(telegram(0, 8, timing.character_time, -1));
  sink.on_frame(telegram(50'000'000, 8, timing.character_time, 1, Direction::response));
  sink.on_frame(telegram(100'000'000, 8, timing.character_time, 1));
  sink.on_frame(telegram(400'000'000, 8, timing.character_time, 1));
  const std::string json = sink.tables(true);
  EXPECT_EQ(value_after(json, "mean"), "200.000");
  EXPECT_EQ(value_after(json, "jitter"), "100.000");
  EXPECT_EQ(value_after(json, "bytes"), "32");
  EXPECT_EQ(value_after(json, "share_pct"), "100.000");
}

TEST(StatsTables, AsksForHeadsAloneAndKeepsTheMainSinksNeeds) {
  ChannelTable channels;
  StatsTablesSink stations(channels, {}, true, {{StatisticKind::stations, kNsPerSecond}});
  const SinkNeeds alone = stations.needs();
  EXPECT_TRUE(alone.records);
  EXPECT_TRUE(alone.transactions);
  EXPECT_FALSE(alone.detail);
  EXPECT_FALSE(alone.fields);
  EXPECT_FALSE(alone.events);
  EXPECT_TRUE(alone.deferred_decode);
  StatsTablesSink functions(channels, {}, true, {{StatisticKind::functions, kNsPerSecond}});
  EXPECT_FALSE(functions.needs().records);  // transactions alone
  EXPECT_TRUE(functions.needs().transactions);

  // Beside a sink that shows everything and decodes on its own thread: its needs, and the
  // counter's transactions.
  class Shows final : public RecordDroppingSink {
   public:
    using RecordDroppingSink::RecordDroppingSink;
    [[nodiscard]] SinkNeeds needs() const override {
      SinkNeeds n;
      n.transactions = false;
      n.deferred_decode = true;
      n.drive_info = true;
      return n;
    }
  };
  class Nothing final : public RecordDroppingSink {
   public:
    using RecordDroppingSink::RecordDroppingSink;
    [[nodiscard]] SinkNeeds needs() const override { return SinkNeeds::none(); }
  };
  TeeSink tee;
  Shows shows(tee);
  const SinkNeeds beside = BesideSink(shows, stations).needs();
  EXPECT_TRUE(beside.records && beside.detail && beside.fields && beside.transactions);
  EXPECT_TRUE(beside.deferred_decode && beside.drive_info);
  // Beside a sink that takes no records (--stats): the counter's needs.
  Nothing nothing(tee);
  const SinkNeeds stats_only = BesideSink(nothing, stations).needs();
  EXPECT_TRUE(stats_only.records && stats_only.transactions && stats_only.deferred_decode);
  EXPECT_FALSE(stats_only.detail || stats_only.fields || stats_only.drive_info);
}

TEST(StatsTables, ParsesNamesAndLoadIntervals) {
  std::string error;
  EXPECT_EQ(parse_statistic("stations", &error)->kind, StatisticKind::stations);
  EXPECT_EQ(parse_statistic("load", &error)->interval, kNsPerSecond);
  EXPECT_EQ(parse_statistic("load,0.25", &error)->interval, 250'000'000);
  EXPECT_FALSE(parse_statistic("x", &error));
  EXPECT_EQ(error, "-z: unknown statistic 'x' (stations, functions, gaps, load)");
  EXPECT_FALSE(parse_statistic("load,", &error));
  EXPECT_FALSE(parse_statistic("load,-1", &error));
  EXPECT_FALSE(parse_statistic("load,1s", &error));
  EXPECT_FALSE(parse_statistic("gaps,1", &error));
}
