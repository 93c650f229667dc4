// Unit tests: the hybrid Modbus RTU framer (silence + length prediction + CRC).
#include <gtest/gtest.h>

#include <random>

#include <fmt/format.h>

#include "core/checksum.hpp"
#include "dissectors/modbus/rtu_dissector.hpp"
#include "dissectors/modbus/rtu_framer.hpp"
#include "test_support.hpp"

using namespace drivetap;
using namespace drivetap::modbus;
using drivetap::testing::with_crc;

namespace {

const SerialConfig k9600 = {9600, 8, Parity::none, 1};
const TimeNs kChar = k9600.character_time();

const std::vector<std::uint8_t> kRequest = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02});
const std::vector<std::uint8_t> kReply = with_crc({0x01, 0x03, 0x04, 0x00, 0x0A, 0x01, 0xF4});

struct Feed {
  RtuFramer framer{0, RtuFramerOptions{FramingTiming::from(k9600), 100 * kNsPerMs, 4096}};
  FrameBatch out;
  TimeNs clock = 0;

  // Bytes back to back from `at` (or from the clock), each stamped `stamp_each` or at its time.
  void bytes(const std::vector<std::uint8_t>& b, TimeNs at = -1, bool one_stamp = false,
             std::uint8_t flags = 0) {
    if (at >= 0) clock = at;
    const TimeNs first = clock;
    for (std::uint8_t v : b) {
      ByteEvent e{one_stamp ? first : clock, v, flags, 0};
      framer.advance(e.time, out);
      framer.push(e, out);
      clock += kChar;
    }
  }
  void silence(TimeNs t) {
    clock += t;
    framer.advance(clock, out);
  }
  void finish() { framer.finish(out); }
  std::vector<std::uint8_t> bytes_of(std::size_t i) const { return out.at(i).bytes(); }
};

// `bytes` evenly spaced from `clock` on (a character apart), then `silence`.
void append_bytes(std::vector<ByteEvent>& events, TimeNs& clock,
                  const std::vector<std::uint8_t>& bytes, TimeNs silence = 0) {
  for (const std::uint8_t b : bytes) {
    events.push_back(ByteEvent{clock, b, 0, 0});
    clock += kChar;
  }
  clock += silence;
}

// `events` through one framer byte by byte (push) and through another in one push() call:
// the same frames must come out. Returns them.
std::vector<Frame> frames_alike_by_push_and_push_span(const std::vector<ByteEvent>& events) {
  RtuFramer one_by_one(0, RtuFramerOptions{FramingTiming::from(k9600)});
  RtuFramer at_once(0, RtuFramerOptions{FramingTiming::from(k9600)});
  FrameBatch expected, got;
  for (const ByteEvent& e : events) one_by_one.push(e, expected);
  one_by_one.finish(expected);
  at_once.push_all(events, got);
  at_once.finish(got);
  EXPECT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size() && i < expected.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(got[i].events, expected[i].events);
    EXPECT_EQ(got[i].kind, expected[i].kind);
    EXPECT_EQ(got[i].close, expected[i].close);
  }
  return expected.take();
}

}  // namespace

TEST(RtuFramer, FramesSeparatedBySilence) {
  Feed f;
  f.bytes(kRequest, 0);
  f.silence(10 * kNsPerMs);
  f.bytes(kReply);
  f.silence(10 * kNsPerMs);
  ASSERT_EQ(f.out.size(), 2u);
  EXPECT_EQ(f.bytes_of(0), kRequest);
  EXPECT_EQ(f.bytes_of(1), kReply);
  EXPECT_EQ(f.out[0].close, FrameClose::silence);
  EXPECT_EQ(f.out[0].gap_before, -1);
  EXPECT_GT(f.out[1].gap_before, 9 * kNsPerMs);
}

TEST(RtuFramer, ClosesOnlyAfterT35OfSilence) {
  Feed f;
  f.bytes(kRequest, 0);
  f.silence(k9600.t35() - kNsPerUs);
  EXPECT_TRUE(f.out.empty()) << "closed before t3.5 elapsed";
  f.silence(2 * kNsPerUs);
  EXPECT_EQ(f.out.size(), 1u);
}

TEST(RtuFramer, SplitsRequestAndReplyWithOneTimestampByContent) {
  Feed f;
  std::vector<std::uint8_t> both = kRequest;
  both.insert(both.end(), kReply.begin(), kReply.end());
  f.bytes(both, 0, /*one_stamp=*/true);
  f.finish();
  ASSERT_EQ(f.out.size(), 2u);
  EXPECT_EQ(f.bytes_of(0), kRequest);
  EXPECT_EQ(f.bytes_of(1), kReply);
  EXPECT_EQ(f.out[0].close, FrameClose::content);
  EXPECT_EQ(f.out[1].kind, FrameKind::telegram);
}

