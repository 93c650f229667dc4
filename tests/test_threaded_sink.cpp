// Unit tests: ThreadedSink — the inner sink gets every record, whole and in order, on the writer
// thread; flush() and finish() wait for it; its needs() are the inner sink's.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>

#include "dissectors/modbus/modbus_protocol.hpp"
#include "sinks/json_sink.hpp"
#include "sinks/text_sink.hpp"
#include "sinks/threaded_sink.hpp"

using namespace drivetap;

namespace {

// Writes each record as one line, and notes the thread it was called on.
class RecordingSink final : public Sink {
 public:
  explicit RecordingSink(bool detail = true) : detail_(detail) {}
  void on_frame(const Message& m) override {
    std::string bytes;
    for (const ByteEvent& e : m.frame.events) bytes += std::to_string(e.byte) + ",";
    std::string fields;
    for (const FieldNode& f : m.fields)
      fields += std::string(m.fields.text(f)) + "=" + std::to_string(f.value) + ",";
    std::string raw;
    for (const std::uint8_t b : m.bytes) raw += std::to_string(b) + ",";
    for (const FieldNode& f : m.fields)
      fields += std::to_string(f.depth) + "/" + std::to_string(f.offset) + "/" +
                std::to_string(f.length) + std::string(f.desc ? f.desc->id : "-") + ",";
    note("frame " + std::to_string(m.frame.number) + " " + bytes + " " + raw + " " + fields + " " +
         m.info + " " + m.drive_info + " " + std::to_string(m.anomalies.size()) + " " +
         std::to_string(static_cast<int>(m.direction)) + " " +
         std::to_string(static_cast<int>(m.checksum.verdict)) + " " +
         std::to_string(m.frame.channel) + " " + std::to_string(m.latency) + " " +
         std::to_string(m.request_number) + " " + std::to_string(m.address));
  }
  void on_noise(const Frame& f) override {
    note("noise " + std::to_string(f.number) + " " + std::to_string(f.events.size()));
  }
  void on_anomaly(const Anomaly& a) override { note("anomaly " + a.detail); }
  void on_transaction(const Transaction& t) override {
    note("transaction " + std::to_string(t.request_number) + " " + t.detail);
  }
  void on_summary(const Stats& s) override { note("summary " + std::to_string(s.frames)); }
  void on_event(const BusEvent& e) override { note("event " + std::string(event_kind_id(e.kind)) + " " + e.detail); }
  bool flush() override {
    ++flushes;
    return true;
  }
  [[nodiscard]] SinkNeeds needs() const override {
    SinkNeeds n;
    n.detail = detail_;
    return n;
  }

  std::vector<std::string> lines;
  std::vector<std::thread::id> threads;
  int flushes = 0;

