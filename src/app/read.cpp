// `drivetap read`: a capture file of any supported format decoded, shown and written as -T, -o and
// -w say (README "Commands").
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <memory>
#include <string>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "app/inputs.hpp"
#include "app/outputs.hpp"
#include "app/stop_signals.hpp"
#include "pipeline/pipeline.hpp"
#include "sinks/time_format.hpp"

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
  CaptureReadHooks hooks;
  // -t r counts from the first byte of a wall-clock capture; the others' clocks start at 0.
  hooks.first_byte = [&](TimeNs first) {
    const bool wall_clock = is_wall_clock_time(first);
    out.set_clock(wall_clock, wall_clock ? first : 0);
    if (!wall_clock && time_format_is_wall_clock(time_format_of(o)))
      say(
          fmt::format("-t {}: {} has no wall-clock time, only seconds from its start: times shown "
                      "relative",
                      o.time_format, in.name));
  };
  std::uint64_t batches = 0;
  hooks.stop = [&] {
    if (o.count > 0 && pipeline.stats().frames >= o.count) return true;  // -c: as many as asked
    // A failed text output with nothing else to write: the rest would be read for nothing.
    return ++batches % 256 == 0 && out.unread();
  };
  const bool interrupted = read_capture(o, path, in, input_fd, *source, pipeline, hooks);
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