TEST(RtuFramer, StrayByteBetweenFramesIsOneNoiseRecord) {
  Feed f;
  f.bytes(kRequest, 0);
  f.silence(10 * kNsPerMs);
  f.bytes({0xFF});
  f.silence(10 * kNsPerMs);
  f.bytes(kReply);
  f.finish();
  ASSERT_EQ(f.out.size(), 3u);
  EXPECT_EQ(f.out[1].kind, FrameKind::noise);
  EXPECT_EQ(f.bytes_of(1), std::vector<std::uint8_t>{0xFF});
  EXPECT_EQ(f.bytes_of(2), kReply);
}

TEST(RtuFramer, NoiseGluedBeforeAFrameIsSplitOff) {
  Feed f;
  std::vector<std::uint8_t> glued = {0x00, 0x55};
  glued.insert(glued.end(), kRequest.begin(), kRequest.end());
  f.bytes(glued, 0);
  f.finish();
  ASSERT_EQ(f.out.size(), 2u);
  EXPECT_EQ(f.out[0].kind, FrameKind::noise);
  EXPECT_EQ(f.bytes_of(0), (std::vector<std::uint8_t>{0x00, 0x55}));
  EXPECT_EQ(f.bytes_of(1), kRequest);
}

TEST(RtuFramer, TwoCharacterGapInsideFrameKeepsOneFrame) {
  Feed f;
  f.bytes({kRequest.begin(), kRequest.begin() + 4}, 0);
  f.silence(2 * kChar);
  f.bytes({kRequest.begin() + 4, kRequest.end()});
  f.finish();
  ASSERT_EQ(f.out.size(), 1u);
  EXPECT_EQ(f.bytes_of(0), kRequest);
  EXPECT_EQ(f.out[0].max_intra_gap, 2 * kChar);
  EXPECT_EQ(f.out[0].max_intra_gap_at, 4u);
}

TEST(RtuFramer, FrameSplitByAdapterLatencyIsJoinedByCrc) {
  Feed f;
  f.bytes({kRequest.begin(), kRequest.begin() + 3}, 0);
  f.silence(16 * kNsPerMs);  // > t3.5: looks like a boundary
  f.bytes({kRequest.begin() + 3, kRequest.end()});
  f.silence(20 * kNsPerMs);
  ASSERT_EQ(f.out.size(), 1u);
  EXPECT_EQ(f.bytes_of(0), kRequest);
  EXPECT_GT(f.out[0].max_intra_gap, 15 * kNsPerMs);
}

TEST(RtuFramer, HeldFragmentIsReleasedAfterMaxHold) {
  Feed f;
  f.bytes({0x01, 0x03, 0x00}, 0);
  f.silence(10 * kNsPerMs);
  EXPECT_TRUE(f.out.empty()) << "incomplete frame should wait for its rest";
  f.silence(200 * kNsPerMs);
  ASSERT_EQ(f.out.size(), 1u);
  EXPECT_EQ(f.out[0].kind, FrameKind::noise);  // 3 bytes: too short for a frame
}

TEST(RtuFramer, BadCrcFrameBetweenGoodOnesInABurst) {
  Feed f;
  std::vector<std::uint8_t> bad = kRequest;
  bad.back() ^= 0x5A;
  std::vector<std::uint8_t> burst = bad;
  burst.insert(burst.end(), kReply.begin(), kReply.end());
  f.bytes(burst, 0, true);
  f.finish();
  ASSERT_EQ(f.out.size(), 2u);
  EXPECT_EQ(f.bytes_of(0), bad);
  EXPECT_EQ(f.out[0].kind, FrameKind::telegram);
  EXPECT_EQ(f.bytes_of(1), kReply);
}

TEST(RtuFramer, BadCrcRequestAndReplySeparatedByShortSilence) {
  Feed f;
  std::vector<std::uint8_t> bad_req = kRequest, bad_rsp = kReply;
  bad_req.back() ^= 1;
  bad_rsp.back() ^= 1;
  f.bytes(bad_req, 0);
  f.silence(2 * kChar);  // > t1.5 but < t3.5
  f.bytes(bad_rsp);
  f.finish();
  ASSERT_EQ(f.out.size(), 2u);
  EXPECT_EQ(f.bytes_of(0), bad_req);
  EXPECT_EQ(f.bytes_of(1), bad_rsp);
}

TEST(RtuFramer, UnknownFunctionCodeFramedBySilenceAndByCrcInBursts) {
  const auto vendor = with_crc({0x05, 0x41, 0x10, 0x20, 0x30});
  Feed f;
  f.bytes(vendor, 0);
  f.silence(10 * kNsPerMs);
  std::vector<std::uint8_t> burst = vendor;
  burst.insert(burst.end(), kRequest.begin(), kRequest.end());
  f.bytes(burst, -1, true);
  f.finish();
  ASSERT_EQ(f.out.size(), 3u);
  EXPECT_EQ(f.bytes_of(0), vendor);
  EXPECT_EQ(f.bytes_of(1), vendor);
  EXPECT_EQ(f.bytes_of(2), kRequest);
}

