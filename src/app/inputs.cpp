// drivetap command line: capture files as sources (src/app/inputs.hpp).
#include "app/inputs.hpp"

#include <fmt/format.h>

#include <sys/stat.h>

#include <cstdio>
#include <optional>

#include "app/progress.hpp"
#include "app/stop_signals.hpp"
#include "pipeline/options.hpp"
#include "pipeline/pipeline.hpp"
#include "sources/file/byte_log.hpp"
#include "sources/file/capture_reader.hpp"
#include "sources/logic/logic_source.hpp"
#include "sources/logic/sigrok_file.hpp"
#include "sources/logic/vcd_file.hpp"
#include "sources/read_ahead.hpp"

namespace drivetap::app {
namespace {

// -s and --invert for a logic capture: given settings are used as given; without -s the line is
// detected (and --invert alone is refused: detection finds the polarity itself).
LogicSourceOptions logic_source_options(const CommonOptions& o) {
  LogicSourceOptions so;
  so.channels = o.logic_channels;
  if (!o.serial.empty()) {
    const PipelineOptions line = make_pipeline_options(o, RunSettings{});
    so.uart = phy::UartSettings::from(line.serial);
    so.uart->inverted = o.invert;
  } else if (o.invert) {
    die("--invert: give the line settings too (-s \"19200 8E1\"), or neither: both are detected");
  }
  return so;
}

// A file named on the command line that is a regular file (not "-", a FIFO or a device).
bool is_regular_file(const std::string& path) {
  struct stat st {};
  return path != "-" && ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

// Refused after opening: the input closed first (a pipe's stream holds the bytes it sniffed).
[[noreturn]] void refuse(InputFile& in, const std::string& message, int code) {
  close_input(in);
  die(message, code);
}

}  // namespace

// The source for a capture file of any supported format (the format is read from its first bytes).
std::unique_ptr<ByteSource> open_source(const CommonOptions& o, const std::string& path,
                                        InputFile& in, ChannelTable& channels, int* input_fd) {
  std::string err;
  if (!open_input(path, &in, &err)) die(err, 1);
  if (input_fd)
    *input_fd =
        in.format == InputFormat::sigrok || in.format == InputFormat::vcd ? -1 : ::fileno(in.file);
  // Options for logic-analyser captures do nothing for the others: refused (exit 2).
  if (in.format == InputFormat::byte_log || in.format == InputFormat::pcap ||
      in.format == InputFormat::pcapng) {
    const char* logic_option = !o.logic_channels.empty()                           ? "--channels"
                               : o.invert                                          ? "--invert"
                               : o.logic_max != SigrokFile::kDefaultMaxSampleBytes ? "--logic-max"
                                                                                   : nullptr;
    if (logic_option)
      refuse(in,
             fmt::format("{}: only for logic-analyser captures (sigrok, VCD); {} is a {}",
                         logic_option, in.name, input_format_name(in.format)),
             2);
  } else if (in.format == InputFormat::vcd && o.logic_max != SigrokFile::kDefaultMaxSampleBytes) {
    refuse(in, fmt::format("--logic-max: only for sigrok sessions; {} is a VCD", in.name), 2);
  }
  std::unique_ptr<ByteSource> source;
  switch (in.format) {
    case InputFormat::byte_log:
      source = std::make_unique<ByteLogReader>(in.file, in.name, channels);
      break;
    case InputFormat::pcapng:
      source = std::make_unique<CaptureReader>(in.file, in.name, true, channels);
      break;
    case InputFormat::pcap:
      source = std::make_unique<CaptureReader>(in.file, in.name, false, channels);
      in.file = nullptr;  // libpcap owns and closes it
      break;
    case InputFormat::sigrok:
    case InputFormat::vcd: {
      // Logic captures are read by name from a regular file: a zip (libzip) seeks, and detection
      // reads the start of either twice (a pipe or FIFO would give its first bytes only once).
      if (!is_regular_file(path))
        refuse(in,
               fmt::format("{}: a {} must be read from a regular file (it is read twice), not a "
                           "pipe, FIFO or device",
                           in.name, input_format_name(in.format)),
               1);
      const InputFormat format = in.format;
      close_input(in);
      std::string error;
      std::unique_ptr<LogicCapture> file;
      if (format == InputFormat::sigrok) {
        auto sigrok = SigrokFile::open(path, &error);
        if (sigrok) sigrok->set_max_sample_bytes(o.logic_max);
        file = std::move(sigrok);
      } else {
        file = VcdFile::open(path, &error);
      }
      if (!file) die(error, 1);
      source =
          std::make_unique<LogicSource>(std::move(file), path, channels, logic_source_options(o));
      break;
    }
    case InputFormat::empty:
      refuse(in, fmt::format("{}: empty file", in.name), 1);
    case InputFormat::unknown:
      refuse(in,
             fmt::format("{}: offset 0: not a recognised capture format (first byte 0x{:02X}); "
                         "expected pcapng, pcap, a sigrok session, a VCD or a drivetap byte log",
                         in.name, in.head[0]),
             1);
  }
  return source;
}

// Reads the source's header and settles the run's options: the capture's settings, overridden by
// the command line's.
PipelineOptions start_source(const CommonOptions& o, ByteSource& source) {
  source.set_stop_flag(&g_stop);  // reading ahead for detection may take long (catch_stop_signals)
  // Stopped while reading ahead, a source may fail for having seen too little: that is no error.
  const bool header_read = source.read_header();
  if (g_stop) die("interrupted", 130);
  if (!header_read) die(source.error(), 1);
  PipelineOptions p = make_pipeline_options(o, source.settings());
  // (A logic capture's settings are detected or given, and said so by its detection.)
  if (dynamic_cast<const LogicSource*>(&source) == nullptr) {
    const SettingsProvenance from = settings_provenance(source.settings(), o.serial);
    if (!from.contradiction.empty()) say("warning: " + from.contradiction);
  }
  source.set_character_time(p.timing.character_time);
  return p;
}

bool is_wall_clock_time(TimeNs first) {
  return first >= 1'000'000'000 * kNsPerSecond;
}

bool read_capture(const CommonOptions& o, const std::string& path, const InputFile& in,
                  int input_fd, ByteSource& source, Pipeline& pipeline,
                  const CaptureReadHooks& hooks) {
  Progress progress(o, in.name, input_fd);
  RunBatch batch;
  bool interrupted = false;
  bool first_seen = false;
  // pcap/pcapng files are read a few chunks ahead on a second thread (no findings; a regular
  // file cannot block the reader for ever); other sources batch by batch on this one.
  std::optional<ReadAhead> ahead;
  if ((in.format == InputFormat::pcapng || in.format == InputFormat::pcap) && is_regular_file(path))
    ahead.emplace(source);
  // Each pass decodes one chunk or one batch of the source.
  while (ahead ? ahead->next_chunk(batch) : (batch.clear(), source.append_runs(batch))) {
    if (!first_seen && !batch.empty()) {
      first_seen = true;
      if (hooks.first_byte) hooks.first_byte(batch[0].first);
    }
    if (hooks.batch) hooks.batch(batch);
    if (!ahead)
      for (const Anomaly& a : source.take_findings()) pipeline.report(a);
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
    if (hooks.stop && hooks.stop()) break;
    progress.update(pipeline.stats().frames);
  }
  interrupted = interrupted || g_stop;  // a source may end early, as at its end, when stopped
  ahead.reset();  // the reader thread has stopped: the source is the caller's alone again
  progress.clear();
  return interrupted;
}

}  // namespace drivetap::app
