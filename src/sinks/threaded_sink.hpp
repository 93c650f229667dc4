// Threaded sink: the records of a run written on a thread of their own, so that formatting and
// writing (text, JSON, pcapng) use the second core while the first decodes (docs/performance.md).
// Contract of src/sinks/sink.hpp: the inner sink gets every record, in order.
//
//   pipeline thread:  on_frame(m) ... -> copied into a batch (kBatchRecords) -> queue (kDepth)
//   writer thread:    batch -> [decoded, drive annotation written] -> inner.on_frame(copy) ... ;
//                     the batch goes back for reuse
//
// With drive profiles the writer also writes each frame's drive annotation (Message::drive_profile
// -> drive_info, SinkNeeds::drive_info): the profiles, which the pipeline indexed before the first
// frame, are then read on both threads and changed on neither.
// Records are copied: the pipeline reuses its Message for the next frame at once. A batch's
// records keep their storage from one use to the next, so the copies do not allocate once the
// run is under way. (Copying beats swapping a frame's Message with its record: swapped,
// the storage of every queued message goes round the decoding thread's caches, where one Message
// stays hot.) At most kDepth batches wait, and a batch is handed on early once
// its records' frames hold kBatchBytes: memory stays bounded however far the writer falls behind,
// and however large the frames. A record whose frame holds more than kKeptStorageBytes is freed
// once replayed (the rest of a message is bounded by the longest telegram). flush() and finish()
// wait until the writer has replayed everything given so far; finish() (or the destructor) then
// stops the thread; records after it go straight to the inner sink. The worker thread runs with
// SIGINT and SIGTERM blocked. The inner sink and everything its records name (the ChannelTable)
// must outlive this one, and so must the drive profiles its messages name; only the writer thread
// calls the inner sink between construction and finish(), except needs(), read once here.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "drive/annotate.hpp"
#include "sinks/sink.hpp"

namespace drivetap {

class alignas(kCacheLineBytes) ThreadedSink final : public Sink {
 public:
  static constexpr std::size_t kBatchRecords = 256;
  static constexpr std::size_t kDepth = 4;  // batches queued for the writer at most
  // A waiting writer is woken once this many batches wait, not for each one, unless the writers
  // were behind within the last kBehindBatches (publish()): a writer that keeps up (the pipeline
  // thread is the slower one with drive profiles) then takes two per wake-up, each of which costs
  // the pipeline thread a futex call and scheduler time.
  static constexpr std::size_t kWakeWritersAt = 2;
  static constexpr std::uint64_t kBehindBatches = 8;
  static_assert(kWakeWritersAt <= kDepth, "a pipeline waiting for a free batch has woken them");
  // A batch is published once its records' frames hold this many bytes of storage (4 KiB of
  // noise with a time stamp a byte holds some 70 KiB), however few they are.
  static constexpr std::size_t kBatchBytes = 1024 * 1024;

  // One writer replays into `inner`.
  explicit ThreadedSink(Sink& inner);
  // With `helpers` (sinks like `inner`, made to write into memory: FormattingSink::formatted()),
  // batches are formatted whole by several threads, each with a helper of its own, and their text
  // goes to `inner` (FormattingSink::write_formatted()) in the batches' order: one writer thread
  // per helper but the last, which is the pipeline thread's when its next batch would otherwise
  // wait for a writer (one helper: one writer thread, no help). No helpers: as above. The helpers
  // must outlive this sink.
  ThreadedSink(FormattingSink& inner, std::vector<FormattingSink*> helpers);
  ~ThreadedSink() override;
  ThreadedSink(const ThreadedSink&) = delete;
  ThreadedSink& operator=(const ThreadedSink&) = delete;