TEST(RtuFramer, ByteSwappedCrcStillFrames) {
  auto swapped = kRequest;
  std::swap(swapped[6], swapped[7]);
  Feed f;
  std::vector<std::uint8_t> burst = swapped;
  burst.insert(burst.end(), kReply.begin(), kReply.end());
  f.bytes(burst, 0, true);
  f.finish();
  ASSERT_EQ(f.out.size(), 2u);
  EXPECT_EQ(f.bytes_of(0), swapped);
}

TEST(RtuFramer, GarbageChunkWithUartErrorsIsNoise) {
  Feed f;
  f.bytes({0x00, 0x00, 0x00, 0x00, 0x00}, 0, false, kUartFramingError);
  f.finish();
  ASSERT_EQ(f.out.size(), 1u);
  EXPECT_EQ(f.out[0].kind, FrameKind::noise);
}

TEST(RtuFramer, ContinuousStreamWithoutSilenceStaysBounded) {
  // 100 000 frames back to back with no silence: segmented under pressure, nothing lost.
  const std::size_t frames = 100'000;
  Feed g;
  std::size_t seen = 0, bytes = 0;
  for (int i = 0; i < 50'000; ++i) {
    g.bytes(kRequest);
    g.bytes(kReply);
    for (const Frame& fr : g.out) {
      ++seen;
      bytes += fr.size();
      EXPECT_EQ(fr.kind, FrameKind::telegram);
    }
    g.out.clear();
  }
  g.finish();
  for (const Frame& fr : g.out) {
    ++seen;
    bytes += fr.size();
  }
  EXPECT_EQ(seen, frames);
  EXPECT_EQ(bytes, 50'000u * (kRequest.size() + kReply.size()));
}

TEST(RtuFramer, EveryByteAccountedForUnderRandomNoise) {
  // Property: frames + noise cover the input exactly once, in order, and every good frame
  // surrounded by silence comes out intact whatever noise sits between them.
  std::mt19937 rng(12345);
  Feed f;
  std::vector<std::uint8_t> all;
  std::size_t good_frames = 0;
  for (int i = 0; i < 2000; ++i) {
    if (rng() % 3 == 0) {
      std::vector<std::uint8_t> junk(1 + rng() % 6);
      for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
      f.bytes(junk);
      all.insert(all.end(), junk.begin(), junk.end());
      f.silence(5 * kNsPerMs);
    }
    const auto& frame = (i % 2) ? kReply : kRequest;
    f.bytes(frame);
    all.insert(all.end(), frame.begin(), frame.end());
    ++good_frames;
    f.silence(5 * kNsPerMs);
  }
  f.finish();
  std::vector<std::uint8_t> seen;
  std::size_t intact = 0;
  for (const Frame& fr : f.out) {
    auto b = fr.bytes();
    seen.insert(seen.end(), b.begin(), b.end());
    intact += fr.kind == FrameKind::telegram && (b == kRequest || b == kReply);
  }
  EXPECT_EQ(seen, all);
  EXPECT_EQ(intact, good_frames);
}

// A pressure close that emits everything the framer holds as one frame, inside push(events): the
// bytes appended in bulk after it start a new run, whose timing must not carry the old one's
// (found in review: the second frame came out with the first one's 1 ms gap).
TEST(RtuFramer, PressureCloseOfOneFrameStartsTheNextTimingAfresh) {
  const FramingTiming timing = FramingTiming::from(k9600);
  const std::vector<std::uint8_t> request = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01});
  ASSERT_EQ(request.size(), 8u);
  std::vector<ByteEvent> events;
  TimeNs clock = 0;
  for (int frame = 0; frame < 2; ++frame)
    for (std::size_t i = 0; i < request.size(); ++i) {
      if (frame == 0 && i == 3) clock += kNsPerMs;  // under t3.5: inside the frame
      events.push_back(ByteEvent{clock, request[i], 0, 0});
      clock += kChar;
    }
  const RtuFramerOptions options{timing, 100 * kNsPerMs, 8};  // pressure at one frame
  RtuFramer one_by_one(0, options), in_one_run(0, options);
  FrameBatch expected, got;
  for (const ByteEvent& e : events) one_by_one.push(e, expected);
  one_by_one.finish(expected);
  in_one_run.push_all(events, got);
  in_one_run.finish(got);
  ASSERT_EQ(got.size(), 2u);
  ASSERT_EQ(expected.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(got[i].bytes(), request);
    EXPECT_EQ(got[i].max_intra_gap, expected[i].max_intra_gap);
    EXPECT_EQ(got[i].max_intra_gap_at, expected[i].max_intra_gap_at);
  }
  EXPECT_GT(got[0].max_intra_gap, 0);
  EXPECT_EQ(got[1].max_intra_gap, 0);
}

