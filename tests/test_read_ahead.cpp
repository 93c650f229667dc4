// Unit tests: ReadAhead — a source's batches read on a thread of their own come out whole, in
// order, and the reader stops when asked or when the source ends or fails.
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "sources/read_ahead.hpp"

#include "core/byte_events.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"

using namespace drivetap;

namespace {

// Gives `total` bytes in batches of 1..`longest` (37), interning a new channel every 1000 bytes (as
// a capture reader meets new interfaces), then ends, with an error when told to.
class CountingSource final : public ByteSource {
 public:
  CountingSource(ChannelTable& channels, std::size_t total, bool fail, std::size_t longest = 37,
                 std::chrono::microseconds pause = {})
      : channels_(channels), total_(total), fail_(fail), longest_(longest), pause_(pause) {}
  bool read_header() override { return true; }
  [[nodiscard]] RunSettings settings() const override { return {}; }
  void set_character_time(TimeNs) override {}
  bool next(ByteEvent& out) override {
    if (given_ == total_) {
      if (fail_) error_ = "test: offset 123: damaged";
      return false;
    }
    if (given_ % 1000 == 0) channel_ = channels_.intern("ch" + std::to_string(given_ / 1000 % 300));
    out = {static_cast<TimeNs>(given_) * 1000, static_cast<std::uint8_t>(given_), 0, channel_,
           static_cast<std::uint32_t>(given_)};
    ++given_;
    return true;
  }
  bool next_batch(std::vector<ByteEvent>& out) override {
    out.clear();
    if (pause_.count() > 0) std::this_thread::sleep_for(pause_);  // a slow read
    const std::size_t want = 1 + batches_++ % longest_;
    ByteEvent e;
    while (out.size() < want && next(e)) out.push_back(e);
    return !out.empty();
  }
  [[nodiscard]] const std::string& error() const override { return error_; }

 private:
  ChannelTable& channels_;
  std::size_t total_, given_ = 0, batches_ = 0;
  bool fail_;
  std::size_t longest_;
  std::chrono::microseconds pause_;
  ChannelId channel_ = 0;
  std::string error_;
};

}  // namespace