  void on_frame(const Message& message) override;
  void on_noise(const Frame& noise) override {
    give_numbered(Kind::noise, &Record::noise, noise, &Sink::on_noise, noise.number);
  }
  void on_anomaly(const Anomaly& anomaly) override {
    give(Kind::anomaly, &Record::anomaly, anomaly, &Sink::on_anomaly);
  }
  void on_transaction(const Transaction& transaction) override;
  void on_summary(const Stats& stats) override;
  void on_event(const BusEvent& event) override {
    give(Kind::event, &Record::event, event, &Sink::on_event);
  }
  // Waits for the writer to replay everything, then flushes the inner sink (on this thread).
  bool flush() override;
  // The inner sink's needs, and: the drive annotation (Message::drive_profile) is written on the
  // writer thread, before the inner sink gets the message (formatting it is a large part of the
  // decoding thread's work with drive profiles); telegrams handed over
  // undecoded are copied as they come and decoded on the writer thread, before the inner sink
  // gets them and their anomalies (or, for an inner sink that judges them undecoded, the display
  // filter's, handed on as they came).
  [[nodiscard]] SinkNeeds needs() const override { return needs_; }
  void on_deferred_frame(const DeferredTelegram& telegram) override;
  // Replays what is left and stops the writer thread; the inner sink is the caller's again.
  void finish();
  // Waits until the writer is idle, then counts the storage its records' frames keep for reuse:
  // what kKeptStorageBytes bounds. On the thread that gives the records only (it publishes the
  // batch being filled, and reads it). Messages' other members (bytes, fields, info) are not
  // counted: they are bounded by the longest telegram.
  [[nodiscard]] std::size_t kept_storage_bytes();

 private:
  ThreadedSink(Sink& inner, FormattingSink* formatting_inner, std::vector<FormattingSink*> helpers);
  enum class Kind : unsigned char {
    frame,
    undissected,
    noise,
    anomaly,
    transaction,
    summary,
    event
  };
  // A DeferredTelegram whose bytes, and then its request's, were copied into the batch's
  // `bytes` from `bytes_at`: its spans are set to them when replayed.
  struct Undissected {
    DeferredTelegram telegram;
    // For an inner sink that judges telegrams undecoded: a copy of *telegram.head (which points
    // into the pipeline, valid during the hand-over only); telegram.head is set to it when
    // replayed, and is null for other inner sinks.
    TelegramFindings head;
    std::size_t bytes_at = 0;
    std::uint32_t anomalies_at = 0;     // telegram.anomalies' in Batch::anomalies
    std::uint32_t drive_values_at = 0;  // telegram.drive_values' in Batch::drive_values
  };
  // A record of a kind but the two of nearly every record of a run (undissected telegrams and
  // transactions); only the member of its kind is meaningful. The others keep their storage.
  struct Record {
    Message message;
    Frame noise;
    Anomaly anomaly;
    BusEvent event;
    std::unique_ptr<Stats> stats;  // rare: the closing summary
  };
  // A batch's records in order: one of kind `kind` is the `slot`-th of the vector of its kind.
  struct Entry {
    Kind kind;
    std::uint32_t slot;
  };
  // A batch's records of one kind, kept from use to use (their strings keep their storage).
  template <class T>
  struct Slots {
    std::vector<T> items;
    std::size_t used = 0;
    T& next() {
      if (used == items.size()) items.emplace_back();
      return items[used++];
    }
  };
  // On cache lines of its own: the pipeline thread writes the members of the batch it fills for
  // every record while a writer reads those of another for every record it replays, and the
  // batches are made one after the other on the heap (a shared line slows both threads).
  struct alignas(kCacheLineBytes) Batch {
    // Undissected telegrams and transactions, nearly all of a run's records, are small records
    // in vectors of their own, their bytes in one vector: the pipeline thread writes (and a
    // writer reads) a few cache lines a record, not a Record of every kind (over a kilobyte).
    std::vector<Entry> order;
    Slots<Undissected> undissected;
    Slots<Transaction> transactions;
    Slots<Record> records;
    std::vector<std::uint8_t> bytes;  // the undissected telegrams'
    // Their anomalies found by the pipeline (drive timing rules: rare).
    std::vector<Anomaly> anomalies;
    std::vector<DriveValue> drive_values;  // theirs with drive profiles
    std::size_t storage_bytes = 0;         // of the frames of its records, and `bytes`
    std::uint64_t sequence = 0;            // published as the sequence-th batch
    std::uint64_t follows = 0;             // the number of the frame or noise record before it
    LineBuffer text;                       // with helpers: its records' text, once formatted
    Batch() { order.reserve(kBatchRecords); }
    [[nodiscard]] bool empty() const { return order.empty(); }
    // Emptied for reuse (the records' storage kept).
    void clear() {
      order.clear();
      undissected.used = transactions.used = records.used = 0;
      bytes.clear();
      anomalies.clear();
      drive_values.clear();
      storage_bytes = 0;
      text.clear();
    }
  };
  // A writer's own storage, reused from record to record.
  struct Scratch {
    DriveReading drive;  // complete_drive_info()'s
    Message decoded;     // an undissected telegram's
  };