TEST(RtuFramer, RunOfARequestAndMoreIsNotTakenWholeForItsLength) {
  // A request whose start address begins 0x0A also reads as the start of a 15-byte reply (byte
  // count 10). Its 8 bytes and 7 more arrive as one evenly spaced run between silences, so the
  // run's length is a predicted one, but its last two bytes are no CRC of it: push(events) must
  // not take it as one frame, and cuts the request off as push() of each byte does.
  const std::vector<std::uint8_t> request = with_crc({0x01, 0x03, 0x0A, 0x00, 0x00, 0x02});
  std::vector<std::uint8_t> run = request;
  for (const std::uint8_t b : {0x01, 0x03, 0x04, 0x00, 0x10, 0x00, 0x20}) run.push_back(b);
  ASSERT_EQ(run.size(), 15u);
  const std::uint16_t crc = crc16_modbus(std::span(run).first(13));
  ASSERT_NE(run[13] | (run[14] << 8), crc);
  ASSERT_NE(run[14] | (run[13] << 8), crc);
  std::vector<ByteEvent> events;
  TimeNs clock = 0;
  append_bytes(events, clock, run, 5 * kNsPerMs);
  append_bytes(events, clock, run, 5 * kNsPerMs);
  append_bytes(events, clock, kRequest);  // a byte after the second run's silence, in the call
  const std::vector<Frame> expected = frames_alike_by_push_and_push_span(events);
  ASSERT_GE(expected.size(), 3u);
  EXPECT_EQ(expected[0].bytes(), request);
}

TEST(RtuFramer, RunLongerThanTheLongestFrameComesOutAsPushMakesIt) {
  // A read reply of byte count 252 would be 257 bytes, one more than an RTU frame can be, so
  // push(events) cannot take such a run whole for its predicted length; with a good CRC between
  // silences it must still come out as push() of each byte makes it (one frame of all 257 bytes,
  // closed by the silence).
  std::vector<std::uint8_t> body = {0x01, 0x03, 252};
  for (int k = 0; k < 252; ++k) body.push_back(static_cast<std::uint8_t>(k * 7));
  const std::vector<std::uint8_t> run = with_crc(body);
  ASSERT_EQ(run.size(), 257u);
  std::vector<ByteEvent> events;
  TimeNs clock = 0;
  append_bytes(events, clock, run, 5 * kNsPerMs);
  append_bytes(events, clock, kRequest);
  const std::vector<Frame> expected = frames_alike_by_push_and_push_span(events);
  ASSERT_FALSE(expected.empty());
  EXPECT_EQ(expected[0].size(), 257u);
}

