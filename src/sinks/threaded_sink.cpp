// Threaded sink (src/sinks/threaded_sink.hpp): records copied into batches, replayed in order
// into the inner sink on a writer thread.
#include "sinks/threaded_sink.hpp"

#include "core/protocol.hpp"
#include "core/worker_thread.hpp"

namespace drivetap {

ThreadedSink::ThreadedSink(Sink& inner)
    : inner_(inner),
      wants_detail_(inner.wants_detail()),
      wants_fields_(inner.wants_fields()),
      wants_transactions_(inner.wants_transactions()),
      wants_records_(inner.wants_records()),
      current_(std::make_unique<Batch>()) {
  // kDepth batches besides the one being filled: the writer holds at most one of them.
  for (std::size_t i = 0; i < kDepth; ++i) free_.push_back(std::make_unique<Batch>());
  writer_ = start_worker_thread([this] { run(); });
}

ThreadedSink::~ThreadedSink() {
  finish();
}

ThreadedSink::Record& ThreadedSink::next_record() {
  if (current_->used == current_->records.size()) publish();
  return current_->records[current_->used++];
}

void ThreadedSink::publish() {
  if (current_->used == 0) return;
  std::unique_lock lock(mutex_);
  full_.push_back(std::move(current_));
  changed_.notify_all();
  // Back-pressure: every other batch is queued or being replayed; wait for one to come back.
  changed_.wait(lock, [this] { return !free_.empty(); });
  current_ = std::move(free_.back());
  free_.pop_back();
}

void ThreadedSink::wait_until_idle() {
  publish();
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [this] { return full_.empty() && replaying_ == 0; });
}

std::size_t ThreadedSink::kept_storage_bytes() {
  if (!finished_) wait_until_idle();
  const std::lock_guard lock(mutex_);
  std::size_t bytes = 0;
  auto count = [&bytes](const Batch& batch) {
    for (const Record& r : batch.records)
      bytes += r.message.frame.storage_bytes() + r.noise.storage_bytes();
  };
  count(*current_);
  for (const std::unique_ptr<Batch>& batch : free_) count(*batch);
  return bytes;
}

void ThreadedSink::run() {
  for (;;) {
    std::unique_ptr<Batch> batch;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [this] { return !full_.empty() || stopping_; });
      if (full_.empty()) return;  // stopping, and everything replayed
      batch = std::move(full_.front());
      full_.pop_front();
      ++replaying_;
    }
    for (std::size_t i = 0; i < batch->used; ++i) {
      Record& r = batch->records[i];  // not const: a record holding a large frame is freed
      switch (r.kind) {
        case Kind::frame:
          complete_drive_info(r.message, drive_scratch_);
          inner_.on_frame(r.message);
          if (r.message.frame.storage_bytes() > kKeptStorageBytes) r.message = Message{};
          break;
        case Kind::undissected:
          r.undissected.telegram.run.bytes = r.undissected.bytes;
          r.undissected.telegram.request = r.undissected.request;
          replay_undissected(r.undissected.telegram);
          if (decoded_.frame.storage_bytes() > kKeptStorageBytes) decoded_ = Message{};
          break;
        case Kind::noise:
          inner_.on_noise(r.noise);
          if (r.noise.storage_bytes() > kKeptStorageBytes) r.noise = Frame{};
          break;
        case Kind::anomaly:
          inner_.on_anomaly(r.anomaly);
          break;
        case Kind::transaction:
          inner_.on_transaction(r.transaction);
          break;
        case Kind::summary:
          inner_.on_summary(*r.stats);
          break;
        case Kind::event:
          inner_.on_event(r.event);
          break;
      }
    }
    batch->used = 0;
    batch->storage_bytes = 0;
    std::lock_guard lock(mutex_);
    free_.push_back(std::move(batch));
    --replaying_;
    changed_.notify_all();
  }
}

void ThreadedSink::weigh(std::size_t bytes) {
  current_->storage_bytes += bytes;
  if (current_->storage_bytes >= kBatchBytes) publish();
}

void ThreadedSink::replay_undissected(const UndissectedTelegram& telegram) {
  decoded_.detail = wants_detail_;
  decoded_.tree = wants_detail_ && wants_fields_;
  decode_undissected(telegram, decoded_);
  inner_.on_frame(decoded_);
  // The message's anomalies follow it, as the pipeline hands them on.
  for (const Anomaly& a : decoded_.anomalies) inner_.on_anomaly(a);
}

void ThreadedSink::on_undissected(const UndissectedTelegram& telegram) {
  if (finished_) return replay_undissected(telegram);  // (the writer has stopped: decoded here)
  Record& r = next_record();
  r.kind = Kind::undissected;
  r.undissected.telegram = telegram;
  r.undissected.bytes.assign(telegram.run.bytes.begin(), telegram.run.bytes.end());
  r.undissected.request.assign(telegram.request.begin(), telegram.request.end());
  weigh(r.undissected.bytes.size());
}

void ThreadedSink::on_frame(const Message& message) {
  if (finished_ && message.drive_profile) {
    // The writer thread has stopped: the annotation is written here, on a copy.
    Message completed = message;
    complete_drive_info(completed, drive_scratch_);
    return inner_.on_frame(completed);
  }
  if (const Record* r = give(Kind::frame, &Record::message, message, &Sink::on_frame))
    weigh(r->message.frame.storage_bytes());
}
void ThreadedSink::on_noise(const Frame& noise) {
  if (const Record* r = give(Kind::noise, &Record::noise, noise, &Sink::on_noise))
    weigh(r->noise.storage_bytes());
}
void ThreadedSink::on_anomaly(const Anomaly& anomaly) {
  give(Kind::anomaly, &Record::anomaly, anomaly, &Sink::on_anomaly);
}
void ThreadedSink::on_transaction(const Transaction& transaction) {
  give(Kind::transaction, &Record::transaction, transaction, &Sink::on_transaction);
}
void ThreadedSink::on_event(const BusEvent& event) {
  give(Kind::event, &Record::event, event, &Sink::on_event);
}

void ThreadedSink::on_summary(const Stats& stats) {
  if (finished_) return inner_.on_summary(stats);
  Record& r = next_record();
  r.kind = Kind::summary;
  r.stats = std::make_unique<Stats>(stats);
}

bool ThreadedSink::flush() {
  if (finished_) return inner_.flush();
  wait_until_idle();
  return inner_.flush();
}

void ThreadedSink::finish() {
  if (finished_) return;
  wait_until_idle();
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    changed_.notify_all();
  }
  writer_.join();
  finished_ = true;
}

}  // namespace drivetap
