// Read-ahead: a ByteSource's batches read on a thread of their own, a few chunks ahead of the
// pipeline, so that file reading and unpacking (pcapng blocks, exported-PDU tags, per-byte
// options) use the second core while the first decodes (docs/performance.md).
//
//   reader thread:  source.append_runs() ... -> chunk (kChunkBytes, kChunkRuns) -> queue (kDepth)
//   caller:         next_chunk() <- queue; push_runs(chunk); the chunk goes back for reuse
//
// Only for sources that report no findings (take_findings(): those belong before a given byte)
// and read regular files (a read that can block without end, a pipe or a terminal, could not be
// stopped). The source's ChannelTable is interned on the reader thread and looked up on the
// caller's: ChannelTable allows one writer alongside readers of the channels they were handed.
// error() and notes() of the source may be read once next_chunk() returned false.
//
// The reader also makes each run's precheck (TelegramPrecheck, core/precheck.hpp) for a channel
// whose decoder the caller has named (precheck_with(): the pipeline's, once it has detected the
// protocol): the framer's check and the head's findings, worked out from the bytes alone on
// the second core instead of the decoding thread's.
#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

#include "core/byte_events.hpp"
#include "core/protocol.hpp"
#include "sources/source.hpp"

namespace drivetap {

class ReadAhead {
 public:
  // A chunk ends at the first batch past kChunkBytes bytes or kChunkRuns runs (a run, 56 bytes,
  // holds one byte where every byte has a time of its own: a noisy bus seen by a logic analyser).
  static constexpr std::size_t kChunkBytes = 16384;
  static constexpr std::size_t kChunkRuns = 2048;
  static constexpr std::size_t kDepth = 8;  // chunks read ahead at most
  // The caller wakes a waiting reader once the queue is down to this many chunks, not after
  // every chunk taken: the reader, faster than the pipeline, then reads two before it waits
  // again. A wake-up costs the caller's thread a futex call and scheduler time.
  static constexpr std::size_t kRefillAt = kDepth - 2;

  // `precheck_ahead`: kPrecheckAhead but in tests (0: every chunk prechecked).
  explicit ReadAhead(ByteSource& source, std::size_t precheck_ahead = kPrecheckAhead);
  // Stops the reader thread (at its next batch) and waits for it.
  ~ReadAhead();
  ReadAhead(const ReadAhead&) = delete;
  ReadAhead& operator=(const ReadAhead&) = delete;

  // The next chunk of bytes, in the source's order, into `out` (which goes back to the reader for
  // reuse); false once the source has ended (at its end or on error: see the source's error()).
  bool next_chunk(RunBatch& out);
  // Runs of `channel` read from now on carry `decoder`'s precheck (nullptr: none), for channels
  // below kPrecheckChannels. Any thread; the reader sees it at its next chunk.
  static constexpr std::size_t kPrecheckChannels = 64;
  // A chunk is prechecked only while at least this many wait in the queue: when reading is the
  // slower side (a capture whose packets cost more to unpack, drivetap's full pcapng), prechecks
  // would hold the caller up, and the reader then leaves them to it, chunk by chunk.
  static constexpr std::size_t kPrecheckAhead = kDepth / 2;
  void precheck_with(ChannelId channel, const ProtocolDecoder* decoder);

 private:
  void run();
  // The prechecks of the chunk's runs whose channel has a decoder named.
  void precheck(RunBatch& chunk);

  ByteSource& source_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<RunBatch> full_;    // read, in order
  std::vector<RunBatch> spare_;  // handed back, for the reader to fill again
  bool ended_ = false;           // the reader has read its last chunk
  bool stop_ = false;            // the caller wants no more
  const std::size_t precheck_ahead_;
  std::array<std::atomic<const ProtocolDecoder*>, kPrecheckChannels> prechecking_{};
  std::thread thread_;
};

}  // namespace drivetap