TEST(RtuFramer, PushAllGivesTheFramesOfPushingOneByOne) {
  // Framer::push(events) appends runs without silence in bulk; it must cut exactly where push()
  // does: silences of every length, one-stamp bursts, noise, UART marks, and the pressure mark
  // (set low so that runs meet it).
  std::mt19937 rng(2026);
  const FramingTiming timing = FramingTiming::from(k9600);
  const TimeNs gaps[] = {
      0, kChar / 2, timing.t15 + 1, timing.t35 - 1, timing.t35 + 1, 5 * kNsPerMs, 200 * kNsPerMs};
  std::vector<ByteEvent> events;
  TimeNs clock = 0;
  for (int i = 0; i < 3000; ++i) {
    std::vector<std::uint8_t> bytes = (i % 2) ? kReply : kRequest;
    if (rng() % 5 == 0) bytes.resize(1 + rng() % bytes.size());  // cut short
    if (rng() % 4 == 0)
      for (std::size_t k = 0; k < 1 + rng() % 4; ++k)
        bytes.push_back(static_cast<std::uint8_t>(rng()));
    const bool one_stamp = rng() % 6 == 0;
    const std::uint8_t flags = rng() % 20 == 0 ? kUartParityError : 0;
    const TimeNs first = clock;
    for (std::uint8_t b : bytes) {
      events.push_back(ByteEvent{one_stamp ? first : clock, b, flags, 0});
      clock += kChar + (rng() % 10 == 0 ? gaps[rng() % 4] : 0);
    }
    clock += gaps[rng() % std::size(gaps)];
    if (i % 500 == 499) {
      // A long run with no silence at all, past the pressure mark and the longest frame.
      for (int k = 0; k < 600; ++k) {
        events.push_back(ByteEvent{clock, static_cast<std::uint8_t>(rng()), 0, 0});
        clock += kChar;
      }
    }
  }
  const RtuFramerOptions options{timing, 100 * kNsPerMs, 64};
  RtuFramer one_by_one(0, options), in_runs(0, options);
  FrameBatch expected, got;
  std::vector<std::size_t> frames_after(events.size());  // of pushing each byte alone, up to it
  for (std::size_t j = 0; j < events.size(); ++j) {
    one_by_one.push(events[j], expected);
    frames_after[j] = expected.size();
  }
  one_by_one.finish(expected);
  // push(events) stops where frames closed, and only there: right after the byte that closed
  // them, or right before the one whose silence closed them.
  for (std::size_t i = 0; i < events.size();) {
    SCOPED_TRACE(i);
    const std::size_t run = std::min<std::size_t>(1 + rng() % 300, events.size() - i);
    const std::size_t frames_before = got.size();
    const std::size_t taken = in_runs.push(std::span(events).subspan(i, run), got);
    ASSERT_GE(taken, 1u);
    ASSERT_LE(taken, run);
    const std::size_t last = i + taken - 1;
    const bool closed_by_last = got.size() == frames_after[last];
    const bool closed_before_next =
        taken < run && frames_after[last] == frames_before && got.size() == frames_after[last + 1];
    ASSERT_TRUE(closed_by_last || closed_before_next);
    if (taken < run) {
      EXPECT_NE(got.size(), frames_before);
    }
    if (taken > 1) {
      EXPECT_EQ(frames_after[last - 1], frames_before);
    }
    i += taken;
  }
  in_runs.finish(got);
  ASSERT_EQ(got.size(), expected.size());
  std::size_t telegrams = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(got[i].events, expected[i].events);  // times, flags, channel and source unit too
    EXPECT_EQ(got[i].kind, expected[i].kind);
    EXPECT_EQ(got[i].close, expected[i].close);
    EXPECT_EQ(got[i].gap_before, expected[i].gap_before);
    EXPECT_EQ(got[i].max_intra_gap, expected[i].max_intra_gap);
    EXPECT_EQ(got[i].max_intra_gap_at, expected[i].max_intra_gap_at);
    telegrams += got[i].kind == FrameKind::telegram;
  }
  // The framer keeps the timing of what it holds as bytes arrive (and takes it for a frame of all
  // of them): it must be what the frames' own events say, one-stamp bursts and overlaps included.
  TimeNs previous_end = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    SCOPED_TRACE(i);
    const ByteEvents& ev = got[i].events;
    TimeNs end = ev.front().time + timing.character_time, max_gap = 0;
    std::uint32_t max_gap_at = 0;
    for (std::size_t k = 1; k < ev.size(); ++k) {
      if (ev[k].time - end > max_gap) {
        max_gap = ev[k].time - end;
        max_gap_at = static_cast<std::uint32_t>(k);
      }
      end = std::max(end, ev[k].time + timing.character_time);
    }
    EXPECT_EQ(got[i].max_intra_gap, max_gap);
    EXPECT_EQ(got[i].max_intra_gap_at, max_gap_at);
    EXPECT_EQ(got[i].gap_before, i == 0 ? -1 : std::max<TimeNs>(0, ev.front().time - previous_end));
    previous_end = i == 0 ? end : std::max(previous_end, end);
  }
  // The stream exercises every path: telegrams, noise, and closes by silence and by content.
  EXPECT_GT(telegrams, 1000u);
  EXPECT_LT(telegrams, got.size());
}

// A frame push(events) takes whole between two silences carries the CRC-16 the framer computed over
// exactly its bytes (also when the frame's own is byte-swapped); frames cut another way carry
// none. The dissector's verdicts are the same either way.
TEST(RtuFramer, AFrameTakenWholeCarriesTheCrcComputedOverIt) {
  auto swapped = kReply;
  std::swap(swapped[swapped.size() - 2], swapped[swapped.size() - 1]);
  std::vector<ByteEvent> events;
  TimeNs clock = 0;
  append_bytes(events, clock, kRequest, 5 * kNsPerMs);
  append_bytes(events, clock, swapped, 5 * kNsPerMs);
  append_bytes(events, clock, kRequest);  // a byte after the silence shows it, in the same call
  RtuFramer framer(0, RtuFramerOptions{FramingTiming::from(k9600)});
  FrameBatch frames;
  framer.push_all(events, frames);
  framer.finish(frames);
  ASSERT_EQ(frames.size(), 3u);
  for (std::size_t i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    const std::vector<std::uint8_t> bytes = frames[i].bytes();
    EXPECT_EQ(frames[i].checksum_kind, FrameChecksum::crc16_modbus);
    EXPECT_EQ(frames[i].checksum, crc16_modbus(std::span(bytes).first(bytes.size() - 2)));
  }
  EXPECT_EQ(frames[2].checksum_kind, FrameChecksum::none);  // closed by the end of the input
  // Dissected with the framer's CRC and without it: the same verdicts, good and swapped.
  const FramingTiming timing = FramingTiming::from(k9600);
  for (std::size_t i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    Frame without = frames[i];
    without.checksum_kind = FrameChecksum::none;
    const Message carried =
        dissected(modbus::dissect_rtu, Frame(frames[i]), Direction::unknown, timing);
    const Message computed =
        dissected(modbus::dissect_rtu, std::move(without), Direction::unknown, timing);
    EXPECT_EQ(carried.checksum.verdict, i == 0 ? ChecksumVerdict::good : ChecksumVerdict::swapped);
    EXPECT_EQ(carried.checksum.verdict, computed.checksum.verdict);
    EXPECT_EQ(carried.checksum.stated_wire, computed.checksum.stated_wire);
    EXPECT_EQ(carried.checksum.computed_wire, computed.checksum.computed_wire);
  }
}