 private:
  void note(std::string line) {
    lines.push_back(std::move(line));
    threads.push_back(std::this_thread::get_id());
  }
  bool detail_;
};

// A run's worth of records of every kind, the frames' contents varying in size (a record's
// reused storage must not keep anything of the previous one).
void play(Sink& sink, std::size_t frames) {
  Message m;
  for (std::size_t i = 1; i <= frames; ++i) {
    m.frame.number = i;
    m.frame.events.clear();
    for (std::size_t k = 0; k < i % 7; ++k)
      m.frame.events.push_back(
          {static_cast<TimeNs>(k * (i % 3)), static_cast<std::uint8_t>(i + k), 0, 0, 0});
    m.bytes.assign(i % 5, static_cast<std::uint8_t>(i));
    m.fields.clear();
    for (std::size_t k = 0; k < i % 3; ++k) {
      FieldNode& f = m.fields.emplace_back();
      f.value = static_cast<std::int64_t>(i);
      m.fields.set_text(f, std::string(i % 40, 'x'));
      f.depth = static_cast<std::uint16_t>(i % 2);
      f.offset = static_cast<std::uint32_t>(i % 9);
      f.length = static_cast<std::uint32_t>(i % 4);
    }
    m.direction = i % 3 ? Direction::request : Direction::response;
    m.checksum.verdict = i % 4 ? ChecksumVerdict::good : ChecksumVerdict::bad;
    m.frame.channel = static_cast<ChannelId>(i % 2);
    m.latency = i % 2 ? -1 : static_cast<TimeNs>(i * 1000);
    m.request_number = i % 2 ? 0 : i - 1;
    m.address = static_cast<int>(i % 248);
    m.info = "info " + std::to_string(i);
    m.drive_info = i % 2 ? "drive " + std::to_string(i) : "";
    m.anomalies.assign(i % 2, Anomaly{});
    sink.on_frame(m);
    if (i % 5 == 0) {
      Frame noise;
      noise.number = i;
      noise.events = {ByteEvent{}, ByteEvent{}, ByteEvent{}};
      sink.on_noise(noise);
    }
    if (i % 2 == 0) {
      Transaction t;
      t.request_number = i - 1;
      t.detail = i % 4 ? "" : "late";
      sink.on_transaction(t);
    }
    if (i % 11 == 0) sink.on_anomaly({AnomalyKind::noise, 0, 0, i, "anomaly " + std::to_string(i)});
    if (i % 13 == 0) {
      BusEvent e;
      e.kind = EventKind::running;
      e.detail = "drive " + std::to_string(i);
      sink.on_event(e);
    }
  }
  Stats s;
  s.frames = frames;
  sink.on_summary(s);
}

}  // namespace

TEST(ThreadedSink, InnerSinkGetsEveryRecordInOrderOnTheWriterThread) {
  // Far more records than the batches in flight hold: the writer falls behind and catches up.
  const std::size_t frames = ThreadedSink::kBatchRecords * (ThreadedSink::kDepth + 3) * 2 + 17;
  RecordingSink direct;
  play(direct, frames);
  RecordingSink inner;
  {
    ThreadedSink threaded(inner);
    play(threaded, frames);
    threaded.finish();
    EXPECT_EQ(inner.flushes, 0) << "finish() replays; flushing is the owner's";
  }
  EXPECT_EQ(inner.lines, direct.lines);
  ASSERT_FALSE(inner.threads.empty());
  for (const std::thread::id& id : inner.threads) EXPECT_NE(id, std::this_thread::get_id());
}

TEST(ThreadedSink, FlushWaitsForTheWriterThenFlushesTheInnerSink) {
  RecordingSink inner;
  ThreadedSink threaded(inner);
  play(threaded, 10);  // less than a batch: nothing is handed over until the flush
  EXPECT_TRUE(threaded.flush());
  EXPECT_EQ(inner.flushes, 1);
  RecordingSink direct;
  play(direct, 10);
  EXPECT_EQ(inner.lines, direct.lines);
  // Records after a flush still come, after the earlier ones.
  threaded.on_anomaly({AnomalyKind::noise, 0, 0, 0, "after"});
  threaded.finish();
  ASSERT_FALSE(inner.lines.empty());
  EXPECT_EQ(inner.lines.back(), "anomaly after");
}

TEST(ThreadedSink, DestructionReplaysWhatIsLeftAndKeepsTheInnerSinksDetail) {
  RecordingSink inner(/*detail=*/false);
  {
    ThreadedSink threaded(inner);
    EXPECT_FALSE(threaded.needs().detail);
    EXPECT_FALSE(threaded.needs().fields);
    play(threaded, 3 * ThreadedSink::kBatchRecords);
  }  // no finish(): the destructor does it
  RecordingSink direct;
  play(direct, 3 * ThreadedSink::kBatchRecords);
  EXPECT_EQ(inner.lines, direct.lines);
  RecordingSink detailed;
  EXPECT_TRUE(ThreadedSink(detailed).needs().detail);
  EXPECT_TRUE(ThreadedSink(detailed).needs().fields);
  EXPECT_TRUE(ThreadedSink(detailed).needs().transactions);
  SummaryOnlySink summary_only(detailed);  // a sink that drops transactions
  EXPECT_FALSE(ThreadedSink(summary_only).needs().transactions);
}

