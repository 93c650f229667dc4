// drivetap command line: opening a capture file of any supported format as a source, the run's
// options settled from its header and the command line, and the capture read into a pipeline.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "app/common.hpp"
#include "core/byte_event.hpp"
#include "pipeline/options.hpp"
#include "sources/input_file.hpp"
#include "sources/source.hpp"

namespace drivetap {
class Pipeline;
}

namespace drivetap::app {

// The source for a capture file of any supported format (the format is read from its first bytes).
// `input_fd`, when given: the descriptor the source reads from (-1 for a logic capture, read by
// name), for the progress line.
std::unique_ptr<ByteSource> open_source(const CommonOptions& o, const std::string& path,
                                        InputFile& in, ChannelTable& channels,
                                        int* input_fd = nullptr);

// Reads the source's header and settles the run's options: the capture's settings, overridden by
// the command line's.
PipelineOptions start_source(const CommonOptions& o, ByteSource& source);

// Whether a capture whose first byte is at `first` has wall-clock times (ns since the epoch, as
// the pcap of any tool and a live capture) rather than times from its start (a byte log, a logic
// capture, and the pcapng drivetap writes of them): the time is after 2001-09-09, which no run
// from its start reaches.
bool is_wall_clock_time(TimeNs first);

// What a command does beside decoding while read_capture() reads, each optional.
struct CaptureReadHooks {
  // Once, before the first byte is decoded, with its time.
  std::function<void(TimeNs first)> first_byte;
  // Each batch of runs, before it is decoded.
  std::function<void(const RunBatch& batch)> batch;
  // After each batch is decoded: true stops reading before the source's end.
  std::function<bool()> stop;
};

// Decodes `source`, opened from `path` as `in` (open_source(), which gave `input_fd`), into
// `pipeline` batch by batch until its end, a stop signal (g_stop) or hooks.stop, with the progress
// line. Returns whether a stop signal ended it; the pipeline is left to finish.
bool read_capture(const CommonOptions& o, const std::string& path, const InputFile& in,
                  int input_fd, ByteSource& source, Pipeline& pipeline,
                  const CaptureReadHooks& hooks);

}  // namespace drivetap::app