// The dissector takes the CRC the framer carried rather than computing it a second time (a
// carried value that is not the frame's reads as a bad CRC), and only a CRC-16 of Modbus RTU.
TEST(RtuFramer, TheDissectorReadsTheCarriedCrc) {
  Frame f;
  for (const std::uint8_t b : kRequest) f.events.push_back({0, b, 0, 0, 0});
  const std::uint16_t crc = crc16_modbus(std::span(kRequest).first(kRequest.size() - 2));
  const FramingTiming timing = FramingTiming::from(k9600);
  f.checksum_kind = FrameChecksum::crc16_modbus;
  f.checksum = crc ^ 0x0101u;
  EXPECT_EQ(dissected(modbus::dissect_rtu, Frame(f), Direction::request, timing).checksum.verdict,
            ChecksumVerdict::bad);
  f.checksum_kind = FrameChecksum::none;  // no CRC carried: the dissector computes it
  EXPECT_EQ(dissected(modbus::dissect_rtu, Frame(f), Direction::request, timing).checksum.verdict,
            ChecksumVerdict::good);
}

// take_whole() is push() of the run and of the byte after the silence, without the frame: on a
// stream of whole frames, cut ones, noise, one-stamp bursts, short and long silences, a framer
// taking runs whole where it can must emit, with the frames add_whole_frame() makes of what it
// took, exactly the frames of one pushing every run, timing included, and carry the right CRC.
TEST(RtuFramer, TakeWholeIsPushWithoutTheFrame) {
  std::mt19937 rng(77);
  const FramingTiming timing = FramingTiming::from(k9600);
  const TimeNs gaps[] = {0, timing.t15 + 1, timing.t35 - 1, timing.t35 + 1, 10 * kNsPerMs};
  auto swapped = kReply;
  std::swap(swapped[swapped.size() - 2], swapped[swapped.size() - 1]);
  struct Run {
    std::vector<std::uint8_t> bytes;
    TimeNs first, step;
  };
  std::vector<Run> runs;
  TimeNs clock = 0;
  for (int i = 0; i < 4000; ++i) {
    std::vector<std::uint8_t> bytes = i % 7 == 3 ? swapped : (i % 2) ? kReply : kRequest;
    // (A cut frame is held up to max_hold for the rest: no run is taken whole meanwhile.)
    if (rng() % 40 == 0) bytes.resize(1 + rng() % bytes.size());
    if (rng() % 20 == 0) bytes.push_back(static_cast<std::uint8_t>(rng()));
    const TimeNs step = rng() % 20 == 0 ? 0 : kChar + (rng() % 10 == 0 ? gaps[rng() % 3] : 0);
    runs.push_back({bytes, clock, step});
    // Mostly a silence that ends a frame; now and then one that may not.
    clock += static_cast<TimeNs>(bytes.size()) * std::max(step, kChar) +
             (rng() % 2 == 0 ? 10 * kNsPerMs : gaps[rng() % 5]);
  }
  const RtuFramerOptions options{timing, 100 * kNsPerMs, 4096};
  RtuFramer pushing(0, options), taking(0, options);
  FrameBatch pushed, taken_frames;
  std::size_t taken = 0;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    SCOPED_TRACE(k);
    const ByteRun run{runs[k].bytes, runs[k].first, runs[k].step, 0, 0, {}};
    const TimeNs next = k + 1 < runs.size() ? runs[k + 1].first : clock + kNsPerSecond;
    pushing.advance(run.first, pushed);
    taking.advance(run.first, taken_frames);
    pushing.push_all(run, pushed);
    Framer::WholeFrame whole;
    if (taking.take_whole(run, next, &whole)) {
      ++taken;
      add_whole_frame(taken_frames, 0, run, whole);
      continue;
    }
    taking.push_all(run, taken_frames);
  }
  // (The last run was taken as if a byte came a second later: that silence closes it.)
  pushing.advance(clock + kNsPerSecond, pushed);
  taking.advance(clock + kNsPerSecond, taken_frames);
  pushing.finish(pushed);
  taking.finish(taken_frames);
  EXPECT_GT(taken, 1000u);
  ASSERT_EQ(pushed.size(), taken_frames.size());
  for (std::size_t i = 0; i < pushed.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(pushed[i].events, taken_frames[i].events);
    EXPECT_EQ(pushed[i].kind, taken_frames[i].kind);
    EXPECT_EQ(pushed[i].close, taken_frames[i].close);
    EXPECT_EQ(pushed[i].gap_before, taken_frames[i].gap_before);
    EXPECT_EQ(pushed[i].max_intra_gap, taken_frames[i].max_intra_gap);
    EXPECT_EQ(pushed[i].max_intra_gap_at, taken_frames[i].max_intra_gap_at);
    // A frame taken whole carries the CRC the framer computed over it (pushed byte by byte it
    // may carry none); where both carry one it is the same.
    const Frame& t = taken_frames[i];
    if (t.checksum_kind == FrameChecksum::crc16_modbus) {
      const std::span<const std::uint8_t> bytes = t.events.bytes();
      ASSERT_GE(bytes.size(), 2u);
      EXPECT_EQ(t.checksum, crc16_modbus(bytes.first(bytes.size() - 2)));
    }
    if (pushed[i].checksum_kind != FrameChecksum::none && t.checksum_kind != FrameChecksum::none) {
      EXPECT_EQ(pushed[i].checksum_kind, t.checksum_kind);
      EXPECT_EQ(pushed[i].checksum, t.checksum);
    }
  }
}

