// Threaded sink (src/sinks/threaded_sink.hpp): records copied into batches, replayed in order
// into the inner sink on a writer thread (or formatted by helpers on several, written in order).
#include "sinks/threaded_sink.hpp"

#include <algorithm>

#include "core/protocol.hpp"
#include "core/worker_thread.hpp"
#include "drive/drive_fields.hpp"

namespace drivetap {

namespace {

// The inner sink's needs, completed by the ThreadedSink (the drive annotation, the deferred
// decode), the field tree only with detail.
SinkNeeds threaded_needs(const Sink& inner) {
  SinkNeeds n = inner.needs();
  n.fields = n.detail && n.fields;
  n.drive_info = true;
  n.deferred_decode = true;
  return n;
}

}  // namespace

ThreadedSink::ThreadedSink(Sink& inner) : ThreadedSink(inner, nullptr, {}) {}

ThreadedSink::ThreadedSink(FormattingSink& inner, std::vector<FormattingSink*> helpers)
    : ThreadedSink(inner, &inner, std::move(helpers)) {}

ThreadedSink::ThreadedSink(Sink& inner, FormattingSink* formatting_inner,
                           std::vector<FormattingSink*> helpers)
    : inner_(inner),
      formatting_inner_(formatting_inner),
      needs_(threaded_needs(inner)),
      inner_takes_undecoded_(inner.needs().deferred_decode),
      helpers_(std::move(helpers)),
      assist_(helpers_.size() >= 2),
      scratch_(std::max<std::size_t>(1, helpers_.size())),
      current_(std::make_unique<Batch>()) {
  // One writer thread, or one per helper but the last, which is the pipeline thread's.
  const std::size_t writers = assist_ ? helpers_.size() - 1 : 1;
  // kDepth batches besides the one being filled, and one more for each formatting thread past
  // the first: each holds at most one of them.
  for (std::size_t i = 0; i < kDepth + scratch_.size() - 1; ++i)
    free_.push_back(std::make_unique<Batch>());
  for (std::size_t w = 0; w < writers; ++w)
    writers_.push_back(start_worker_thread([this, w] { run(w); }));
}

ThreadedSink::~ThreadedSink() {
  finish();
}

void ThreadedSink::publish() {
  if (current_->empty()) return;
  std::unique_lock lock(mutex_);
  current_->sequence = published_++;
  full_.push_back(std::move(current_));
  // While the writers have been the slower side lately (this thread found no free batch within
  // the last kBehindBatches), a waiting writer is woken at once: an idle writer is lost time.
  // Otherwise once kWakeWritersAt batches wait: this thread is the slower side, and every
  // wake-up costs it. (Waiting for a free batch below, this thread has published all the others:
  // kWakeWritersAt or more wait, or are being replayed, so the writers are busy or were woken.)
  const bool writers_behind = published_ - last_back_pressure_ <= kBehindBatches;
  if (full_.size() >= (writers_behind ? 1 : kWakeWritersAt)) changed_.notify_all();
  if (free_.empty()) last_back_pressure_ = published_;
  // Back-pressure: every other batch is queued or being replayed; wait for one to come back.
  // With a helper of its own, this thread formats the oldest queued batch meanwhile: the writers
  // are behind, and this core would idle.
  while (free_.empty()) {
    if (!assist_ || full_.empty()) {
      changed_.wait(lock);
      continue;
    }
    std::unique_ptr<Batch> batch = std::move(full_.front());
    full_.pop_front();
    ++replaying_;
    lock.unlock();
    replay(*batch, *helpers_.back(), scratch_.back());
    commit(std::move(batch));
    lock.lock();
  }
  current_ = std::move(free_.back());
  free_.pop_back();
  current_->follows = last_number_;
}

void ThreadedSink::wait_until_idle() {
  publish();
  std::unique_lock lock(mutex_);
  changed_.notify_all();  // the writers take what is queued, however little
  changed_.wait(lock, [this] { return full_.empty() && replaying_ == 0; });
}

std::size_t ThreadedSink::kept_storage_bytes() {
  if (!finished_) wait_until_idle();
  const std::lock_guard lock(mutex_);
  std::size_t bytes = 0;
  auto count = [&bytes](const Batch& batch) {
    for (const Record& r : batch.records.items)
      bytes += r.message.frame.storage_bytes() + r.noise.storage_bytes();
    bytes += batch.bytes.capacity();
  };
  for (const Scratch& scratch : scratch_) bytes += scratch.decoded.frame.storage_bytes();
  count(*current_);
  for (const std::unique_ptr<Batch>& batch : free_) count(*batch);
  return bytes;
}

void ThreadedSink::run(std::size_t writer) {
  // Without helpers, the one writer replays into the inner sink. With them, each writer replays
  // its batches into its helper, which writes them into memory, and the text goes to the inner
  // sink in the batches' order (commit()).
  Sink& target = helpers_.empty() ? inner_ : static_cast<Sink&>(*helpers_[writer]);
  Scratch& scratch = scratch_[writer];
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
    replay(*batch, target, scratch);
    if (helpers_.empty()) {
      recycle(std::move(batch));
    } else {
      commit(std::move(batch));
    }
  }
}

