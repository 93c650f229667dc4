// drivetap command line: the outputs of a run, text or JSON (-T, -o) and a capture file (-w, a
// ring of files with -b), flushed as a live capture runs and closed valid whatever ends the run.
#pragma once

#include <cstdio>
#include <memory>
#include <optional>
#include <vector>

#include "app/common.hpp"
#include "core/byte_event.hpp"
#include "filter/display_filter.hpp"
#include "filter/filter_sink.hpp"
#include "pipeline/options.hpp"
#include "sinks/capture_sink.hpp"
#include "sinks/ring_capture_sink.hpp"
#include "sinks/sink.hpp"
#include "sinks/stats_tables.hpp"
#include "sinks/threaded_sink.hpp"
#include "sinks/time_format.hpp"

namespace drivetap::app {

// The capture file's options for -w (format, link type, the run's settings in each interface).
CaptureSinkOptions capture_options(const CommonOptions& o, const PipelineOptions& p);

// No line per frame (--stats, -q): the summary (or the statistics) alone.
bool summary_only(const CommonOptions& o);

// Owns the output files and the sinks chosen by -T, -o and -w.
class Outputs {
 public:
  // Opens -o and -w (a ring of files with `ring`); `timed`: the records have real times.
  Outputs(const CommonOptions& o, const ChannelTable& channels, const PipelineOptions& p,
          bool timed, const RingOptions* ring = nullptr);
  // From now on the records are formatted and written on a second thread (ThreadedSink) while
  // this one decodes: `read`, when some sink shows or writes every frame (not --stats or
  // --events without -w, whose sinks drop nearly every record: copying them would cost more
  // than it saves).
  void write_on_second_thread();
  // The capture's clock for the text time column (-t): whether its times are wall-clock time, and
  // its start on that clock. Set before the first record reaches the sink.
  void set_clock(bool wall_clock, TimeNs origin);
  // The sink the pipeline writes to; with -Y, the filter in front of the others (made on the
  // first call: after write_on_second_thread(), which also puts a filter in front of outputs
  // that take no records on a thread of its own); with -z, the statistics are counted beside
  // it.
  Sink& sink();
  // Whether nothing written from now on reaches anybody: the text output failed (its reader went
  // away, `| head`) and there is no capture file to complete. Reading on would be wasted.
  [[nodiscard]] bool unread() const { return !capture_ && !ring_ && std::ferror(text_file_); }
  // Live capture: everything written so far reaches its file (a text line per frame as it
  // completes; pcapng packets readable while the capture runs). False when a write failed.
  bool flush();

  // Flushes and closes every output; a failed write (disk full, closed pipe) is an error.
  void close();
  // The -w stream's reader may go away (Wireshark stopping an extcap capture): close() then
  // ends the file quietly, and reader_left() says so.
  void set_reader_may_leave(bool may) { reader_may_leave_ = may; }
  [[nodiscard]] bool reader_left() const { return reader_left_; }

 private:
  const CommonOptions& options_;
  TimeReference clock_;  // the text sinks read it (TextSinkOptions::clock)
  std::FILE* text_file_ = stdout;
  std::FILE* capture_file_ = nullptr;
  int capture_errno_ = 0;  // why the first failed flush failed
  std::unique_ptr<FormattingSink> text_;
  std::vector<std::unique_ptr<FormattingSink>> helpers_;  // text_'s kind, writing into memory
  std::unique_ptr<Sink> events_only_;
  std::unique_ptr<Sink> summary_only_;
  std::unique_ptr<CaptureSink> capture_;
  std::unique_ptr<RingCaptureSink> ring_;
  TeeSink tee_;
  // -z: the statistics' counter, written after the summary by close(); and what hands it the
  // records beside the sink above (made by sink()).
  std::unique_ptr<StatsTablesSink> statistics_;
  std::unique_ptr<BesideSink> beside_;
  long capture_good_size_ = 0;  // the capture file up to its last packet flushed whole
  bool capture_failed_ = false;
  bool reader_may_leave_ = false;
  bool reader_left_ = false;
  // -Y: the compiled filter until sink() puts its sink in front of the others.
  std::optional<DisplayFilter> display_filter_;
  std::unique_ptr<DisplayFilterSink> filter_sink_;
  const ChannelTable& channels_;
  TimeNs character_time_ = 0;
  bool timed_ = true;
  // write_on_second_thread() was called.
  bool second_thread_ = false;
  // Last: destroyed first, their threads joined before the sinks they write to go. -Y where no
  // output takes records (--stats, --events) and the filter decodes every telegram: the filter
  // judges them on a thread of its own.
  std::unique_ptr<ThreadedSink> threaded_;
  std::unique_ptr<ThreadedSink> filter_thread_;
};

}  // namespace drivetap::app
