// Read-ahead of a ByteSource on a thread of its own (read_ahead.hpp).
#include "sources/read_ahead.hpp"

#include "core/worker_thread.hpp"

#include <utility>

namespace drivetap {

ReadAhead::ReadAhead(ByteSource& source, std::size_t precheck_ahead)
    : source_(source),
      precheck_ahead_(precheck_ahead),
      thread_(start_worker_thread([this] { run(); })) {}

ReadAhead::~ReadAhead() {
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void ReadAhead::run() {
  RunBatch chunk;
  // Each pass reads one chunk and queues it, or ends.
  while (true) {
    bool ahead = false;  // the caller has chunks enough to go on with while this one is prechecked
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [this] { return stop_ || full_.size() < kDepth; });
      if (stop_) break;
      ahead = full_.size() >= precheck_ahead_;
      if (!spare_.empty()) {
        chunk = std::move(spare_.back());
        spare_.pop_back();
      }
    }
    chunk.clear();
    bool more = true;
    // Each pass appends one batch of the source.
    while (chunk.byte_count() < kChunkBytes && chunk.size() < kChunkRuns &&
           (more = source_.append_runs(chunk))) {
    }
    if (ahead) precheck(chunk);
    {
      const std::lock_guard lock(mutex_);
      if (!chunk.empty()) full_.push_back(std::move(chunk));
      if (!more) ended_ = true;
    }
    changed_.notify_all();
    if (!more) return;
  }
  const std::lock_guard lock(mutex_);
  ended_ = true;
}

void ReadAhead::precheck_with(ChannelId channel, const ProtocolDecoder* decoder) {
  if (channel < kPrecheckChannels) prechecking_[channel].store(decoder, std::memory_order_relaxed);
}

void ReadAhead::precheck(RunBatch& chunk) {
  // (Relaxed: a decoder is a constant object of the table, and a chunk read before the caller
  // named it simply has no prechecks.)
  std::array<const ProtocolDecoder*, kPrecheckChannels> decoders;
  bool any = false;
  for (std::size_t c = 0; c < kPrecheckChannels; ++c) {
    decoders[c] = prechecking_[c].load(std::memory_order_relaxed);
    any = any || decoders[c] != nullptr;
  }
  if (!any) return;
  for (std::size_t k = 0; k < chunk.size(); ++k) {
    const ByteRun run = chunk[k];
    // (A run with UART marks is never taken whole: no precheck.)
    if (run.channel >= kPrecheckChannels || !decoders[run.channel] || !run.flags.empty()) continue;
    TelegramPrecheck made;
    if (!decoders[run.channel]->precheck(run.bytes, &made)) continue;
    made.decoder = decoders[run.channel];
    chunk.set_precheck(k, made);
  }
}

bool ReadAhead::next_chunk(RunBatch& out) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [this] { return !full_.empty() || ended_; });
  if (full_.empty()) return false;
  if (spare_.size() < kDepth) spare_.push_back(std::move(out));
  out = std::move(full_.front());
  full_.pop_front();
  const bool refill = full_.size() <= kRefillAt;  // (the reader waits only with kDepth queued)
  lock.unlock();
  if (refill) changed_.notify_all();
  return true;
}

}  // namespace drivetap
