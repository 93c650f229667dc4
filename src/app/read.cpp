// `drivetap read`: a capture file of any supported format decoded, shown and written as -T, -o and
// -w say (README "Commands").
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <sys/stat.h>

#include <memory>
#include <optional>
#include <string>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/inputs.hpp"
#include "app/outputs.hpp"
#include "app/progress.hpp"
#include "app/stop_signals.hpp"
#include "pipeline/pipeline.hpp"
#include "sinks/time_format.hpp"
#include "sources/read_ahead.hpp"

namespace drivetap::app {
namespace {

// Said once a run: channel names from the input that were escaped or shortened to print.
void say_rewritten_names(const ChannelTable& channels) {
  if (channels.rewritten_names() == 0) return;
  say(
      fmt::format("{} channel name{} not printable UTF-8 or longer than {} bytes: shown escaped or "
                  "shortened (first: {})",
                  channels.rewritten_names(), channels.rewritten_names() == 1 ? " was" : "s were",
                  ChannelTable::kMaxNameBytes, channels.first_rewritten_name()));
}

// Whether a capture whose first byte is at `first` has wall-clock times (ns since the epoch, as
// the pcap of any tool and a live capture) rather than times from its start (a byte log, a logic
// capture, and the pcapng drivetap writes of them): the time is after 2001-09-09, which no run
// from its start reaches.
bool is_wall_clock_time(TimeNs first) {
  return first >= 1'000'000'000 * kNsPerSecond;
}

// A file named on the command line that is a regular file (not "-", a FIFO or a device).
bool is_regular_file(const std::string& path) {
  struct stat st {};
  return path != "-" && ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

int run_read(const CommonOptions& o, const std::string& path) {
  refuse_shared_files({{"input", path}, {"-o", o.output}, {"-w", o.write}});
  InputFile in;
  ChannelTable channels;
  int input_fd = -1;
  std::unique_ptr<ByteSource> source = open_source(o, path, in, channels, &input_fd);
  catch_stop_signals();
  PipelineOptions p = start_source(o, *source);
  p.max_frames = o.count;  // -c
  Outputs out(o, channels, p, /*timed=*/true);
  out.write_on_second_thread();
  Pipeline pipeline(p, channels, out.sink());
  bool clock_set = false;
  Progress progress(o, in.name, input_fd);

  RunBatch batch;
  bool interrupted = false;
  std::uint64_t batches = 0;
  // pcap/pcapng files are read a few chunks ahead on a second thread (no findings; a regular
  // file cannot block the reader for ever); other sources batch by batch on this one.
  std::optional<ReadAhead> ahead;
  if ((in.format == InputFormat::pcapng || in.format == InputFormat::pcap) && is_regular_file(path))
    ahead.emplace(*source);
  // Each pass decodes one chunk or one batch of the source.
  while (ahead ? ahead->next_chunk(batch) : (batch.clear(), source->append_runs(batch))) {
    // -t r counts from the first byte of a wall-clock capture; the others' clocks start at 0.
    if (!clock_set && !batch.empty()) {
      const bool wall_clock = is_wall_clock_time(batch[0].first);
      out.set_clock(wall_clock, wall_clock ? batch[0].first : 0);
      if (!wall_clock && time_format_is_wall_clock(time_format_of(o)))
        say(
            fmt::format("-t {}: {} has no wall-clock time, only seconds from its start: times "
                        "shown relative",
                        o.time_format, in.name));
      clock_set = true;
    }
    if (!ahead)
      for (const Anomaly& a : source->take_findings()) pipeline.report(a);
    pipeline.push_runs(batch);
    // The reader makes the prechecks the pipeline asks for, by the decoders detected so far.
    if (ahead)
      for (std::size_t c = 0; c < pipeline.channel_count(); ++c)
        ahead->precheck_with(static_cast<ChannelId>(c),
                             pipeline.precheck_decoder_of(static_cast<ChannelId>(c)));
    if (g_stop) {
      interrupted = true;
      break;
    }
    if (o.count > 0 && pipeline.stats().frames >= o.count) break;  // -c: as many as asked
    progress.update(pipeline.stats().frames);
    if (++batches % 256 == 0 && out.unread()) break;
  }
  interrupted = interrupted || g_stop;  // a source may end early, as at its end, when stopped
  ahead.reset();  // the reader thread has stopped: the source is the caller's alone again
  progress.clear();
  // Whatever happened, what was read so far is decoded, summarised, written and flushed.
  pipeline.finish();
  out.close();
  for (const std::string& note : source->notes()) say(note);
  say_rewritten_names(channels);
  const std::string error = source->error();
  source.reset();
  close_input(in);
  if (!error.empty()) die(error, 1);
  if (interrupted) die("interrupted; output flushed", 130);
  return 0;
}

}  // namespace

Command add_read_command(CLI::App& app) {
  return add_file_command(
      app, "read", "Decode a capture: pcapng, pcap, byte log, sigrok session or VCD; '-' for stdin",
      "Capture file", run_read);
}

}  // namespace drivetap::app