void ThreadedSink::replay(Batch& batch, Sink& target, Scratch& scratch) {
  // With helpers, `target` is one of them (run(), publish()).
  if (!helpers_.empty()) static_cast<FormattingSink&>(target).follow(batch.follows);
  for (const Entry& entry : batch.order) {
    switch (entry.kind) {
      case Kind::frame: {
        Record& r = batch.records.items[entry.slot];  // not const: a large frame is freed
        complete_drive_info(r.message, scratch.drive);
        target.on_frame(r.message);
        if (r.message.frame.storage_bytes() > kKeptStorageBytes) r.message = Message{};
        break;
      }
      case Kind::undissected: {
        Undissected& u = batch.undissected.items[entry.slot];
        const std::span<const std::uint8_t> bytes(batch.bytes);
        const std::size_t size = u.telegram.run.bytes.size();
        u.telegram.run.bytes = bytes.subspan(u.bytes_at, size);
        u.telegram.request = bytes.subspan(u.bytes_at + size, u.telegram.request.size());
        if (!u.telegram.anomalies.empty())
          u.telegram.anomalies = std::span<const Anomaly>(batch.anomalies)
                                     .subspan(u.anomalies_at, u.telegram.anomalies.size());
        if (!u.telegram.drive_values.empty())
          u.telegram.drive_values = std::span<const DriveValue>(batch.drive_values)
                                        .subspan(u.drive_values_at, u.telegram.drive_values.size());
        if (inner_takes_undecoded_ && u.telegram.head) u.telegram.head = &u.head;
        replay_undissected(u.telegram, target, scratch);
        if (scratch.decoded.frame.storage_bytes() > kKeptStorageBytes) scratch.decoded = Message{};
        break;
      }
      case Kind::noise: {
        Record& r = batch.records.items[entry.slot];
        target.on_noise(r.noise);
        if (r.noise.storage_bytes() > kKeptStorageBytes) r.noise = Frame{};
        break;
      }
      case Kind::anomaly:
        target.on_anomaly(batch.records.items[entry.slot].anomaly);
        break;
      case Kind::transaction:
        target.on_transaction(batch.transactions.items[entry.slot]);
        break;
      case Kind::summary:
        target.on_summary(*batch.records.items[entry.slot].stats);
        break;
      case Kind::event:
        target.on_event(batch.records.items[entry.slot].event);
        break;
    }
  }
  // (A helper is made to write into memory: formatted() is its text.)
  if (!helpers_.empty()) batch.text.swap(*static_cast<FormattingSink&>(target).formatted());
}

void ThreadedSink::recycle(std::unique_ptr<Batch> batch) {
  batch->clear();
  std::lock_guard lock(mutex_);
  free_.push_back(std::move(batch));
  --replaying_;
  changed_.notify_all();
}

