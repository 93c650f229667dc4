// ByteEvents (src/core/byte_events.hpp) against the plain vector of ByteEvents it stands for:
// every way of filling it gives the same events, and the timing read off its stretches is what
// ByteRunTiming finds byte by byte.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "core/byte_events.hpp"
#include "core/frame.hpp"
#include "core/protocol.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"

namespace drivetap {
namespace {

constexpr TimeNs kChar = 572'917;  // 19200 8E1

void expect_same(const ByteEvents& got, const std::vector<ByteEvent>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    SCOPED_TRACE(i);
    const ByteEvent e = got[i];
    EXPECT_EQ(e.time, want[i].time);
    EXPECT_EQ(e.byte, want[i].byte);
    EXPECT_EQ(e.flags, want[i].flags);
    EXPECT_EQ(e.channel, want[i].channel);
    EXPECT_EQ(e.origin, want[i].origin);
    EXPECT_EQ(got.time(i), want[i].time);
    EXPECT_EQ(got.byte(i), want[i].byte);
    EXPECT_EQ(got.flags(i), want[i].flags);
    EXPECT_EQ(got.origin(i), want[i].origin);
  }
  // Iteration gives the same as indexing.
  std::size_t i = 0;
  for (const ByteEvent& e : got) {
    ASSERT_LT(i, want.size());
    EXPECT_EQ(e.time, want[i].time);
    EXPECT_EQ(e.byte, want[i].byte);
    ++i;
  }
  EXPECT_EQ(i, want.size());
  if (!want.empty()) {
    EXPECT_EQ(got.front_time(), want.front().time);
    EXPECT_EQ(got.back_time(), want.back().time);
  }
  EXPECT_EQ(got, ByteEvents(std::span<const ByteEvent>(want)));
}

// A random run: back to back (most), spaced wider, overlapping, one byte, marked, another origin.
struct TestRun {
  std::vector<std::uint8_t> bytes, flags;
  TimeNs first = 0, step = 0;
  ChannelId channel = 0;
  std::uint32_t origin = 0;
};

TestRun random_run(std::mt19937& rng, TimeNs& clock) {
  TestRun r;
  const std::size_t n = 1 + rng() % 12;
  for (std::size_t i = 0; i < n; ++i) r.bytes.push_back(static_cast<std::uint8_t>(rng()));
  const unsigned kind = rng() % 8;
  r.step = kind < 4    ? kChar
           : kind == 4 ? kChar + static_cast<TimeNs>(rng() % 5000)
           : kind == 5 ? 0
                       : kChar / 2;
  // Sometimes right after the previous run (the stretch continues), sometimes after a silence.
  clock += rng() % 3 == 0 ? 0 : static_cast<TimeNs>(rng() % 4'000'000);
  r.first = clock;
  clock = r.first + static_cast<TimeNs>(n) * r.step;
  if (rng() % 6 == 0) {
    r.flags.assign(n, 0);
    r.flags[rng() % n] = kUartParityError;
  }
  r.channel = static_cast<ChannelId>(rng() % 5 == 0 ? 1 : 0);
  r.origin = static_cast<std::uint32_t>(rng() % 4 == 0 ? rng() % 3 : 0);
  return r;
}

std::vector<ByteEvent> events_of(const TestRun& r) {
  std::vector<ByteEvent> out;
  for (std::size_t i = 0; i < r.bytes.size(); ++i)
    out.push_back({r.first + static_cast<TimeNs>(i) * r.step, r.bytes[i],
                   r.flags.empty() ? std::uint8_t{0} : r.flags[i], r.channel, r.origin});
  return out;
}

TEST(ByteEvents, PushBackAndAppendRunGiveTheEventsOfAVector) {
  std::mt19937 rng(7);
  for (int round = 0; round < 300; ++round) {
    SCOPED_TRACE(round);
    ByteEvents by_event, by_run;
    std::vector<ByteEvent> want;
    TimeNs clock = 1'000'000;
    const int runs = 1 + static_cast<int>(rng() % 8);
    for (int k = 0; k < runs; ++k) {
      const TestRun r = random_run(rng, clock);
      const std::vector<ByteEvent> ev = events_of(r);
      for (const ByteEvent& e : ev) by_event.push_back(e);
      by_run.append_run(ByteRun{r.bytes, r.first, r.step, r.channel, r.origin, r.flags});
      want.insert(want.end(), ev.begin(), ev.end());
    }
    expect_same(by_event, want);
    expect_same(by_run, want);
    // Back to back runs of one origin and channel are one stretch, not one per byte.
    if (by_run.stretches().size() > static_cast<std::size_t>(runs) * 2) ADD_FAILURE();
  }
}

TEST(ByteEvents, RangesErasePopAndSwapKeepTheEvents) {
  std::mt19937 rng(11);
  for (int round = 0; round < 300; ++round) {
    SCOPED_TRACE(round);
    ByteEvents seq;
    std::vector<ByteEvent> want;
    TimeNs clock = 0;
    for (int k = 0; k < 6; ++k) {
      const TestRun r = random_run(rng, clock);
      seq.append_run(ByteRun{r.bytes, r.first, r.step, r.channel, r.origin, r.flags});
      const std::vector<ByteEvent> ev = events_of(r);
      want.insert(want.end(), ev.begin(), ev.end());
    }
    // A range of it appended to another sequence (after some events of its own).
    const std::size_t from = rng() % want.size();
    const std::size_t count = rng() % (want.size() - from + 1);
    ByteEvents part{ByteEvent{5, 0xAA, 0, 0, 0}};
    part.append_range(seq, from, count);
    std::vector<ByteEvent> want_part{ByteEvent{5, 0xAA, 0, 0, 0}};
    want_part.insert(want_part.end(), want.begin() + static_cast<std::ptrdiff_t>(from),
                     want.begin() + static_cast<std::ptrdiff_t>(from + count));
    expect_same(part, want_part);
    // The first n dropped, the last one popped.
    const std::size_t n = rng() % (want.size() + 1);
    seq.erase_front(n);
    want.erase(want.begin(), want.begin() + static_cast<std::ptrdiff_t>(n));
    expect_same(seq, want);
    if (!want.empty()) {
      seq.pop_back();
      want.pop_back();
      expect_same(seq, want);
    }
    ByteEvents other;
    other.swap(seq);
    expect_same(other, want);
    EXPECT_TRUE(seq.empty());
  }
}

TEST(ByteEvents, EqualityIsThatOfTheEvents) {
  ByteEvents a{{10, 1, 0, 0, 0}, {20, 2, 0, 0, 0}, {30, 3, 0, 0, 0}};
  ByteEvents b;
  b.append_run(ByteRun{std::vector<std::uint8_t>{1, 2}, 10, 10, 0, 0, {}});
  b.push_back({30, 3, 0, 0, 0});
  EXPECT_EQ(a, b);
  b.pop_back();
  b.push_back({31, 3, 0, 0, 0});
  EXPECT_NE(a, b);
  b.pop_back();
  b.push_back({30, 3, kUartFramingError, 0, 0});
  EXPECT_NE(a, b);
  EXPECT_TRUE(b.any_flags());
  EXPECT_FALSE(a.any_flags());
}

TEST(ByteEvents, StepsTooLargeToMultiplyStartStretchesInsteadOfOverflowing) {
  ByteEvents seq;
  const TimeNs big = kTimeLimit - 10;
  seq.push_back({-big, 1, 0, 0, 0});
  seq.push_back({big, 2, 0, 0, 0});  // step 2 * big - 20: the next multiple overflows
  seq.push_back({big + 5, 3, 0, 0, 0});
  expect_same(seq, {{-big, 1, 0, 0, 0}, {big, 2, 0, 0, 0}, {big + 5, 3, 0, 0, 0}});
}

TEST(ByteEvents, TimingFromStretchesIsTheTimingByteByByte) {
  std::mt19937 rng(3);
  for (int round = 0; round < 500; ++round) {
    SCOPED_TRACE(round);
    ByteEvents seq;
    std::vector<ByteEvent> want;
    TimeNs clock = 0;
    const int runs = 1 + static_cast<int>(rng() % 5);
    for (int k = 0; k < runs; ++k) {
      TestRun r = random_run(rng, clock);
      r.channel = 0;
      if (rng() % 5 == 0) r.first -= static_cast<TimeNs>(rng() % (3 * kChar));  // overlaps
      seq.append_run(ByteRun{r.bytes, r.first, r.step, r.channel, r.origin, r.flags});
      const std::vector<ByteEvent> ev = events_of(r);
      want.insert(want.end(), ev.begin(), ev.end());
    }
    ByteRunTiming expected;
    expected.start(want.front().time, kChar);
    for (std::size_t i = 1; i < want.size(); ++i) expected.add(want[i].time, i, kChar);
    const ByteRunTiming got = timing_of(seq, kChar);
    EXPECT_EQ(got.end, expected.end);
    EXPECT_EQ(got.max_gap, expected.max_gap);
    EXPECT_EQ(got.max_gap_at, expected.max_gap_at);
  }
}

// A chunk's prechecks sit beside its runs (RunBatch::set_precheck): handed with run k while set
// by a decoder, none for the other runs, gone with clear().
TEST(RunBatch, PrechecksStayWithTheirRunsUntilCleared) {
  const std::vector<std::uint8_t> bytes{1, 2, 3, 4, 5, 6};
  RunBatch batch;
  for (int k = 0; k < 4; ++k) batch.add(ByteRun{bytes, k * 1000, 10, 0, 0, {}});
  EXPECT_FALSE(batch.has_prechecks());
  EXPECT_EQ(batch.precheck(1), nullptr);
  const ProtocolDecoder* const some_decoder = decoder_for(protocols::modbus_rtu);
  TelegramPrecheck made;
  made.decoder = some_decoder;
  made.checksum = 0xBEEF;
  batch.set_precheck(2, made);
  ASSERT_TRUE(batch.has_prechecks());
  EXPECT_EQ(batch.precheck(0), nullptr);
  EXPECT_EQ(batch.precheck(1), nullptr);
  ASSERT_NE(batch.precheck(2), nullptr);
  EXPECT_EQ(batch.precheck(2)->checksum, 0xBEEFu);
  EXPECT_EQ(batch.precheck(3), nullptr);
  EXPECT_EQ(batch.precheck(4), nullptr);          // past the runs
  batch.add(ByteRun{bytes, 9000, 10, 0, 0, {}});  // a run added later has none
  EXPECT_EQ(batch.precheck(4), nullptr);
  made.decoder = nullptr;  // a precheck no decoder made is none
  batch.set_precheck(1, made);
  EXPECT_EQ(batch.precheck(1), nullptr);
  batch.clear();
  EXPECT_FALSE(batch.has_prechecks());
  batch.add(ByteRun{bytes, 0, 10, 0, 0, {}});
  EXPECT_EQ(batch.precheck(0), nullptr);
}
}  // namespace
}  // namespace drivetap