TEST(ReadAhead, ChunksHoldEveryByteInOrder) {
  for (const bool fail : {false, true}) {
    ChannelTable channels;
    CountingSource source(channels, 200'000, fail);
    std::size_t next = 0;
    {
      ReadAhead ahead(source);
      RunBatch chunk;
      while (ahead.next_chunk(chunk)) {
        ASSERT_FALSE(chunk.empty());
        for (std::size_t k = 0; k < chunk.size(); ++k) {
          for (std::size_t i = 0; i < chunk[k].size(); ++i) {
            const ByteEvent e = chunk[k].event(i);
            ASSERT_EQ(e.origin, next);
            ASSERT_EQ(e.time, static_cast<TimeNs>(next) * 1000);
            ASSERT_EQ(e.byte, static_cast<std::uint8_t>(next));
            // The channel the reader interned is there for this thread to look up.
            ASSERT_EQ(channels.at(e.channel).name, "ch" + std::to_string(next / 1000 % 300));
            ++next;
          }
        }
      }
    }
    EXPECT_EQ(next, 200'000u);
    EXPECT_EQ(source.error(), fail ? "test: offset 123: damaged" : "");
    EXPECT_EQ(channels.size(), 200u);
  }
}

TEST(ReadAhead, StopsWhenTheCallerTakesNoMore) {
  ChannelTable channels;
  CountingSource source(channels, 10'000'000, false);
  {
    ReadAhead ahead(source);
    RunBatch chunk;
    ASSERT_TRUE(ahead.next_chunk(chunk));
    EXPECT_EQ(chunk[0].origin, 0u);
  }  // the destructor stops the reader a few chunks ahead, not at the end of the source
  ByteEvent e;
  ASSERT_TRUE(source.next(e));
  EXPECT_LT(e.origin, (ReadAhead::kDepth + 2) * ReadAhead::kChunkBytes);
}

TEST(ReadAhead, WakesTheReaderAgainOnceTheQueueRunsLow) {
  // The reader fills every place of the queue while the caller is away, and waits; the caller
  // must wake it as it drains the queue, or it would wait for ever for the rest of the source.
  ChannelTable channels;
  const std::size_t total = 3 * ReadAhead::kDepth * ReadAhead::kChunkBytes;
  CountingSource source(channels, total, false);
  ReadAhead ahead(source);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  auto drained = std::async(std::launch::async, [&ahead] {
    std::size_t bytes = 0;
    RunBatch chunk;
    while (ahead.next_chunk(chunk))
      for (std::size_t k = 0; k < chunk.size(); ++k) bytes += chunk[k].size();
    return bytes;
  });
  if (drained.wait_for(std::chrono::seconds(30)) != std::future_status::ready) {
    std::fprintf(stderr, "ReadAhead: no chunk for 30 s with the reader's queue drained\n");
    std::_Exit(1);  // (the caller's thread cannot be stopped; a hang would stall the suite)
  }
  EXPECT_EQ(drained.get(), total);
}

TEST(ReadAhead, AChunkOfOneByteRunsEndsAtKChunkRuns) {
  // Bytes that come one a batch (each with a time of its own, as on a noisy bus) make a run each:
  // a chunk of kChunkBytes of them would hold 16 384 runs of 56 bytes, and the queue eight such.
  ChannelTable channels;
  const std::size_t total = 4 * ReadAhead::kChunkBytes;
  CountingSource source(channels, total, false, 1);
  ReadAhead ahead(source);
  RunBatch chunk;
  std::size_t bytes = 0;
  while (ahead.next_chunk(chunk)) {
    EXPECT_LE(chunk.size(), ReadAhead::kChunkRuns);
    bytes += chunk.byte_count();
  }
  EXPECT_EQ(bytes, total);
}

namespace {

// A decoder whose precheck marks every run it is asked about with the run's size, for the reader's
// prechecks to be recognised (the rest is never called).
class SizeStampingDecoder final : public ProtocolDecoder {
 public:
  [[nodiscard]] Protocol protocol() const override { return protocols::modbus_rtu; }
  [[nodiscard]] std::unique_ptr<Framer> make_framer(ChannelId,
                                                    const FramerSettings&) const override {
    return nullptr;
  }
  [[nodiscard]] DirectionFit direction_fit(std::span<const std::uint8_t>) const override {
    return {};
  }
  [[nodiscard]] bool always_response(std::span<const std::uint8_t>) const override { return false; }
  [[nodiscard]] bool recognisable(std::span<const std::uint8_t>) const override { return false; }
  [[nodiscard]] PairingKeys pairing_keys(std::span<const std::uint8_t>) const override {
    return {};
  }
  bool dissect(TelegramView&, Direction, const FramingTiming&, std::span<const std::uint8_t>,
               DissectDepth, Message&, TelegramFindings*) const override {
    return true;
  }
  bool precheck(std::span<const std::uint8_t> bytes, TelegramPrecheck* out) const override {
    out->whole_frame = true;
    out->checksum = static_cast<std::uint32_t>(bytes.size());
    return true;
  }
};

}  // namespace

// Runs of a channel the caller named a decoder for (precheck_with) come with that decoder's
// precheck once the reader has seen the name; other channels' runs, and every run read once the
// name is withdrawn, come without. Channel "ch1" (id 1) has bytes 1000-1999, 301 000-301 999 and
// 601 000-601 999; the reader is at most ReadAhead::kDepth chunks (some 150 KB here) ahead.
TEST(ReadAhead, RunsOfANamedChannelCarryTheDecodersPrecheck) {
  ChannelTable channels;
  CountingSource source(channels, 700'000, false);
  const SizeStampingDecoder decoder;
  std::size_t prechecked_bytes = 0;
  bool withdrawn = false;
  {
    ReadAhead ahead(source, 0);        // every chunk prechecked
    ahead.precheck_with(1, &decoder);  // long before the reader reaches byte 301 000
    ahead.precheck_with(ReadAhead::kPrecheckChannels, &decoder);  // out of range: ignored
    RunBatch chunk;
    while (ahead.next_chunk(chunk)) {
      for (std::size_t k = 0; k < chunk.size(); ++k) {
        const ByteRun run = chunk[k];
        const TelegramPrecheck* made = chunk.precheck(k);
        const std::uint32_t first = run.origin;
        if (run.channel == 1 && first >= 301'000 && first < 302'000) {
          ASSERT_NE(made, nullptr) << first;
        }
        // Withdrawn past the second stretch (the reader is some 150 KB ahead: far from 601 000).
        if (!withdrawn && first >= 302'000) {
          ahead.precheck_with(1, nullptr);
          withdrawn = true;
        }
        if (!made) continue;
        ASSERT_EQ(run.channel, 1u);
        ASSERT_LT(first, 600'000u) << "read after the name was withdrawn";
        ASSERT_EQ(made->decoder, &decoder);
        ASSERT_EQ(made->checksum, run.size());
        prechecked_bytes += run.size();
      }
    }
  }
  EXPECT_TRUE(withdrawn);
  EXPECT_GE(prechecked_bytes, 1000u);
}

namespace {

// Gives `batches` batches of ReadAhead::kChunkBytes bytes on one channel, each batch a chunk of
// its own; before each batch it calls `before_batch(index)` on the reader's thread, which lets a
// test hold the reader at a chunk of its choosing.
class GatedSource final : public ByteSource {
 public:
  GatedSource(ChannelTable& channels, std::size_t batches,
              std::function<void(std::size_t)> before_batch)
      : channel_(channels.intern("ch0")),
        batches_(batches),
        before_batch_(std::move(before_batch)) {}
  bool read_header() override { return true; }
  [[nodiscard]] RunSettings settings() const override { return {}; }
  void set_character_time(TimeNs) override {}
  bool next(ByteEvent&) override { return false; }
  bool next_batch(std::vector<ByteEvent>& out) override {
    out.clear();
    if (given_ == batches_) return false;
    before_batch_(given_);
    for (std::size_t i = 0; i < ReadAhead::kChunkBytes; ++i, ++origin_)
      out.push_back({static_cast<TimeNs>(origin_) * 1000, static_cast<std::uint8_t>(origin_), 0,
                     channel_, static_cast<std::uint32_t>(origin_)});
    ++given_;
    return true;
  }
  [[nodiscard]] const std::string& error() const override { return error_; }

 private:
  ChannelId channel_;
  std::size_t batches_, given_ = 0;
  std::uint32_t origin_ = 0;
  std::function<void(std::size_t)> before_batch_;
  std::string error_;
};

}  // namespace

// By default a chunk is prechecked only while the caller has ReadAhead::kPrecheckAhead chunks
// queued: a reader slower than its caller leaves the prechecks to the caller; one that is ahead
// makes them. The source holds the reader where the test wants it, so that the queue's length
// at each chunk, and with it the answer, is the same in every run.
TEST(ReadAhead, PrechecksOnlyWhileAhead) {
  const SizeStampingDecoder decoder;
  constexpr std::size_t kChunks = ReadAhead::kPrecheckAhead + 2;
  static_assert(kChunks < ReadAhead::kDepth, "the reader must not wait for room");
  for (const bool reader_ahead : {false, true}) {
    SCOPED_TRACE(reader_ahead);
    std::mutex mutex;
    std::condition_variable changed;
    std::size_t taken = 0;      // chunks the caller has taken
    bool reached_last = false;  // the reader has come to the last chunk
    auto before_batch = [&](std::size_t index) {
      std::unique_lock lock(mutex);
      if (reader_ahead) {
        // The caller takes nothing before the reader starts its last chunk: chunk k (from 0)
        // starts with k queued.
        if (index + 1 == kChunks) reached_last = true;
        changed.notify_all();
      } else {
        // Each chunk starts once the caller took the one before: at most one queued.
        changed.wait(lock, [&] { return taken >= index; });
      }
    };
    ChannelTable channels;
    GatedSource source(channels, kChunks, before_batch);
    std::vector<bool> prechecked;  // per chunk: its runs carry prechecks
    {
      ReadAhead ahead(source);
      ahead.precheck_with(0, &decoder);
      if (reader_ahead) {
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return reached_last; });
      }
      RunBatch chunk;
      while (ahead.next_chunk(chunk)) {
        ASSERT_GT(chunk.size(), 0u);
        std::size_t with = 0;
        for (std::size_t k = 0; k < chunk.size(); ++k) with += chunk.precheck(k) ? 1 : 0;
        ASSERT_TRUE(with == 0 || with == chunk.size()) << "chunk " << prechecked.size();
        prechecked.push_back(with > 0);
        const std::lock_guard lock(mutex);
        ++taken;
        changed.notify_all();
      }
    }
    ASSERT_EQ(prechecked.size(), kChunks);
    for (std::size_t k = 0; k < kChunks; ++k)
      EXPECT_EQ(prechecked[k], reader_ahead && k >= ReadAhead::kPrecheckAhead) << "chunk " << k;
  }
}