// The precheck the read-ahead thread makes (RtuDecoder::precheck, TelegramPrecheck) must be what
// the framer's check of a run taken whole and the dissection to its head find, on well-formed
// telegrams of every function code each way, exceptions, cut and padded ones, swapped CRCs and
// noise.
TEST(RtuDecoder, PrecheckIsWhatTheFramerAndTheSummaryFind) {
  std::mt19937 rng(2026);
  const RtuDecoder decoder;
  const FramingTiming timing = FramingTiming::from(k9600);
  std::size_t whole = 0;
  for (int i = 0; i < 20000; ++i) {
    std::vector<std::uint8_t> pdu{
        static_cast<std::uint8_t>(rng() % 4 == 0 ? rng() : 1 + rng() % 16)};
    const std::size_t length = rng() % 3 == 0 ? rng() % 12 : 4 + rng() % 2 * (1 + rng() % 9);
    for (std::size_t k = 0; k < length; ++k)
      pdu.push_back(static_cast<std::uint8_t>(rng() % 5 == 0 ? rng() % 8 : rng()));
    if (pdu.size() >= 5 && rng() % 2 == 0)
      pdu[4] = static_cast<std::uint8_t>(pdu.size() - 5);  // a byte count that fits
    std::vector<std::uint8_t> frame{static_cast<std::uint8_t>(1 + rng() % 247)};
    frame.insert(frame.end(), pdu.begin(), pdu.end());
    frame = with_crc(frame);
    if (rng() % 10 == 0) std::swap(frame[frame.size() - 2], frame[frame.size() - 1]);
    if (rng() % 10 == 0) frame[rng() % frame.size()] ^= 0x10;
    if (rng() % 20 == 0) frame.resize(rng() % frame.size());
    SCOPED_TRACE(::testing::PrintToString(frame));
    TelegramPrecheck made;
    ASSERT_TRUE(decoder.precheck(frame, &made));
    std::uint32_t checksum = 0;
    const bool good = is_good_hybrid_frame(RtuFramer::rules(), frame, &checksum);
    ASSERT_EQ(made.whole_frame, good);
    if (!good) continue;
    ++whole;
    EXPECT_EQ(made.checksum, checksum);
    EXPECT_EQ(made.fit.request, decoder.direction_fit(frame).request);
    EXPECT_EQ(made.fit.response, decoder.direction_fit(frame).response);
    EXPECT_EQ(made.always_response, decoder.always_response(frame));
    // The head with the precheck is the head without it, each way.
    TelegramView t;
    t.run = ByteRun{frame, 0, kChar, 0, 0, {}};
    t.taken.checksum_kind = FrameChecksum::crc16_modbus;
    t.taken.checksum = checksum;
    for (const Direction way : {Direction::request, Direction::response}) {
      made.decoder = &decoder;
      TelegramFindings with, without;
      Message unused;
      t.precheck = &made;
      ASSERT_FALSE(decoder.dissect(t, way, timing, {}, DissectDepth::head, unused, &with));
      t.precheck = nullptr;
      ASSERT_FALSE(decoder.dissect(t, way, timing, {}, DissectDepth::head, unused, &without));
      EXPECT_EQ(with.exception_code, without.exception_code);
      EXPECT_EQ(with.malformed, without.malformed);
      EXPECT_EQ(with.verdict, without.verdict);
      EXPECT_EQ(with.other_kinds, without.other_kinds);
    }
  }
  EXPECT_GT(whole, 3000u);
}