  // The slot of the next record, of kind `kind`, in the current batch (publishing a full batch
  // first).
  template <class T>
  T& next_slot(Kind kind, Slots<T> Batch::*slots) {
    if (current_->order.size() == kBatchRecords) publish();
    Slots<T>& of_kind = (*current_).*slots;
    current_->order.push_back({kind, static_cast<std::uint32_t>(of_kind.used)});
    return of_kind.next();
  }
  // A record of one kind: copied into `slot` of the next record, or after finish() given to the
  // inner sink through `direct` (then nullptr).
  template <class T>
  Record* give(Kind kind, T Record::*slot, const T& value, void (Sink::*direct)(const T&)) {
    if (finished_) {
      (inner_.*direct)(value);
      return nullptr;
    }
    Record& r = next_slot(kind, &Batch::records);
    r.*slot = value;  // copy-assigned: the record's vectors and strings keep their storage
    return &r;
  }
  // A frame or noise record (a Message or a Frame in `slot`), numbered `number`: given, then its
  // frame's storage weighed.
  template <class T>
  void give_numbered(Kind kind, T Record::*slot, const T& value, void (Sink::*direct)(const T&),
                     std::uint64_t number) {
    const Record* r = give(kind, slot, value, direct);
    given(number);
    if (r) weigh(frame_of(r->*slot).storage_bytes());
  }
  static const Frame& frame_of(const Message& m) { return m.frame; }
  static const Frame& frame_of(const Frame& f) { return f; }
  // Counts `bytes` of storage in the current batch; publishes it once it holds kBatchBytes.
  void weigh(std::size_t bytes);
  // The frame or noise record numbered `number` has been given (after its record is in the
  // batch, before weigh(): a batch published from now on starts after it, Batch::follows).
  void given(std::uint64_t number) { last_number_ = number; }
  // An undissected telegram to `target`: decoded into scratch.decoded (its drive annotation
  // written with scratch.drive), then it and its anomalies; or handed on undecoded to an inner
  // sink that decodes telegrams itself.
  void replay_undissected(const DeferredTelegram& telegram, Sink& target, Scratch& scratch) const;
  void publish();                // hands the current batch, if it holds records, to the writer
  void wait_until_idle();        // until every published batch has been replayed
  void run(std::size_t writer);  // a writer thread
  // The batch's records into `target` (with helpers, its text then in batch.text).
  void replay(Batch& batch, Sink& target, Scratch& scratch);
  // A replayed batch back to the free ones.
  void recycle(std::unique_ptr<Batch> batch);
  // With helpers: a formatted batch's text to the inner sink in the batches' order (now, or by
  // the writer writing the batches before it), then the batch back to the free ones.
  void commit(std::unique_ptr<Batch> batch);

  // Members in three groups, each on cache lines of its own: read by every thread; written by
  // the pipeline thread for every record; shared under the mutex. The writers read needs_ for
  // every record and the pipeline thread writes last_number_ for every record: sharing a line,
  // they would slow both threads down (false sharing).
  Sink& inner_;
  // With helpers: the inner sink, which writes their text.
  FormattingSink* const formatting_inner_;
  const SinkNeeds needs_;
  // The inner sink judges undecoded telegrams itself (a display filter: SinkNeeds::
  // deferred_decode): they are handed on undecoded, with their heads.
  const bool inner_takes_undecoded_;
  std::vector<FormattingSink*> helpers_;
  const bool assist_;  // the pipeline thread formats with the last helper when it would wait
  std::vector<Scratch> scratch_;  // one per helper (after finish(), the first is the caller's)
  std::vector<std::thread> writers_;

  alignas(kCacheLineBytes) std::unique_ptr<Batch> current_;  // being filled on the pipeline thread
  // The number of the last frame or noise record given (pipeline thread only).
  std::uint64_t last_number_ = 0;
  bool finished_ = false;  // the writer thread has stopped (pipeline thread only)

  alignas(kCacheLineBytes) std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::unique_ptr<Batch>> full_;  // published, in order
  std::vector<std::unique_ptr<Batch>> free_;
  std::size_t replaying_ = 0;             // batches the writers have taken and not given back
  std::uint64_t published_ = 0;           // batches published
  std::uint64_t last_back_pressure_ = 0;  // published_ when publish() last found no free batch
  std::uint64_t committed_ = 0;           // with helpers: batches whose text went to the inner sink
  std::vector<std::unique_ptr<Batch>> formatted_;  // with helpers: formatted, waiting their turn
  bool committing_ = false;  // a writer is writing formatted batches to the inner sink
  bool stopping_ = false;
};

}  // namespace drivetap