void ThreadedSink::commit(std::unique_ptr<Batch> batch) {
  std::unique_lock lock(mutex_);
  formatted_.push_back(std::move(batch));
  // One writer at a time writes, every formatted batch that is next in order; a writer whose
  // batch must wait leaves it to that one and formats another meanwhile.
  if (committing_) return;
  committing_ = true;
  for (;;) {
    const auto next = std::find_if(formatted_.begin(), formatted_.end(),
                                   [this](const auto& b) { return b->sequence == committed_; });
    if (next == formatted_.end()) break;
    std::unique_ptr<Batch> ready = std::move(*next);
    formatted_.erase(next);
    lock.unlock();
    formatting_inner_->write_formatted(ready->text.view());
    ready->clear();
    lock.lock();
    ++committed_;
    free_.push_back(std::move(ready));
    --replaying_;
    changed_.notify_all();
  }
  committing_ = false;
}

void ThreadedSink::weigh(std::size_t bytes) {
  current_->storage_bytes += bytes;
  if (current_->storage_bytes >= kBatchBytes) publish();
}

void ThreadedSink::replay_undissected(const DeferredTelegram& telegram, Sink& target,
                                      Scratch& scratch) const {
  if (inner_takes_undecoded_) return target.on_deferred_frame(telegram);  // (it decodes them)
  Message& decoded = scratch.decoded;
  decoded.detail = needs_.detail;
  decoded.tree = needs_.fields;
  telegram.decode_into(decoded);
  if (telegram.drive_values_with_annotation)
    complete_drive_info_and_values(decoded, scratch.drive);
  else if (decoded.drive_profile)
    complete_drive_info(decoded, scratch.drive);
  target.on_frame(decoded);
  // The message's anomalies follow it, as the pipeline hands them on.
  for (const Anomaly& a : decoded.anomalies) target.on_anomaly(a);
}

void ThreadedSink::on_deferred_frame(const DeferredTelegram& telegram) {
  if (finished_) {  // the writers have stopped: decoded here
    replay_undissected(telegram, inner_, scratch_[0]);
    given(telegram.number);
    return;
  }
  Undissected& r = next_slot(Kind::undissected, &Batch::undissected);
  r.telegram = telegram;
  if (inner_takes_undecoded_ && telegram.head)
    r.head = *telegram.head;
  else
    r.telegram.head = nullptr;  // (no reader: not kept pointing into the pipeline)
  if (!telegram.anomalies.empty()) {
    std::vector<Anomaly>& anomalies = current_->anomalies;
    r.anomalies_at = static_cast<std::uint32_t>(anomalies.size());
    anomalies.insert(anomalies.end(), telegram.anomalies.begin(), telegram.anomalies.end());
  }
  if (!telegram.drive_values.empty()) {
    std::vector<DriveValue>& values = current_->drive_values;
    r.drive_values_at = static_cast<std::uint32_t>(values.size());
    values.insert(values.end(), telegram.drive_values.begin(), telegram.drive_values.end());
  }
  std::vector<std::uint8_t>& bytes = current_->bytes;
  r.bytes_at = bytes.size();
  bytes.insert(bytes.end(), telegram.run.bytes.begin(), telegram.run.bytes.end());
  bytes.insert(bytes.end(), telegram.request.begin(), telegram.request.end());
  given(telegram.number);
  weigh(telegram.run.bytes.size() + telegram.request.size());
}

void ThreadedSink::on_frame(const Message& message) {
  if (finished_ && message.drive_profile) {
    // The writers have stopped: the annotation is written here, on a copy.
    Message completed = message;
    complete_drive_info(completed, scratch_[0].drive);
    inner_.on_frame(completed);
    given(message.frame.number);
    return;
  }
  give_numbered(Kind::frame, &Record::message, message, &Sink::on_frame, message.frame.number);
}
void ThreadedSink::on_transaction(const Transaction& transaction) {
  if (finished_) return inner_.on_transaction(transaction);
  next_slot(Kind::transaction, &Batch::transactions) = transaction;
}

void ThreadedSink::on_summary(const Stats& stats) {
  if (finished_) return inner_.on_summary(stats);
  Record& r = next_slot(Kind::summary, &Batch::records);
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
  for (std::thread& writer : writers_) writer.join();
  finished_ = true;
  // Records from now on go straight to the inner sink, after the last one a writer replayed.
  if (!helpers_.empty()) formatting_inner_->follow(last_number_);
}

}  // namespace drivetap