// A USB adapter delivers a frame in two reads, 16 ms apart (> t3.5): every split position of a
// request and a reply of every function code the length rules know, with a frame before and one
// after, gives the frame whole. The silence proposes a cut there; content (the whole stretch's
// CRC) decides. The hard positions are those where the other direction's layout would end
// (after 8 bytes of a 0F/10 request, after 5 + byte 2 of an 01-04 request, inside a long reply).
TEST(RtuFramer, EverySplitPositionOfEveryFunctionCodeGivesTheFrameWhole) {
  const auto hex_of = [](const std::vector<std::uint8_t>& bytes) {
    std::string s;
    for (const std::uint8_t b : bytes) s += fmt::format("{:02X} ", b);
    return s;
  };
  const std::vector<std::vector<std::uint8_t>> frames = {
      with_crc({0x11, 0x01, 0x00, 0x13, 0x00, 0x25}),                    // 01 request
      with_crc({0x11, 0x01, 0x05, 0xCD, 0x6B, 0xB2, 0x0E, 0x1B}),        // 01 reply
      with_crc({0x11, 0x02, 0x00, 0xC4, 0x00, 0x16}),                    // 02 request
      with_crc({0x11, 0x02, 0x03, 0xAC, 0xDB, 0x35}),                    // 02 reply
      with_crc({0x11, 0x03, 0x00, 0x6B, 0x00, 0x03}),                    // 03 request
      with_crc({0x11, 0x03, 0x06, 0xAE, 0x41, 0x56, 0x52, 0x43, 0x40}),  // 03 reply
      with_crc({0x11, 0x03, 0x02, 0x00, 0x07}),                          // 03 reply, 1 register
      with_crc({0x01, 0x03, 0x01, 0x00, 0x00, 0x02}),                    // 03 request, byte 2 = 1
      with_crc({0x01, 0x04, 0x03, 0x00, 0x00, 0x08}),                    // 04 request, byte 2 = 3
      with_crc({0x01, 0x04, 0x10, 0x00, 0x01, 0x00, 0x02, 0x00, 0x03, 0x00, 0x04, 0x00, 0x05, 0x00,
                0x06, 0x00, 0x07, 0x00, 0x08}),  // 04 reply, 8 registers
      with_crc({0x11, 0x05, 0x00, 0xAC, 0xFF, 0x00}),                    // 05 request = reply
      with_crc({0x11, 0x06, 0x00, 0x01, 0x00, 0x03}),                    // 06 request = reply
      with_crc({0x11, 0x08, 0x00, 0x00, 0xA5, 0x37}),                    // 08 echo
      with_crc({0x11, 0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01}),  // 0F request
      with_crc({0x11, 0x0F, 0x00, 0x13, 0x00, 0x0A}),                    // 0F reply
      with_crc({0x11, 0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02}),  // 10 request
      with_crc({0x11, 0x10, 0x00, 0x01, 0x00, 0x02}),                                // 10 reply
      with_crc({0x11, 0x17, 0x00, 0x03, 0x00, 0x06, 0x00, 0x0E, 0x00, 0x03, 0x06, 0x00, 0xFF, 0x00,
                0xFF, 0x00, 0xFF}),                                        // 17 request
      with_crc({0x11, 0x17, 0x0C, 0x00, 0xFE, 0x0A, 0xCD, 0x00, 0x01, 0x00, 0x03, 0x00, 0x0D, 0x00,
                0xFF}),                                                    // 17 reply
      with_crc({0x11, 0x83, 0x02}),                                        // exception
  };
  const std::vector<std::uint8_t> before = with_crc({0x05, 0x06, 0x00, 0x10, 0x12, 0x34});
  const std::vector<std::uint8_t> after = with_crc({0x05, 0x03, 0x00, 0x10, 0x00, 0x01});
  int cases = 0;
  for (const auto& frame : frames) {
    for (std::size_t k = 1; k < frame.size(); ++k) {
      SCOPED_TRACE(::testing::Message() << "frame " << hex_of(frame) << " split after " << k);
      Feed f;
      f.bytes(before, 0);
      f.silence(30 * kNsPerMs);
      f.bytes({frame.begin(), frame.begin() + static_cast<std::ptrdiff_t>(k)});
      f.silence(16 * kNsPerMs);
      f.bytes({frame.begin() + static_cast<std::ptrdiff_t>(k), frame.end()});
      f.silence(30 * kNsPerMs);
      f.bytes(after);
      f.silence(30 * kNsPerMs);
      f.finish();
      ++cases;
      EXPECT_EQ(f.out.size(), 3u);
      if (f.out.size() != 3u) continue;
      EXPECT_EQ(f.bytes_of(0), before);
      EXPECT_EQ(f.bytes_of(1), frame);
      EXPECT_EQ(f.out[1].kind, FrameKind::telegram);
      EXPECT_EQ(f.bytes_of(2), after);
    }
  }
  EXPECT_GT(cases, 180);
}