namespace {

// Blocks the writer in on_frame for frame `gate_at` until opened.
class GatedSink final : public Sink {
 public:
  explicit GatedSink(std::uint64_t gate_at) : gate_at_(gate_at) {}
  void on_frame(const Message& m) override {
    if (m.frame.number == gate_at_) {
      std::unique_lock lock(mutex_);
      waiting = true;
      changed_.notify_all();
      changed_.wait(lock, [this] { return open_; });
    }
    frames = m.frame.number;
  }
  void on_noise(const Frame&) override {}
  void on_anomaly(const Anomaly&) override {}
  void on_transaction(const Transaction&) override {}
  void on_summary(const Stats&) override {}
  bool flush() override {
    ++flushes;
    flushed_at = frames.load();
    return true;
  }
  void wait_until_blocked() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] { return waiting; });
  }
  void open() {
    const std::lock_guard lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }

  std::atomic<std::uint64_t> frames{0};
  std::atomic<int> flushes{0};
  std::atomic<std::uint64_t> flushed_at{0};
  bool waiting = false;

 private:
  std::uint64_t gate_at_;
  std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = false;
};

// The pipeline's side: frames 1..count of `m` given on a thread of their own, `given` counting
// them, then flush().
std::thread give_frames(ThreadedSink& threaded, Message& m, std::size_t count,
                        std::atomic<std::size_t>& given) {
  return std::thread([&threaded, &m, count, &given] {
    for (std::size_t i = 1; i <= count; ++i) {
      m.frame.number = i;
      threaded.on_frame(m);
      given = i;
    }
    threaded.flush();
  });
}

}  // namespace

// The pipeline thread waits for a writer that falls behind (the queue is bounded), and flush()
// waits until the writer has replayed the last record, not only taken it.
TEST(ThreadedSink, APipelineAheadOfItsWriterWaitsAndFlushWaitsForTheReplay) {
  constexpr std::size_t kFrames = ThreadedSink::kBatchRecords * (ThreadedSink::kDepth + 3);
  {
    GatedSink inner(/*gate_at=*/1);
    ThreadedSink threaded(inner);
    Message m;
    std::atomic<std::size_t> given{0};
    std::thread pipeline = give_frames(threaded, m, kFrames, given);
    inner.wait_until_blocked();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    // The batch being replayed, those queued and the one being filled: no more.
    EXPECT_LE(given.load(), (ThreadedSink::kDepth + 1) * ThreadedSink::kBatchRecords);
    EXPECT_EQ(inner.flushes.load(), 0);
    inner.open();
    pipeline.join();
    EXPECT_EQ(inner.flushed_at.load(), kFrames);
  }
  {
    GatedSink inner(/*gate_at=*/kFrames);  // the last record
    ThreadedSink threaded(inner);
    Message m;
    std::atomic<std::size_t> given{0};
    std::thread pipeline = give_frames(threaded, m, kFrames, given);
    inner.wait_until_blocked();  // the writer holds the last batch, nothing else is queued
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_EQ(inner.flushes.load(), 0) << "flush() did not wait for the batch being replayed";
    inner.open();
    pipeline.join();
    EXPECT_EQ(inner.flushed_at.load(), kFrames);
  }
}

