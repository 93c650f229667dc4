// Unit tests: ThreadedSink — the inner sink gets every record, whole and in order, on the writer
// thread; flush() and finish() wait for it; wants_detail() is the inner sink's.
#include <gtest/gtest.h>

#include <string>
#include <thread>
#include <vector>

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
    for (const FieldNode& f : m.fields) fields += f.text + "=" + std::to_string(f.value) + ",";
    note("frame " + std::to_string(m.frame.number) + " " + bytes + " " + fields + " " + m.info +
         " " + m.drive_info + " " + std::to_string(m.anomalies.size()));
  }
  void on_noise(const Frame& f) override {
    note("noise " + std::to_string(f.number) + " " + std::to_string(f.events.size()));
  }
  void on_anomaly(const Anomaly& a) override { note("anomaly " + a.detail); }
  void on_transaction(const Transaction& t) override {
    note("transaction " + std::to_string(t.request_number) + " " + t.detail);
  }
  void on_summary(const Stats& s) override { note("summary " + std::to_string(s.frames)); }
  void on_event(const BusEvent& e) override { note("event " + e.kind + " " + e.detail); }
  bool flush() override {
    ++flushes;
    return true;
  }
  [[nodiscard]] bool wants_detail() const override { return detail_; }

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
    m.frame.events.assign(i % 7, ByteEvent{});
    for (std::size_t k = 0; k < m.frame.events.size(); ++k)
      m.frame.events[k].byte = static_cast<std::uint8_t>(i + k);
    m.fields.assign(i % 3, FieldNode{});
    for (FieldNode& f : m.fields) {
      f.value = static_cast<std::int64_t>(i);
      f.text = std::string(i % 40, 'x');
    }
    m.info = "info " + std::to_string(i);
    m.drive_info = i % 2 ? "drive " + std::to_string(i) : "";
    m.anomalies.assign(i % 2, Anomaly{});
    sink.on_frame(m);
    if (i % 5 == 0) {
      Frame noise;
      noise.number = i;
      noise.events.assign(3, ByteEvent{});
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
      e.kind = "running";
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
    EXPECT_FALSE(threaded.wants_detail());
    play(threaded, 3 * ThreadedSink::kBatchRecords);
  }  // no finish(): the destructor does it
  RecordingSink direct;
  play(direct, 3 * ThreadedSink::kBatchRecords);
  EXPECT_EQ(inner.lines, direct.lines);
  RecordingSink detailed;
  EXPECT_TRUE(ThreadedSink(detailed).wants_detail());
}
