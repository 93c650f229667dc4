// drivetap command line: the outputs of a run (src/app/outputs.hpp).
#include "app/outputs.hpp"

#include <fmt/format.h>

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "app/stop_signals.hpp"
#include "formats/shared_libraries.hpp"
#include "sinks/fields_sink.hpp"
#include "sinks/json_sink.hpp"
#include "sinks/text_sink.hpp"
#include "sources/file/capture_reader.hpp"

namespace drivetap::app {

// No line per frame: --stats, or -q (tshark's: with -z statistics, those alone; without, the
// summary).
bool summary_only(const CommonOptions& o) {
  return o.stats_only || o.quiet;
}

CaptureSinkOptions capture_options(const CommonOptions& o, const PipelineOptions& p) {
  if (o.plain && o.classic_pcap)
    die("--plain: only with pcapng (classic pcap has no comments or per-byte times to leave out)");
  if (o.classic_pcap && !pcap_library().loaded)
    die(fmt::format("--pcap: {}", pcap_library().error));
  CaptureSinkOptions c;
  c.format = o.classic_pcap ? CaptureFormat::pcap : CaptureFormat::pcapng;
  c.link_type = o.dlt == "user0" ? CaptureLinkType::user0 : CaptureLinkType::upper_pdu;
  c.plain = o.plain;
  c.serial = p.serial;
  c.character_time = p.timing.character_time;
  c.settings = encode_settings(p.timing.t15, p.timing.t35, p.reply_timeout, p.max_hold, p.protocol);
  return c;
}

Outputs::Outputs(const CommonOptions& o, const ChannelTable& channels, const PipelineOptions& p,
                 bool timed, const RingOptions* ring)
    : options_(o), channels_(channels), character_time_(p.timing.character_time), timed_(timed) {
  // --dlt user0 with a protocol given that Wireshark has no dissector for at link type 147:
  // refused before any file is made (a detected one at its first telegram: CaptureSink::refusal).
  if (!o.write.empty() && o.dlt == "user0" && p.protocol.desc() &&
      !p.protocol.desc()->wireshark_builtin)
    die(
        fmt::format("--dlt user0: the bus speaks {}, which Wireshark has no dissector for at link "
                    "type 147; write without --dlt (upper-PDU, drivetap's plugin decodes it)",
                    protocol_label(p.protocol)));
  // A bad filter or field list stops the run before any file is made.
  std::string error;
  if (!o.display_filter.empty()) {
    display_filter_ = DisplayFilter::compile(o.display_filter, &error);
    if (!display_filter_) die("-Y: " + error);
  }
  std::optional<FieldsOptions> fields;
  if (o.format == "fields") {
    fields = parse_fields_options(o.fields, o.field_options, &error);
    if (!fields) die(error);
    // `t` as the text time column shows it when -t is given; as the JSON has it otherwise.
    if (!o.time_format.empty()) {
      fields->time_format = time_format_of(o);
      fields->clock = &clock_;
    }
  } else if (!o.fields.empty() || !o.field_options.empty()) {
    die(fmt::format("{}: only with -T fields", o.fields.empty() ? "-E" : "-e"));
  }
  const bool capture_to_stdout = o.write == "-";
  if (o.plain && o.write.empty()) die("--plain: only with -w FILE (it is a kind of pcapng)");
  if (capture_to_stdout && (o.output.empty() || o.output == "-") && o.format == "json")
    die("-w - and JSON output cannot share stdout: add -o FILE for the JSON");
  if (!o.output.empty() && o.output != "-") {
    text_file_ = open_output_file(o.output);
    if (!text_file_) die(fmt::format("-o {}: cannot create: {}", o.output, std::strerror(errno)));
  } else {
    // With the capture on stdout, the text goes to stderr as a summary only (like tcpdump).
    text_file_ = capture_to_stdout ? stderr : stdout;
  }
  if (ring) {
    if (o.write.empty() || capture_to_stdout) die("-b: needs -w FILE (a file name, not -)");
    ring_ = std::make_unique<RingCaptureSink>(o.write, channels, capture_options(o, p), *ring);
    std::string error;
    if (!ring_->open(&error)) die(error, 1);
    tee_.add(ring_.get());
  } else if (!o.write.empty()) {
    capture_file_ = capture_to_stdout ? stdout : open_output_file(o.write);
    if (!capture_file_) die(fmt::format("-w {}: cannot create: {}", o.write, std::strerror(errno)));
    capture_ = std::make_unique<CaptureSink>(capture_file_, channels, capture_options(o, p));
    tee_.add(capture_.get());
  }
  // The text or JSON sink; with no file, one of its helpers (writing into memory).
  const auto make_text = [&](std::FILE* file) -> std::unique_ptr<FormattingSink> {
    if (o.format == "json")
      return std::make_unique<JsonSink>(file, channels, p.timing.character_time, timed);
    if (fields)
      return std::make_unique<FieldsSink>(file, *fields, channels, p.timing.character_time, timed);
    TextSinkOptions t;
    t.verbose = o.verbose;
    t.show_time = timed;
    t.summary = !o.no_summary;
    t.frames = !(capture_to_stdout && text_file_ == stderr);
    t.time_format = time_format_of(o);
    t.clock = &clock_;
    t.color = color_wanted(o, text_file_);
    t.hex_dump = o.hex_dump;
    return std::make_unique<TextSink>(file, channels, t);
  };
  text_ = make_text(text_file_);
  // Text or JSON alone, to a file or a pipe, is formatted a batch at a time by as many threads
  // as there are cores, the decoding thread among them when it is ahead (ThreadedSink helpers),
  // and written in order: formatting is most of a run's work. A terminal gets each line as it
  // comes from the one writer; a capture file has its own order of blocks to keep.
  const unsigned cores = std::thread::hardware_concurrency();
  // (-t d and dd: each line's time depends on the line before it, formatted by one sink only.)
  const TimeFormat time_format = time_format_of(o);
  const bool time_from_previous =
      time_format == TimeFormat::delta || time_format == TimeFormat::delta_displayed;
  if (!ring && o.write.empty() && !summary_only(o) && !fields && !o.events_only && cores >= 2 &&
      !time_from_previous && ::isatty(::fileno(text_file_)) != 1)
    for (unsigned i = 0; i < std::min(cores, 4u); ++i) helpers_.push_back(make_text(nullptr));
  if (o.stats_only && o.no_summary && o.statistics.empty())
    die("--stats and --no-summary leave nothing to print");
  if (o.quiet && o.no_summary) die("-q and --no-summary leave nothing to print");
  if (o.quiet && !o.statistics.empty()) {
    // -q -z: the statistics alone, as tshark -q -z prints them.
  } else if (summary_only(o)) {
    summary_only_ = std::make_unique<SummaryOnlySink>(*text_);
    tee_.add(summary_only_.get());
  } else if (o.events_only) {
    events_only_ = std::make_unique<EventsOnlySink>(*text_);
    tee_.add(events_only_.get());
  } else {
    tee_.add(text_.get());
  }
  if (!o.statistics.empty()) {
    std::vector<StatisticRequest> requests;
    std::string error;
    for (const std::string& spec : o.statistics) {
      const std::optional<StatisticRequest> r = parse_statistic(spec, &error);
      if (!r) die(error);
      requests.push_back(*r);
    }
    statistics_ = std::make_unique<StatsTablesSink>(channels, p.timing, timed, std::move(requests));
  }
}

void Outputs::set_clock(bool wall_clock, TimeNs origin) {
  clock_.wall_clock = wall_clock;
  clock_.origin = origin;
}

void Outputs::write_on_second_thread() {
  second_thread_ = true;
  if (!helpers_.empty()) {
    std::vector<FormattingSink*> helpers;
    for (const std::unique_ptr<FormattingSink>& helper : helpers_) helpers.push_back(helper.get());
    threaded_ = std::make_unique<ThreadedSink>(*text_, std::move(helpers));  // (tee_: text_)
  } else if ((!summary_only(options_) && !options_.events_only) || capture_) {
    threaded_ = std::make_unique<ThreadedSink>(tee_);
  }
}

Sink& Outputs::sink() {
  Sink& inner = threaded_ ? static_cast<Sink&>(*threaded_) : tee_;
  if (display_filter_ && !filter_sink_) {
    filter_sink_ = std::make_unique<DisplayFilterSink>(std::move(*display_filter_), inner,
                                                       channels_, character_time_, timed_);
    // A filter that decodes every telegram, where no output takes records (--stats, --events):
    // the decoding would be most of the decoding thread's work, so the records go to a second
    // core, where the filter judges them in order. (A filter that decodes some telegrams, or
    // none, costs less on the decoding thread than the records' copies; with -q -z nothing
    // reads what it selects.)
    if (second_thread_ && !inner.needs().records && !tee_.empty() &&
        filter_sink_->decodes_every_telegram() && std::thread::hardware_concurrency() >= 2)
      filter_thread_ = std::make_unique<ThreadedSink>(*filter_sink_);
  }
  Sink& shown = filter_thread_ ? static_cast<Sink&>(*filter_thread_)
                : filter_sink_ ? static_cast<Sink&>(*filter_sink_)
                               : inner;
  // -z counts every record, as the summary does (tshark's taps see every packet; -Y only
  // selects what is shown).
  if (!statistics_) return shown;
  if (!beside_ || &beside_->main() != &shown)
    beside_ = std::make_unique<BesideSink>(shown, *statistics_);
  return *beside_;
}

bool Outputs::flush() {
  const bool ok = filter_thread_ ? filter_thread_->flush()
                  : threaded_    ? threaded_->flush()
                                 : tee_.flush();
  if (!ok && ring_ && !ring_->error().empty()) die(ring_->error(), 1);
  if (capture_file_ && capture_file_ != stdout) {
    if (ok) {
      capture_good_size_ = std::ftell(capture_file_);
    } else if (!capture_failed_) {
      capture_failed_ = true;
      capture_errno_ = errno;
    }
  }
  return ok;
}

void Outputs::close() {
  // Every record replayed; the sinks are this thread's.
  if (filter_thread_) filter_thread_->finish();
  if (threaded_) threaded_->finish();
  // -z: the tables after everything else, the summary included (as tshark prints them).
  if (statistics_)
    statistics_->write_tables(options_.format == "json",
                              [this](std::string_view part) { text_->write_formatted(part); });
  // Each failure's errno is kept where it happens: cutting the file back and closing it
  // overwrite errno, and the message must give the write's own reason ("No space left").
  const bool text_ok = text_->flush();
  const int text_errno = errno;
  const bool capture_ok = !capture_failed_ && (!capture_ || capture_->flush());
  const int capture_errno = capture_failed_ ? capture_errno_ : errno;
  std::string refusal = capture_ ? capture_->refusal() : std::string();
  if (ring_ && !ring_->refusal().empty()) {
    const std::string ring_refusal = ring_->refusal();
    ring_->close();
    die(ring_refusal);  // what was written before it stays, whole
  }
  if (ring_ && !ring_->close()) die(ring_->error(), 1);
  capture_.reset();
  // A failed write (disk full) leaves the file cut back to its last whole block: valid, with
  // every packet that reached the disk.
  if (!capture_ok && capture_file_ && capture_file_ != stdout)
    cut_back_to(capture_file_, capture_good_size_,
                options_.classic_pcap ? CaptureFormat::pcap : CaptureFormat::pcapng);
  const bool capture_closed =
      !capture_file_ || capture_file_ == stdout || std::fclose(capture_file_) == 0;
  if (!capture_ok && reader_may_leave_ && capture_errno == EPIPE) reader_left_ = true;
  if (reader_left_) return;
  if (!refusal.empty()) die(refusal);  // what was written before it stays, whole
  if (!capture_ok)
    die(fmt::format("-w {}: write failed: {}", options_.write, std::strerror(capture_errno)), 1);
  if (!capture_closed)
    die(fmt::format("-w {}: write failed: {}", options_.write, std::strerror(errno)), 1);
  const bool to_file = text_file_ != stdout && text_file_ != stderr;
  const std::string text_name = to_file                ? "-o " + options_.output
                                : text_file_ == stdout ? std::string("standard output")
                                                       : std::string("standard error");
  if (!text_ok) {
    // Half a line (half a JSON record) would mislead whoever reads the file: cut it off.
    if (to_file) cut_back_to_last_line(text_file_);
    if (!to_file && text_errno == EPIPE) std::_Exit(128 + SIGPIPE);  // `| head`: as SIGPIPE
    if (g_stop && text_errno == EINTR)
      die(fmt::format("interrupted; {} blocked (nobody read it): the rest of its output is lost",
                      text_name),
          130);
    die(fmt::format("{}: write failed: {}", text_name, std::strerror(text_errno)), 1);
  }
  if (to_file && std::fclose(text_file_) != 0)
    die(fmt::format("{}: write failed: {}", text_name, std::strerror(errno)), 1);
}
}  // namespace drivetap::app