// Records of large frames (a byte log of noise with a time stamp a byte) fill a batch by their
// storage long before its count: it is handed on at kBatchBytes, so that a pipeline ahead of its
// writer holds a few MiB of them, not kDepth + 1 batches of 256.
TEST(ThreadedSink, ABatchOfLargeFramesIsHandedOnOnceItHoldsBatchBytes) {
  Message m;
  for (std::size_t i = 0; i < 4096; ++i)
    m.frame.events.push_back({static_cast<TimeNs>(1000 * i + i * (i + 1) / 2), 0x55, 0, 0, 0});
  const std::size_t frame_bytes = m.frame.storage_bytes();
  ASSERT_GT(frame_bytes, 50'000u);
  const std::size_t per_batch = ThreadedSink::kBatchBytes / frame_bytes + 1;
  ASSERT_LT(per_batch, ThreadedSink::kBatchRecords);
  constexpr std::size_t kFrames = ThreadedSink::kBatchRecords;
  GatedSink inner(/*gate_at=*/1);
  ThreadedSink threaded(inner);
  std::atomic<std::size_t> given{0};
  std::thread pipeline = give_frames(threaded, m, kFrames, given);
  inner.wait_until_blocked();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  // The batch being replayed, those queued and the one being filled, each of per_batch records.
  EXPECT_LE(given.load(), (ThreadedSink::kDepth + 1) * per_batch);
  inner.open();
  pipeline.join();
  EXPECT_EQ(inner.flushed_at.load(), kFrames);
}

// Once replayed, a record holding more than it keeps for reuse is freed: a run that met a few
// hundred frames of 4 KiB of noise does not keep their storage in every record.
TEST(ThreadedSink, RecordsKeepNoMoreStorageThanTheBound) {
  Message m;
  Frame noise;
  for (std::size_t i = 0; i < 4096; ++i) {
    const ByteEvent e{static_cast<TimeNs>(1000 * i + i * (i + 1) / 2), 0x55, 0, 0, 0};
    m.frame.events.push_back(e);
    noise.events.push_back(e);
  }
  ASSERT_GT(m.frame.storage_bytes(), kKeptStorageBytes);
  ASSERT_GT(noise.storage_bytes(), kKeptStorageBytes);
  RecordingSink inner;
  ThreadedSink threaded(inner);
  for (std::size_t i = 1; i <= ThreadedSink::kBatchRecords * 2; ++i) {
    m.frame.number = i;
    if (i % 2)
      threaded.on_frame(m);
    else
      threaded.on_noise(noise);
  }
  EXPECT_EQ(threaded.kept_storage_bytes(), 0u);  // every record is as new
  const std::size_t records = ThreadedSink::kBatchRecords * (ThreadedSink::kDepth + 1);
  // Records of small frames keep theirs.
  Message small;
  small.frame.events.push_back({0, 0x01, 0, 0, 0});
  for (std::size_t i = 1; i <= records; ++i) threaded.on_frame(small);
  EXPECT_GT(threaded.kept_storage_bytes(), 0u);
}

TEST(ThreadedSink, RecordsAfterFinishGoStraightToTheInnerSink) {
  RecordingSink inner;
  ThreadedSink threaded(inner);
  play(threaded, 3);
  threaded.finish();
  threaded.on_anomaly({AnomalyKind::noise, 0, 0, 0, "late"});
  ASSERT_FALSE(inner.lines.empty());
  EXPECT_EQ(inner.lines.back(), "anomaly late");
  EXPECT_EQ(inner.threads.back(), std::this_thread::get_id());
}

namespace {

// The text a sink writes into a file in memory.
class MemoryFile {
 public:
  MemoryFile() : file_(open_memstream(&data_, &size_)) {}
  ~MemoryFile() {
    if (file_) std::fclose(file_);
    std::free(data_);
  }
  MemoryFile(const MemoryFile&) = delete;
  MemoryFile& operator=(const MemoryFile&) = delete;
  std::FILE* file() { return file_; }
  std::string text() {
    std::fflush(file_);
    return std::string(data_, size_);
  }

 private:
  char* data_ = nullptr;
  std::size_t size_ = 0;
  std::FILE* file_;
};

// Frames, each now and then followed by anomalies of its own (shown under the frame) or of an
// earlier frame (shown on a line of their own), transactions and noise: what a text sink shows
// differently right after a frame, wherever a batch happens to start.
// With `heavy`, every frame holds some 70 KiB of storage (4 KiB of bytes, each stamped on its
// own, like noise from a logic analyser): batches are then handed on by weight (kBatchBytes),
// right after a frame and before its anomalies.
void play_with_anomalies(Sink& sink, std::size_t frames, bool heavy = false) {
  Message m;
  for (std::size_t i = 1; i <= frames; ++i) {
    m.frame.number = i;
    m.frame.channel = static_cast<ChannelId>(i % 2);
    m.frame.events.clear();
    const std::size_t size = heavy ? 4096 : 2 + i % 5;
    for (std::size_t k = 0; k < size; ++k)
      m.frame.events.push_back({static_cast<TimeNs>(i * 100'000'000 + k * k),
                                static_cast<std::uint8_t>(i), 0, m.frame.channel, 0});
    m.bytes = m.frame.bytes();
    m.protocol = protocols::modbus_rtu;
    m.direction = i % 2 ? Direction::request : Direction::response;
    m.address = static_cast<int>(i % 7);
    m.info = "info " + std::to_string(i);
    sink.on_frame(m);
    for (std::size_t k = 0; k < i % 3; ++k)
      sink.on_anomaly({AnomalyKind::malformed, static_cast<TimeNs>(i * 1000), m.frame.channel,
                       i % 7 == 0 ? i - 1 : i, "anomaly " + std::to_string(i)});
    if (i % 4 == 0) {
      Transaction t;
      t.outcome = Outcome::timeout;
      t.request_number = i - 1;
      sink.on_transaction(t);
    }
    if (i % 9 == 0) {
      Frame noise;
      noise.number = ++i;
      noise.events = {ByteEvent{static_cast<TimeNs>(i * 1000), 0x55, 0, 0, 0}};
      sink.on_noise(noise);
      sink.on_anomaly({AnomalyKind::uart_framing, 0, 0, i, "framing " + std::to_string(i)});
    }
  }
  Stats s;
  s.frames = frames;
  sink.on_summary(s);
}

}  // namespace

// With helpers, batches are formatted on several threads (the pipeline's among them when it is
// ahead) and written in order: the text and JSON must be byte for byte what one sink writes, the
// anomalies shown under their frame wherever a batch starts (after a full batch, or after a frame
// whose weight hands the batch on), and records after finish() too.
TEST(ThreadedSink, HelpersFormatingBatchesWriteWhatOneSinkWrites) {
  ChannelTable channels;
  channels.intern("a");
  channels.intern("b");
  TextSinkOptions options;
  for (const bool json : {false, true}) {
    for (const bool heavy : {false, true}) {
      auto make = [&](std::FILE* f) -> std::unique_ptr<FormattingSink> {
        if (json) return std::make_unique<JsonSink>(f, channels, 1000, true);
        return std::make_unique<TextSink>(f, channels, options);
      };
      const std::size_t frames = heavy ? 150 : ThreadedSink::kBatchRecords * 20 + 7;
      MemoryFile expected_file;
      {
        const std::unique_ptr<Sink> direct = make(expected_file.file());
        play_with_anomalies(*direct, frames, heavy);
        direct->on_anomaly({AnomalyKind::malformed, 0, 0, frames, "after"});
        ASSERT_TRUE(direct->flush());
      }
      const std::string expected = expected_file.text();
      ASSERT_GT(expected.size(), frames * 20);
      for (const std::size_t count : {1u, 2u, 3u}) {
        SCOPED_TRACE(fmt::format("json {} heavy {} helpers {}", json, heavy, count));
        MemoryFile file;
        const std::unique_ptr<FormattingSink> inner = make(file.file());
        std::vector<std::unique_ptr<FormattingSink>> helpers;
        std::vector<FormattingSink*> pointers;
        for (std::size_t i = 0; i < count; ++i) {
          helpers.push_back(make(nullptr));
          pointers.push_back(helpers.back().get());
        }
        {
          ThreadedSink threaded(*inner, pointers);
          play_with_anomalies(threaded, frames, heavy);
          threaded.finish();
          threaded.on_anomaly({AnomalyKind::malformed, 0, 0, frames, "after"});
        }
        ASSERT_TRUE(inner->flush());
        EXPECT_TRUE(file.text() == expected);  // (no diff of megabytes of text when it fails)
      }
    }
  }
}
